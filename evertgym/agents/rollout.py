"""Render one episode of a policy to an animated GIF (Pillow; frames from :mod:`evertgym.render`)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

from evertgym.agents.policies import for_env, make_policy, on_trained_engine
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, engine_of


def rollout_gif(policy_desc: str | dict, env_id: str, out: str | Path, seed: int = 0, every: int = 2, trust: bool = False,
                progress: bool = False, env_kwargs: dict | None = None, allow_engine_mismatch: bool = False) -> dict:
    """Run one episode with ``render_mode="rgb_array"``; every ``every``-th frame goes to ``out``.
    The episode is held-out episode ``seed``: episode and scene seed ``HELD_OUT_SEED_BASE +
    seed``, the same episode as :func:`evertgym.agents.evaluate.evaluate`'s ``seed``-th, which
    training never draws.  ``env_kwargs`` go to the env (a trained policy adds only its
    observation flags).  Returns the outcome, ``episode_seed`` and the pressure command of
    every control step (``command_kpa``).
    ``trust=True`` loads a saved model that is not a shipped policy (model files are code).
    ``progress`` shows a bar over the episode's control steps (on stderr).  A trained model runs on
    the engine it was trained on, as in :func:`~evertgym.agents.evaluate.evaluate` (the same
    ``allow_engine_mismatch``); ``engine`` in the result names the one the episode ran on."""
    from PIL import Image
    from tqdm import tqdm

    out = Path(out)
    if out.suffix.lower() != ".gif":
        raise ValueError(f"--out = {str(out)!r}: expected a .gif file")
    desc = for_env(policy_desc, env_id)
    env_kwargs = on_trained_engine([desc], env_kwargs, allow_engine_mismatch, "allow_engine_mismatch=True")
    policy = make_policy(desc, trust=trust)
    env = gym.make(env_id, render_mode="rgb_array", **{**env_kwargs, **getattr(policy, "observation_kwargs", {})})
    episode_seed = HELD_OUT_SEED_BASE + seed
    obs, info = env.reset(seed=episode_seed, options={"scene_seed": episode_seed})
    policy.reset(env)
    frames = [env.render()]
    commands: list[float] = []
    k = 0
    bar = tqdm(total=env.spec.max_episode_steps if env.spec else None, desc="rollout", unit="step", disable=not progress)
    while True:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        commands.append(round(env.unwrapped.command_pa / 1e3, 2))  # type: ignore[attr-defined]
        k += 1
        bar.update(1)
        if k % every == 0 or term or trunc:
            frames.append(env.render())
        if term or trunc:
            break
    bar.close()
    images = [Image.fromarray(np.asarray(f)) for f in frames]
    out.parent.mkdir(parents=True, exist_ok=True)
    fps = env.metadata.get("render_fps", 10) / every
    images[0].save(out, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    env.close()
    return {"frames": len(images), "success": bool(info["success"]), "time_s": round(float(info["time_s"]), 2),
            "peak_pressure_kpa": round(float(info["peak_pressure_kpa"]), 3), "command_kpa": commands, "out": str(out),
            "episode_seed": episode_seed, "engine": engine_of(env_kwargs)}
