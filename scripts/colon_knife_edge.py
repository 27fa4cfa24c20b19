"""Probe the colon knife edge (docs/quasistatic.md, "Answers independent of the number of cores"): two
held-out Colon-v0 episodes under the 1 <-> 8 kPa wave, with the wave's period and levels perturbed.

Actions are float32, so a relative change below about 6e-8 of a level does not reach the env
(the first line printed checks it); the level perturbations here are one float32 step.

    python scripts/colon_knife_edge.py      # 12 episodes, about 2 min on one core
"""
import numpy as np

from evertgym.agents.evaluate import evaluate
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

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


def main() -> None:
    print("float32(8*(1-1e-9)) == 8:", np.float32(8 * (1 - 1e-9)) == np.float32(8.0))
    for seed in (HELD_OUT_SEED_BASE + i for i in EPISODES):
        for wave in WAVES:
            r = evaluate([wave], "evertgym/Colon-v0", 1, env_kwargs=KW, seed_base=seed)[0]
            print(seed, wave, r["success_rate"], round(r["mean_time_to_goal_s"], 2), repr(r["mean_max_contact_force_n"]), flush=True)


if __name__ == "__main__":
    main()
