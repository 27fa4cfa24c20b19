"""The env layer: Gymnasium environments for pressure scheduling.

Importing :mod:`evertgym` registers every preset of the repository's ``envs/`` folder, so
``gymnasium.make("evertgym/Colon-v0")`` works after ``import evertgym``; without the import,
``gymnasium.make("evertgym:evertgym/Colon-v0")`` imports it for you.  Registration uses
the entry-point string only: the simulator (pymunk, scipy) is imported when an env is made
or when :class:`EversionEnv` is first looked up here.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import gymnasium

from evertgym.env.presets import load_preset, preset_files

if TYPE_CHECKING:
    from evertgym.env.eversion_env import EversionEnv

ENTRY_POINT = "evertgym.env.eversion_env:EversionEnv"
#: Former ids of registered envs -> their ids now: a saved model's metadata naming a former id gets the new
#: one (:func:`current_id`); the command line refuses a former id naming the new one.
RENAMED_IDS = {"evertgym/Tortuous-v1": "evertgym/TortuousHard-v0"}
#: the domain-randomisation arguments a preset's ``[randomisation]`` table may set (ranges checked by the env)
RANDOMISATION_KEYS = ("regulator_tau_s", "wall_friction", "pressure_noise_kpa", "insertion_noise_mm")


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
    for key, value in p.get("randomisation", {}).items():
        if key not in RANDOMISATION_KEYS:
            raise ValueError(f"{env_id}: randomisation.{key} is not allowed: allowed {list(RANDOMISATION_KEYS)}")
        kw[key] = tuple(value) if isinstance(value, list) else value
    return kw


def current_id(env_id: str) -> str:
    """``env_id``, or the id it was renamed to (:data:`RENAMED_IDS`)."""
    return RENAMED_IDS.get(env_id, env_id)


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


def __getattr__(name: str) -> Any:
    """``evertgym.env.EversionEnv``, imported on first use (it pulls in the simulator)."""
    if name == "EversionEnv":
        from evertgym.env.eversion_env import EversionEnv

        return EversionEnv
    raise AttributeError(f"module 'evertgym.env' has no attribute {name!r}")


__all__ = ["RENAMED_IDS", "EversionEnv", "current_id", "preset_kwargs", "register_envs"]
