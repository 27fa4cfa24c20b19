"""Dormant compliant walls (``SimConfig(dormant_walls=True)``) against awake ones, measured.

The paper's banded colon robot (20 mm, 0.8 m, 3 x 10% bands at 250/300/350 mm) grows at a
constant command into the default colon phantom for 12 s; the command is perturbed by a
relative ``eps`` to show how much the stall position moves with round-off-sized changes,
with and without dormant walls.  Prints the stall length (mm), whether it stalled, the peak
tip contact force (N) and the wall time (s, one core, the two settings alternating).

    python -m evertgym.bench.dormant [--pressure-kpa 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

from evertgym.design import Band, TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim, SimConfig

EPS = (0.0, 1e-9, 1e-6, 1e-3)


def run(dormant: bool, eps: float, pressure_kpa: float, sim_s: float = 12.0) -> dict:
    scene = make_scene({"family": "colon", "params": {}})
    design = TubeDesign(diameter_m=0.02, length_m=0.8, bands=tuple(Band(p, 0.1) for p in (0.25, 0.3, 0.35)))
    sim = EversionSim(design, scene=scene, config=SimConfig(engine="dynamic", dormant_walls=dormant))
    sim.set_pressure_command(pressure_kpa * 1e3 * (1 + eps))
    t0 = time.perf_counter()
    sim.run(sim_s)
    wall = time.perf_counter() - t0
    return {"dormant_walls": dormant, "eps": eps, "length_mm": round(sim.length * 1e3, 2), "stalled": sim.stalled,
            "max_contact_force_n": round(sim.max_contact_force, 3), "wall_s": round(wall, 3)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m evertgym.bench.dormant", description=__doc__.splitlines()[0])
    ap.add_argument("--pressure-kpa", type=float, default=3.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not 0.0 < args.pressure_kpa <= 8.0:
        ap.error(f"--pressure-kpa = {args.pressure_kpa} is out of range: allowed (0, 8]")
    rows = [run(d, eps, args.pressure_kpa) for eps in EPS for d in (False, True)]
    if args.json:
        print(json.dumps(rows))
        return
    print(f"banded colon robot, {args.pressure_kpa:g} kPa for 12 s")
    print(f"{'eps':>7s} {'dormant':>8s} {'length_mm':>10s} {'stalled':>8s} {'max_F_N':>8s} {'wall_s':>7s}")
    for r in rows:
        print(f"{r['eps']:>7g} {str(r['dormant_walls']):>8s} {r['length_mm']:>10.2f} {str(r['stalled']):>8s} "
              f"{r['max_contact_force_n']:>8.3f} {r['wall_s']:>7.2f}")


if __name__ == "__main__":
    main()
