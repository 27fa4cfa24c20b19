"""Does the colon stall move with a round-off-sized change of the pressure command?  Both engines.

A robot grows at a constant command into the default colon phantom (compliant walls); the
command is perturbed by a relative ``eps`` in (0, 1e-9, 1e-6, 1e-3).  Robots: the bare 20 mm
robot (0.8 m) for 6 s and the paper's banded colon robot (3 x 10% bands at 250/300/350 mm) for
12 s.  Prints, per engine, robot and ``eps``, the length where it stopped (mm), whether it
stalled, the move against ``eps = 0`` (mm), the quasi-static engine's solves and solves above the
tolerance, and the wall time (s, one process).  Issue 25 asks for less than 0.1 mm at 1e-9.

    python scripts/command_sensitivity.py [--pressure-kpa 3] [--engines quasistatic,dynamic] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

from evertgym.design import Band, TubeDesign
from evertgym.scenes import SceneSpec, make_scene
from evertgym.sim import EversionSim, SimConfig
from evertgym.sim.config import ENGINES

EPS = (0.0, 1e-9, 1e-6, 1e-3)
#: (name, bands at (m), seconds of growth)
ROBOTS = (("bare", (), 6.0), ("3 x 10%", (0.25, 0.3, 0.35), 12.0))


def run(engine: str, bands: tuple[float, ...], sim_s: float, eps: float, pressure_kpa: float) -> dict:
    """One constant-command run; its stop length (mm), stall and solve counts."""
    design = TubeDesign(diameter_m=0.02, length_m=0.8, bands=tuple(Band(p, 0.1) for p in bands))
    sim = EversionSim(design, scene=make_scene(SceneSpec("colon", {}, 0)), config=SimConfig(engine=engine))
    sim.set_pressure_command(pressure_kpa * 1e3 * (1 + eps))
    t0 = time.perf_counter()
    sim.run(sim_s)
    stats = getattr(sim, "solve_stats", {})
    return {"length_mm": round(sim.length * 1e3, 4), "stalled": bool(sim.stalled), "solves": stats.get("solves"),
            "solve_failures": stats.get("solve_failures"), "wall_s": round(time.perf_counter() - t0, 2)}


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pressure-kpa", type=float, default=3.0)
    ap.add_argument("--engines", default="quasistatic,dynamic", help="comma-separated: quasistatic, dynamic")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not 0.0 < args.pressure_kpa <= 8.0:
        ap.error(f"--pressure-kpa = {args.pressure_kpa} is out of range: allowed (0, 8]")
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    bad = [e for e in engines if e not in ENGINES]
    if bad or not engines:
        ap.error(f"--engines = {args.engines!r} is out of range: allowed a comma-separated subset of {', '.join(ENGINES)}")
    rows = []
    for engine in engines:
        for name, bands, sim_s in ROBOTS:
            ref = None
            for eps in EPS:
                r = {"engine": engine, "robot": name, "sim_s": sim_s, "eps": eps,
                     **run(engine, bands, sim_s, eps, args.pressure_kpa)}
                ref = r["length_mm"] if ref is None else ref
                r["move_mm"] = round(r["length_mm"] - ref, 4)
                rows.append(r)
    if args.json:
        print(json.dumps(rows, indent=1))
        return rows
    print(f"colon phantom, constant command {args.pressure_kpa:g} kPa x (1 + eps)")
    print(f"{'engine':>12s} {'robot':>8s} {'eps':>7s} {'length_mm':>10s} {'stalled':>8s} {'move_mm':>8s} {'solves':>7s} "
          f"{'above_tol':>9s} {'wall_s':>7s}")
    for r in rows:
        print(f"{r['engine']:>12s} {r['robot']:>8s} {r['eps']:>7g} {r['length_mm']:>10.4f} {str(r['stalled']):>8s} "
              f"{r['move_mm']:>8.4f} {str(r['solves']):>7s} {str(r['solve_failures']):>9s} {r['wall_s']:>7.2f}")
    return rows


if __name__ == "__main__":
    main()
