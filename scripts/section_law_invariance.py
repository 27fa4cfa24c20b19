"""Do the section law's U-bend outcomes move with the numerical knobs?

Runs the paper's U-bend trials (12 per cell, its randomisation, 3 kPa) under
``SimConfig(section_law=True)`` with the given section-law parameters, for the reference
settings and with ``mass_ratio`` 0.1 and 0.003, ``inertia_factor`` 10 and the step halved,
one knob at a time, and prints the passes per cell and the largest change against the
reference (the criterion: at most 2 of 12).  Stores under ``--out`` make a
killed run resume::

    python scripts/section_law_invariance.py --casing-friction 2.4 --bend-loss 0.6
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from evertgym.experiments.paper import ubend_specs
from evertgym.experiments.trial import run_trial
from evertgym.scoring.runner import run_trials
from evertgym.scoring.store import ResultStore

KNOBS = (("reference", {}), ("mass_ratio=0.1", {"mass_ratio": 0.1}), ("mass_ratio=0.003", {"mass_ratio": 0.003}),
         ("inertia_factor=10", {"inertia_factor": 10.0}), ("dt_s=0.001", {"dt_s": 0.001}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--casing-friction", type=float, default=2.4, help="U-bend casing friction factor")
    ap.add_argument("--bend-loss", type=float, default=0.6, help="the tail's capstan coefficient (1/rad)")
    ap.add_argument("--tail", type=float, default=1.0, help="tail drag fraction of the bare threshold")
    ap.add_argument("--radii", default="35,30,25", help="inner radii (mm)")
    ap.add_argument("--reductions", default="0,0.1", help="band reductions (0: no bands)")
    ap.add_argument("--trials", type=int, default=12)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--sim", default="{}", help="further SimConfig overrides as JSON (every setting)")
    ap.add_argument("--out", default="runs/section_law_invariance")
    args = ap.parse_args()
    radii = [float(r) for r in args.radii.split(",")]
    reds = [float(r) for r in args.reductions.split(",")]
    base = {"engine": "dynamic", "section_law": True, "bend_loss_per_rad": args.bend_loss, "tail_drag_fraction": args.tail, **json.loads(args.sim)}
    cells: dict[str, dict[tuple[float, float], int]] = {}
    for name, knob in KNOBS:
        t0 = time.perf_counter()
        specs = ubend_specs(args.trials, radii=radii, reductions=reds, sim={**base, **knob},
                            scene_params={"wall_friction": args.casing_friction})
        with ResultStore(Path(args.out) / f"{name}.sqlite") as store:
            records = run_trials(specs, run_trial, store, backend="process", workers=args.workers, progress=False)
        cell: dict[tuple[float, float], int] = {(red, r): 0 for red in reds for r in radii}
        for rec in records:
            red = rec.spec.design["bands"][0]["reduction"] if rec.spec.design["bands"] else 0.0
            cell[(red, float(rec.spec.scene["params"]["radius_mm"]))] += bool(rec.result["success"])
        cells[name] = cell
        print(f"{name}: done in {time.perf_counter() - t0:.0f} s", flush=True)
    ref = cells["reference"]
    head = [f"{'no bands' if red == 0 else f'{round(red * 100)}%'} {r:g}" for red in reds for r in radii]
    print(f"\nsection law, casing {args.casing_friction:g}, mu_b {args.bend_loss:g}, f_tail {args.tail:g}, {args.sim}; "
          f"passes of {args.trials}")
    print("| setting | " + " | ".join(head) + " | largest change |")
    print("|---|" + "---:|" * (len(head) + 1))
    for name, _ in KNOBS:
        c = cells[name]
        worst = max(abs(c[k] - ref[k]) for k in ref)
        print(f"| {name} | " + " | ".join(str(c[k]) for k in ref) + f" | {worst} |")


if __name__ == "__main__":
    main()
