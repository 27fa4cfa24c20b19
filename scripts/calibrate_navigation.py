"""Fit the navigation parameters nothing else constrains on the paper's no-band U-bend rows only.

Casing friction factor, the tail's capstan coefficient and the tail's share of the eversion
threshold, under the section law (:mod:`evertgym.experiments.navigation_fit`); writes
``evertgym/data/navigation_fit.json`` with the grid, the best point and how each no-band cell
moves with +-0.05 of each parameter.
Every candidate has its own store under ``--out``, so a killed fit resumes::

    python scripts/calibrate_navigation.py                  # the grid below, 12 trials per cell
    python scripts/calibrate_navigation.py --no-write       # print only
"""

from __future__ import annotations

import argparse
import json

from evertgym.experiments.navigation_fit import PARAMETERS, fit, sensitivity, write_params


def _floats(text: str) -> list[float]:
    return [float(x) for x in text.split(",")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--friction", type=_floats, default=[1.6, 1.8, 2.0, 2.2], help="casing friction factors to try")
    ap.add_argument("--bend-loss", type=_floats, default=[0.4, 0.6, 0.8], help="capstan coefficients (1/rad) to try")
    ap.add_argument("--tail", type=_floats, default=[0.5, 1.0], help="tail drag fractions to try")
    ap.add_argument("--trials", type=int, default=12, help="trials per radius (the paper's 12)")
    ap.add_argument("--workers", type=int, default=None, help="worker processes (default: the CPUs)")
    ap.add_argument("--out", default="runs/calibrate_navigation", help="folder of the per-candidate stores")
    ap.add_argument("--no-write", action="store_true", help="do not rewrite evertgym/data/navigation_fit.json")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args()
    grid = {"casing_friction_factor": args.friction, "bend_loss_per_rad": args.bend_loss, "tail_drag_fraction": args.tail}
    result = fit(grid, args.out, args.trials, workers=args.workers)
    sens = sensitivity(result["best"], args.out, args.trials, workers=args.workers)
    if args.json:
        print(json.dumps({"fit": result, "sensitivity": sens}, indent=2))
    else:
        radii = [f"{r:g}" for r in result["radii_mm"]]
        print("| " + " | ".join(PARAMETERS) + " | " + " | ".join(f"{r} mm" for r in radii) + " | NLL |")
        print("|" + "---|" * (len(PARAMETERS) + len(radii) + 1))
        for r in result["rows"]:
            print("| " + " | ".join(f"{r[n]:g}" for n in PARAMETERS) + " | "
                  + " | ".join(f"{r['passes'][x]}/{result['trials']}" for x in radii) + f" | {r['nll']:.1f} |")
        print("\nsensitivity of the best point (no-band passes per radius):")
        for s in sens:
            print(f"  {s['parameter']} {s['delta']:+.2f}: " + " ".join(f"{x}:{s['passes'][x]}" for x in radii))
    if not args.no_write:
        print(f"wrote {write_params(result, sens)}")


if __name__ == "__main__":
    main()
