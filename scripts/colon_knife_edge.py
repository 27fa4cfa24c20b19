"""Probe the colon knife edge (docs/quasistatic.md, "Answers independent of the number of cores"): two
held-out Colon-v0 episodes under the 1 <-> 8 kPa wave, with the wave's period and levels perturbed, with the
solver's settings changed, and where the two branches part.

Actions are float32, so a relative change below about 6e-8 of a level does not reach the env
(the first line printed checks it); the level perturbations here are one float32 step of the level.

    python scripts/colon_knife_edge.py      # 12 + 20 + 2 episodes, about 4 min on one core
"""
import json

import gymnasium as gym
import numpy as np

from evertgym.agents.baselines import run_episode
from evertgym.agents.evaluate import evaluate
from evertgym.agents.policies import make_policy
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

ENV = "evertgym/Colon-v0"
KW = {"regulator_tau_s": [0.1, 0.6]}
EPISODES = (0, 107)  # the held-out episodes whose outcome the BLAS thread count flipped
WAVES = [
    "cycle",
    "cycle:period_s=2.000000002",
    "cycle:period_s=1.999999998",
    "cycle:high_kpa=7.9999995",
    "cycle:low_kpa=1.0000001",
    "cycle:low_kpa=0.9999999",
]
#: solver settings (SimConfig fields) under which both high levels are replayed
KNOBS = [{}, {"solver_tolerance": 1e-4}, {"growth_increment_m": 0.0005}, {"pressure_increment_fraction": 0.01},
         {"barrier_gap_m": 0.0005}]
HIGHS = (8.0, 7.9999995)


def _trace(seed: int, high_kpa: float) -> list[tuple[float, float, float]]:
    """(time s, insertion mm, tip force N) after every env step of the wave on episode ``seed``."""
    env = gym.make(ENV, **KW)
    policy = make_policy({"name": "cycle", "high_kpa": high_kpa})
    out = []

    def record(env, info) -> bool:
        out.append((info["time_s"], info["insertion_length_mm"], env.unwrapped.sim.tip_force))
        return False

    run_episode(env, policy, seed, options={"scene_seed": seed}, stop=record)
    return out


def main() -> None:
    print("float32(8*(1-1e-9)) == 8:", np.float32(8 * (1 - 1e-9)) == np.float32(8.0))
    for seed in (HELD_OUT_SEED_BASE + i for i in EPISODES):
        for wave in WAVES:
            r = evaluate([wave], ENV, 1, env_kwargs=KW, seed_base=seed)[0]
            print(seed, wave, r["success_rate"], round(r["mean_time_to_goal_s"], 2), repr(r["mean_max_contact_force_n"]), flush=True)
    print("solver settings: outcome and final insertion (mm) with the high level at", " | ".join(f"{h} kPa" for h in HIGHS))
    for seed in (HELD_OUT_SEED_BASE + i for i in EPISODES):
        for knob in KNOBS:
            cells = []
            for high in HIGHS:
                env = gym.make(ENV, **KW, **({"sim_config": knob} if knob else {}))
                info = run_episode(env, make_policy({"name": "cycle", "high_kpa": high}), seed, options={"scene_seed": seed})
                cells.append(f"{info['outcome']:8s} {info['insertion_length_mm']:6.1f}")
            print(seed, f"{json.dumps(knob):40s}", " | ".join(cells), flush=True)
    seed = HELD_OUT_SEED_BASE + EPISODES[0]
    a, b = _trace(seed, HIGHS[0]), _trace(seed, HIGHS[1])
    first = next(i for i, (x, y) in enumerate(zip(a, b)) if abs(x[1] - y[1]) > 1e-3 or abs(x[2] - y[2]) > 1e-3)
    print(f"episode {seed}: the two high levels part (by 1e-3 mm or N) at t = {a[first][0]:.1f} s; "
          "after each step (time s, insertion mm, tip force N):")
    for x, y in list(zip(a, b))[max(0, first - 1):first + 5]:
        print(f"  t {x[0]:5.1f}   {HIGHS[0]} kPa: {x[1]:7.2f} mm {x[2]:.4f} N   {HIGHS[1]} kPa: {y[1]:7.2f} mm {y[2]:.4f} N")
    print(f"  ... at the end: {a[-1][1]:.1f} mm after {a[-1][0]:.1f} s against {b[-1][1]:.1f} mm after {b[-1][0]:.1f} s")


if __name__ == "__main__":
    main()
