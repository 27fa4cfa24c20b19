#!/usr/bin/env python
"""Cost per simulated second against total robot length (the active set at work).

    python scripts/bench_sim_length.py [--lengths-m 0.2,0.8,2.0] [--pressure-kpa 3]

Each robot (40 mm, no bands) grows at constant pressure through a 55 mm pipe with a
90-degree bend (inner radius 60 mm) 100 mm from the base and a straight pipe after it,
until it reaches its full length.  Printed: wall time per simulated second over the whole
run and over its last second (the steady state), the active and total segment counts at
the end, and the ratio to the shortest robot.
"""

import argparse
import time

from evertgym.design import TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim


def run(length_m: float, pressure_pa: float) -> dict:
    scene = make_scene(
        {"family": "bend", "params": {"angle_deg": 90.0, "radius_mm": 60.0, "lumen_mm": 55.0, "lead_in_mm": 100.0,
                                       "lead_out_mm": length_m * 1e3 + 100.0, "goal_after_bend_mm": 50.0}}
    )
    sim = EversionSim(TubeDesign(length_m=length_m), scene=scene)
    sim.set_pressure_command(pressure_pa)
    wall, sim_t, last = 0.0, 0.0, (0.0, 0.0)
    while sim.length < length_m - 1e-9 and sim.t < 120.0:
        t0 = time.perf_counter()
        sim.run(0.1)
        dt = time.perf_counter() - t0
        wall += dt
        sim_t += 0.1
        last = (last[0] + dt, last[1] + 0.1) if sim.t > sim_t - 1.0 else last
    t0 = time.perf_counter()
    sim.run(1.0)  # steady state at full length
    steady = time.perf_counter() - t0
    return {
        "length_m": length_m,
        "sim_s": round(sim.t, 2),
        "wall_s_per_sim_s": wall / sim_t,
        "steady_wall_s_per_sim_s": steady,
        "active_segments": len(sim.bodies) - sim.active_start,
        "segments": len(sim.bodies),
        "reached_full_length": sim.length >= length_m - 1e-9,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lengths-m", default="0.2,0.8,2.0")
    ap.add_argument("--pressure-kpa", type=float, default=3.0)
    args = ap.parse_args()
    rows = [run(float(x), args.pressure_kpa * 1e3) for x in args.lengths_m.split(",")]
    base = rows[0]["wall_s_per_sim_s"]
    print(f"{'length_m':>8} {'sim_s':>6} {'wall_s_per_sim_s':>16} {'ratio':>6} {'steady_at_full':>14} {'active/total segs':>17} {'full':>5}")
    for r in rows:
        print(
            f"{r['length_m']:>8.2f} {r['sim_s']:>6.1f} {r['wall_s_per_sim_s']:>16.4f} {r['wall_s_per_sim_s'] / base:>6.2f} "
            f"{r['steady_wall_s_per_sim_s']:>14.4f} {str(r['active_segments']) + '/' + str(r['segments']):>17} {str(r['reached_full_length']):>5}"
        )


if __name__ == "__main__":
    main()
