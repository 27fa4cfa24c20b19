"""Invariance harness: do the answers move with the simulator's numerical knobs?

For the reference (SimConfig defaults) and one knob at a time (``mass_ratio`` 0.003 and 0.1,
``inertia_factor`` 10, ``dt_s`` halved to 0.001) runs ``reproduce ubend`` (every design and
radius), ``reproduce colon`` and the operator baseline on 50 held-out Colon-v0 episodes, and
prints per setting the largest per-cell change of U-bend successes, whether the colon
outcomes change and the operator's success rate and its change; then the U-bend pass table
per setting.  Each setting keeps its own stores under ``--out``, so a killed run resumes;
start from an empty ``--out`` after a change to the physics.

    python scripts/invariance.py                                   # full size: 30+ min on 2 cores
    python scripts/invariance.py --trials 1 --episodes 2 --radii 40,20 --out runs/invariance_tiny
    python scripts/invariance.py --engine quasistatic --out runs/invariance_qs   # its own settings and criteria
    python scripts/invariance.py --engine quasistatic --sim '{"linear_solver": "semiseparable"}' --out runs/invariance_semi
                                                   # the same, every setting on top of these SimConfig fields
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from evertgym.experiments.invariance import (  # noqa: E402
    CRITERIA,
    QUASISTATIC_CRITERIA,
    QUASISTATIC_SETTINGS,
    SETTINGS,
    format_table,
    run_invariance,
    ubend_table,
)
from evertgym.experiments.paper import UBEND_RADII_MM  # noqa: E402
from evertgym.sim.config import parse_sim  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/invariance", help="results folder (one sub-folder of stores per setting)")
    ap.add_argument("--trials", type=int, default=12, help="U-bend trials per design and radius")
    ap.add_argument("--episodes", type=int, default=50, help="held-out Colon-v0 episodes of the operator baseline")
    ap.add_argument("--radii", default=",".join(f"{r:g}" for r in UBEND_RADII_MM), help="U-bend inner radii (mm); default all")
    ap.add_argument("--settings", default="", help="comma-separated setting names (default all; the reference is always run): "
                    + ", ".join(n for n, _ in SETTINGS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--progress", action="store_true", help="progress bars on stderr")
    ap.add_argument("--json", action="store_true", help="print the result as JSON instead of tables")
    ap.add_argument("--engine", choices=["dynamic", "quasistatic"], default="dynamic",
                    help="the engine whose numerical settings are varied (its own settings and criteria)")
    ap.add_argument("--sim", default="", help="SimConfig fields as JSON under every setting, the reference included "
                    "(e.g. '{\"linear_solver\": \"semiseparable\"}')")
    args = ap.parse_args(argv)
    all_settings, criteria = (QUASISTATIC_SETTINGS, QUASISTATIC_CRITERIA) if args.engine == "quasistatic" else (SETTINGS, CRITERIA)
    radii = tuple(float(r) for r in args.radii.split(",") if r)
    wanted = {s for s in args.settings.split(",") if s}
    unknown = wanted - {n for n, _ in all_settings}
    if unknown:
        ap.error(f"unknown settings {sorted(unknown)}: allowed {[n for n, _ in all_settings]}")
    settings = tuple(s for i, s in enumerate(all_settings) if i == 0 or not wanted or s[0] in wanted)
    if args.sim:
        try:
            settings = tuple((name, parse_sim(args.sim, sim)) for name, sim in settings)
        except ValueError as e:
            ap.exit(2, f"--sim: {e}\n")
    t0 = time.perf_counter()
    result = run_invariance(args.out, trials=args.trials, episodes=args.episodes, radii=radii, settings=settings,
                            workers=args.workers, progress=args.progress, criteria=criteria)
    result["wall_s"] = time.perf_counter() - t0
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(format_table(result))
        print()
        print("U-bend passes per setting:")
        print(ubend_table(result))
        for name, sv in result["solves"].items():
            if sv.get("solves"):
                print(f"{name}: {sv['solves']} equilibrium solves over the U-bend table, {sv['solve_failures']} ended above the "
                      f"tolerance ({100 * sv['failure_share']:.3f}%)")
        print(f"\n({result['wall_s']:.0f} s; stores in {args.out})")
    return result


if __name__ == "__main__":
    main()
