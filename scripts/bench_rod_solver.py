#!/usr/bin/env python
"""Time per case of the Cosserat shooting solver (the paper's tensile test designs).

    python scripts/bench_rod_solver.py [--repeats 5]

Prints, per design and tip displacement, the median wall time of one displacement-
controlled solve (two-unknown shooting, DOP853 at rtol 1e-10) on this machine.
"""

import argparse
import statistics
import time

from evertgym.model.stiffness import paper_prototype, tensile_rod

CASES = [
    ("no bands", (), 0.0),
    ("50% @ 50 mm", (50,), 0.5),
    ("50% @ 50,100,150,200 mm", (50, 100, 150, 200), 0.5),
    ("10% @ 100 mm", (100,), 0.1),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"{'design':28s} {'displacement_mm':>15s} {'median_ms':>10s} {'min_ms':>8s} {'k_n_per_m':>10s}")
    for name, bands, red in CASES:
        for disp_mm in (20.0, 60.0):
            times, k = [], None
            for _ in range(args.repeats):
                rod = tensile_rod(paper_prototype(bands, red))
                t0 = time.perf_counter()
                sol = rod.solve_lateral_displacement(disp_mm / 1e3)
                times.append(time.perf_counter() - t0)
                k = sol.force[1] / (disp_mm / 1e3)
            print(f"{name:28s} {disp_mm:>15.0f} {1e3 * statistics.median(times):>10.1f} {1e3 * min(times):>8.1f} {k:>10.3f}")


if __name__ == "__main__":
    main()
