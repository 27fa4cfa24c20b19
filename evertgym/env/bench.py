"""Env throughput: steps per second per registered id, random actions, one core."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np


def random_steps(env: gym.Env, steps: int, rng: np.random.Generator) -> float:
    """Wall-clock seconds of ``steps`` steps of ``env`` with uniform random actions from ``rng``,
    resetting as episodes end."""
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        if term or trunc:
            env.reset()
    return time.perf_counter() - t0


def bench_env(env_id: str, steps: int = 500, seed: int = 0) -> dict:
    """Run ``steps`` env steps with uniform random actions (resetting as episodes end)."""
    env = gym.make(env_id)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    wall = random_steps(env, steps, rng)
    unwrapped = env.unwrapped
    env.close()
    return {
        "env_id": env_id,
        "steps_per_s": steps / wall,
        "sim_seconds_per_step": unwrapped.control_dt,  # type: ignore[attr-defined]
        "steps": steps,
        "wall_s": wall,
    }
