"""Cost per simulated second against total robot length (the active set at work).

    python -m evertgym.bench.length [--lengths-m 0.2,0.8,2.0] [--pressure-kpa 3] [--repeats 3] [--engine dynamic]

Each robot (40 mm, no bands) grows at constant pressure through a 55 mm pipe with a
90-degree bend (inner radius 60 mm) 100 mm from the base and a straight pipe after it.
Printed per length (medians over repeats): the wall time per simulated second over the
whole growth, over the last simulated second of growth (the tip far from the base, the
active set full: the figure a 1.5x bound is read on) and while holding at full
length, with the ratio of each to the shortest robot; and the active/total segments.
"""

from __future__ import annotations

import argparse
import statistics
import time

from evertgym.design import TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim, SimConfig


def run(length_m: float, pressure_pa: float, engine: str) -> dict:
    scene = make_scene(
        {"family": "bend", "params": {"angle_deg": 90.0, "radius_mm": 60.0, "lumen_mm": 55.0, "lead_in_mm": 100.0,
                                       "lead_out_mm": length_m * 1e3 + 100.0, "goal_after_bend_mm": 50.0}}
    )
    sim = EversionSim(TubeDesign(length_m=length_m), scene=scene, config=SimConfig(engine=engine))
    sim.set_pressure_command(pressure_pa)
    chunks = []  # (wall, sim) per 0.1 s
    while sim.length < length_m - 1e-9 and sim.t < 120.0:
        t0 = time.perf_counter()
        sim.run(0.1)
        chunks.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    sim.run(1.0)
    hold = time.perf_counter() - t0
    return {
        "growth": sum(chunks) / (0.1 * len(chunks)),
        "last_second": sum(chunks[-10:]) / (0.1 * len(chunks[-10:])),
        "hold": hold,
        "active": len(sim.radii()) - sim.active_start,
        "segments": len(sim.radii()),
        "sim_s": sim.t,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lengths-m", default="0.2,0.8,2.0")
    ap.add_argument("--pressure-kpa", type=float, default=3.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--engine", choices=("quasistatic", "dynamic"), default=SimConfig().engine)
    args = ap.parse_args()
    rows = []
    for x in args.lengths_m.split(","):
        runs = [run(float(x), args.pressure_kpa * 1e3, args.engine) for _ in range(args.repeats)]
        row = {k: statistics.median(r[k] for r in runs) for k in ("growth", "last_second", "hold")}
        row.update(length_m=float(x), active=runs[-1]["active"], segments=runs[-1]["segments"], sim_s=runs[-1]["sim_s"])
        rows.append(row)
    b = rows[0]
    print(f"wall seconds per simulated second (median of {args.repeats} runs), engine {args.engine!r}")
    print(f"{'length_m':>8} {'sim_s':>6} {'growth':>8} {'ratio':>6} {'last_1s':>8} {'ratio':>6} {'hold':>8} {'ratio':>6} {'active/total':>13}")
    for r in rows:
        print(
            f"{r['length_m']:>8.2f} {r['sim_s']:>6.1f} {r['growth']:>8.4f} {r['growth'] / b['growth']:>6.2f} "
            f"{r['last_second']:>8.4f} {r['last_second'] / b['last_second']:>6.2f} {r['hold']:>8.4f} {r['hold'] / b['hold']:>6.2f} "
            f"{str(r['active']) + '/' + str(r['segments']):>13}"
        )


if __name__ == "__main__":
    main()
