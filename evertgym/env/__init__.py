"""The env layer: Gymnasium environments for pressure scheduling.

Importing :mod:`evertgym` registers every preset of the repository's ``envs/`` folder, so
``gymnasium.make("evertgym/Colon-v0")`` works after ``import evertgym``; without the import,
``gymnasium.make("evertgym:evertgym/Colon-v0")`` imports it for you.
"""

from __future__ import annotations

import math

import gymnasium

from evertgym.env.eversion_env import EversionEnv
from evertgym.env.presets import load_preset, preset_files

ENTRY_POINT = "evertgym.env.eversion_env:EversionEnv"


def preset_kwargs(env_id: str) -> dict:
    """Constructor kwargs of :class:`EversionEnv` for a registered id."""
    p = load_preset(env_id)
    kw = {
        "scene": dict(p["scene"]),
        "design": dict(p["design"]),
        "band_offset_mm": tuple(p.get("band_offset_mm", (0.0, 0.0))),
        "control_hz": float(p.get("control_hz", 10.0)),
        "max_episode_s": float(p.get("max_episode_s", 30.0)),
    }
    kw.update(p.get("reward", {}))
    kw.update(p.get("observation", {}))
    return kw


def register_envs() -> list[str]:
    """Register every preset with Gymnasium (idempotent); returns the ids."""
    ids = []
    for env_id in preset_files():
        if env_id not in gymnasium.registry:
            kw = preset_kwargs(env_id)
            steps = math.ceil(kw["max_episode_s"] * kw["control_hz"] - 1e-9)
            gymnasium.register(id=env_id, entry_point=ENTRY_POINT, kwargs=kw, max_episode_steps=steps)
        ids.append(env_id)
    return ids


__all__ = ["EversionEnv", "preset_kwargs", "register_envs"]
