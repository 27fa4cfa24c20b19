"""Side-by-side evaluation of policies on the same held-out episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from evertgym.agents.policies import make_policy
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.scoring.stats import wilson_interval


def run_episode(env, policy, seed: int) -> dict:
    obs, info = env.reset(seed=seed, options={"scene_seed": seed})
    policy.reset(env)
    while True:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        if term or trunc:
            return info


def evaluate(policies: list[str | dict], env_id: str, episodes: int, env_kwargs: dict | None = None, seed_base: int = HELD_OUT_SEED_BASE) -> list[dict]:
    """One row per policy: success rate (Wilson 95%), mean time to goal, peak pressure and
    max contact force over ``episodes`` episodes whose seeds (and scene seeds) are
    ``seed_base + i``, the same for every policy."""
    import evertgym  # noqa: F401  (registers the envs)

    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes = {episodes!r} is out of range: allowed integers >= 1")
    rows = []
    for desc in policies:
        policy = make_policy(desc)
        # observation flags a trained model needs; they do not change the physics
        env = gym.make(env_id, **{**(env_kwargs or {}), **getattr(policy, "env_kwargs", {})})
        infos = [run_episode(env, policy, seed_base + i) for i in range(episodes)]
        env.close()
        wins = [i for i in infos if i["success"]]
        lo, hi = wilson_interval(len(wins), episodes)
        rows.append(
            {
                "policy": desc if isinstance(desc, str) else desc.get("name", str(desc)),
                "episodes": episodes,
                "success_rate": len(wins) / episodes,
                "ci_low": lo,
                "ci_high": hi,
                "mean_time_to_goal_s": float(np.mean([i["time_s"] for i in wins])) if wins else math.nan,
                "mean_peak_pressure_kpa": float(np.mean([i["peak_pressure_kpa"] for i in infos])),
                "mean_max_contact_force_n": float(np.mean([i["max_contact_force_n"] for i in infos])),
            }
        )
    return rows
