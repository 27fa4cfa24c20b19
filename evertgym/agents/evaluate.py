"""Side-by-side evaluation of policies on the same held-out episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from evertgym.agents.policies import make_policy
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.limits import MAX_EPISODES
from evertgym.scoring.stats import wilson_interval


def run_episode(env, policy, seed: int) -> dict:
    obs, info = env.reset(seed=seed, options={"scene_seed": seed})
    policy.reset(env)
    while True:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        if term or trunc:
            return info


def _run_episodes(desc: str | dict, env_id: str, env_kwargs: dict | None, seeds: list[int], trust: bool = False) -> list[dict]:
    """Final ``info`` of one episode per seed (episode and scene seed alike) for one policy."""
    import evertgym  # noqa: F401  (registers the envs)

    policy = make_policy(desc, trust=trust)
    # observation flags a trained model needs; they do not change the physics
    env = gym.make(env_id, **{**(env_kwargs or {}), **getattr(policy, "env_kwargs", {})})
    try:
        return [run_episode(env, policy, seed) for seed in seeds]
    finally:
        env.close()


def _worker_init() -> None:
    import torch

    torch.set_num_threads(1)


def evaluate(policies: list[str | dict], env_id: str, episodes: int, env_kwargs: dict | None = None,
             seed_base: int = HELD_OUT_SEED_BASE, workers: int = 1, trust: bool = False) -> list[dict]:
    """One row per policy: success rate (Wilson 95%), mean time to goal, peak pressure and
    max contact force over ``episodes`` episodes whose seeds (and scene seeds) are
    ``seed_base + i``, the same for every policy.  ``workers > 1`` spreads the episodes
    over that many processes; every episode is seeded, so the rows do not change.
    ``trust=True`` loads saved models that are not shipped policies (model files are code)."""
    if not (isinstance(episodes, int) and 1 <= episodes <= MAX_EPISODES):
        raise ValueError(f"episodes = {episodes!r} is out of range: allowed integers in [1, {MAX_EPISODES}]")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers = {workers!r} is out of range: allowed integers >= 1")
    seeds = [seed_base + i for i in range(episodes)]
    size = -(-episodes // workers)  # contiguous chunks: concatenated, they are in seed order
    chunks = [seeds[k:k + size] for k in range(0, episodes, size)]
    if len(chunks) > 1:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(len(chunks), mp_context=mp.get_context("spawn"), initializer=_worker_init) as pool:
            futures = [[pool.submit(_run_episodes, desc, env_id, env_kwargs, c, trust) for c in chunks] for desc in policies]
            results = [[info for f in fs for info in f.result()] for fs in futures]
    else:
        results = [_run_episodes(desc, env_id, env_kwargs, seeds, trust) for desc in policies]
    rows = []
    for desc, infos in zip(policies, results):
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
