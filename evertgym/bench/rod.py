"""Time per solve of the Cosserat shooting solver on the paper's tensile-test designs (``evertgym bench rod``)."""

from __future__ import annotations

import statistics
import time

from evertgym.model.stiffness import paper_prototype, tensile_rod

#: (name, band positions from the tip in mm, reduction) of the timed designs
CASES: tuple[tuple[str, tuple[float, ...], float], ...] = (
    ("no bands", (), 0.0),
    ("50% @ 50 mm", (50,), 0.5),
    ("50% @ 50,100,150,200 mm", (50, 100, 150, 200), 0.5),
    ("10% @ 100 mm", (100,), 0.1),
)


def bench_rod(repeats: int = 5, displacements_mm: tuple[float, ...] = (20.0, 60.0)) -> list[dict]:
    """Per design and tip displacement: the median and least wall time (ms) of one displacement-controlled
    solve (two-unknown shooting, DOP853 at rtol 1e-10) over ``repeats``, and the stiffness it gives (N/m)."""
    if not (isinstance(repeats, int) and repeats >= 1):
        raise ValueError(f"repeats = {repeats!r} is out of range: allowed integers >= 1")
    rows = []
    for name, bands, red in CASES:
        for disp_mm in displacements_mm:
            times, k = [], 0.0
            for _ in range(repeats):
                rod = tensile_rod(paper_prototype(bands, red))
                t0 = time.perf_counter()
                sol = rod.solve_lateral_displacement(disp_mm / 1e3)
                times.append(time.perf_counter() - t0)
                k = float(sol.force[1] / (disp_mm / 1e3))
            rows.append({"design": name, "displacement_mm": disp_mm, "median_ms": 1e3 * statistics.median(times),
                         "min_ms": 1e3 * min(times), "k_n_per_m": k})
    return rows


def format_rod(rows: list[dict]) -> list[str]:
    lines = [f"{'design':28s} {'displacement_mm':>15s} {'median_ms':>10s} {'min_ms':>8s} {'k_n_per_m':>10s}"]
    for r in rows:
        lines.append(f"{r['design']:28s} {r['displacement_mm']:>15.0f} {r['median_ms']:>10.1f} {r['min_ms']:>8.1f} {r['k_n_per_m']:>10.3f}")
    return lines
