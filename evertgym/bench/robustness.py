"""The numbers of docs/robustness.md: the bounded event log and the 1000-band build.

    python -m evertgym.bench.robustness [--minutes 10] [--json]
    python -m evertgym.bench.robustness --worst-steps [--json]

* event log: an EversionSim in a Tortuous-v0 scene with its pressure command cycling
  between 0 and 8 kPa at 20 Hz for ``--minutes`` simulated minutes; the process's RSS and
  the number of kept events after the first simulated minute and at the end.
* bands: wall time to build an EversionSim of a 20 m body with 1000 bands and run 0.5 s.
* ``--worst-steps`` (only this): the longest wall time of one env step of UBend-v0 at 4 kPa (80 steps, through
  the bend) under each of the costliest accepted settings (:data:`WORST_SETTINGS`), with its solve counts.
"""

from __future__ import annotations

import argparse
import json
import time

from evertgym.design import Band, TubeDesign
from evertgym.limits import MAX_EVENTS
from evertgym.scenes import SceneSpec, make_scene
from evertgym.sim import EversionSim


def event_log_memory(minutes: float) -> dict:
    """RSS (MiB) and kept events after 1 simulated minute and after ``minutes`` (needs psutil: the test extra)."""
    from evertgym._extras import require

    require("the event log's memory figures", "psutil")
    import psutil

    proc = psutil.Process()
    sim = EversionSim(TubeDesign(length_m=0.9), scene=make_scene(SceneSpec("tortuous", {}, 0)))
    out: dict = {"minutes": minutes, "max_events": MAX_EVENTS}
    k = 0
    while sim.t < 60.0 * minutes:
        sim.set_pressure_command(8000.0 if k % 2 == 0 else 0.0)
        sim.run(0.05)
        k += 1
        if "rss_mib_at_1_min" not in out and sim.t >= 60.0:
            out.update(rss_mib_at_1_min=proc.memory_info().rss / 2**20, events_at_1_min=len(sim.events))
    out.update(rss_mib_at_end=proc.memory_info().rss / 2**20, events_at_end=len(sim.events),
               events_counted=sum(sim.event_counts.values()))
    return out


def thousand_bands() -> dict:
    """Wall time (s) to build a 1000-band body and simulate 0.5 s."""
    t0 = time.perf_counter()
    sim = EversionSim(TubeDesign(length_m=20.0, bands=tuple(Band(0.05 + 0.019 * i, 0.1) for i in range(1000))))
    sim.set_pressure_command(3000.0)
    sim.run(0.5)
    return {"bands": 1000, "build_and_run_0p5_s_wall_s": time.perf_counter() - t0}


#: The costliest settings the simulator accepts: the quasi-static engine's hardest tolerance with the largest
#: Newton budget, its smallest growth increment, the dense solver on 0.5 mm segments, and the dynamic engine just
#: below its work cap (evertgym.sim.tube.MAX_DYNAMIC_WORK_PER_S); the defaults for reference.
WORST_SETTINGS: tuple[dict, ...] = (
    {},
    {"solver_tolerance": 1e-5, "max_newton_iterations": 10000},
    {"growth_increment_m": 1e-6},
    {"segment_length_m": 0.0005, "growth_increment_m": 0.0005, "linear_solver": "dense"},
    {"engine": "dynamic", "dt_s": 1e-5, "iterations": 3},
    {"engine": "dynamic", "dt_s": 1e-4, "iterations": 30, "segment_length_m": 0.001, "freeze_time_s": 1e6},
)


def worst_steps(steps: int = 80, only: list[int] | None = None) -> list[dict]:
    """Per setting of :data:`WORST_SETTINGS` (``only``: those rows): the longest env step (s), the steps played
    and the solve counts."""
    import gymnasium as gym
    import numpy as np

    from evertgym.env import register_envs

    register_envs()

    rows = []
    for k, sim in enumerate(WORST_SETTINGS):
        if only and k not in only:
            continue
        env = gym.make("evertgym/UBend-v0", sim_config=sim)
        env.reset(seed=0)
        worst, n = 0.0, 0
        info: dict = {}
        while n < steps:
            t0 = time.perf_counter()
            _, _, term, trunc, info = env.step(np.zeros(1, np.float32))  # 4 kPa
            worst = max(worst, time.perf_counter() - t0)
            n += 1
            if term or trunc:
                break
        rows.append({"sim": sim, "steps": n, "worst_step_s": worst, "solves": info.get("solves", 0),
                     "unconverged_solves": info["unconverged_solves"], "solve_budget_cuts": info.get("solve_budget_cuts", 0),
                     "outcome": info["outcome"]})
        env.close()
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--worst-steps", action="store_true", help="only the longest env step under the costliest accepted settings")
    ap.add_argument("--only", type=int, action="append", help="with --worst-steps: only these rows of WORST_SETTINGS (0-based)")
    args = ap.parse_args()
    if args.worst_steps:
        rows = worst_steps(only=args.only)
        print(json.dumps(rows) if args.json else "\n".join(json.dumps(r) for r in rows))
        return
    out = {"event_log": event_log_memory(args.minutes), "bands": thousand_bands()}
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
