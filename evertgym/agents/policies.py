"""Policies by description: baselines by name, trained SB3 models by path."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from evertgym.agents.baselines import Policy, make_baseline


class SB3Policy(Policy):
    """A saved stable-baselines3 model (``.zip``), with its VecNormalize statistics if a
    ``vecnormalize.pkl`` sits beside it; deterministic actions."""

    name = "agent"

    def __init__(self, path: str | Path):
        from stable_baselines3 import PPO, SAC

        path = Path(path)
        if not path.exists():
            raise ValueError(f"policy path = {str(path)!r} does not exist")
        last_error = None
        for cls in (PPO, SAC):
            try:
                self.model = cls.load(str(path), device="cpu")
                break
            except Exception as e:  # noqa: BLE001 - try the next algorithm
                last_error = e
        else:
            raise ValueError(f"policy path = {str(path)!r} is not a PPO or SAC model: {last_error}")
        meta = path.with_name(path.stem + "_env.json")
        #: env kwargs the model was trained with (observation flags); evaluation applies them
        self.env_kwargs = json.loads(meta.read_text())["env_kwargs"] if meta.exists() else {}
        stats = path.with_name(path.stem + "_vecnormalize.pkl")
        self.obs_rms = None
        if stats.exists():
            import pickle

            with open(stats, "rb") as f:
                vn = pickle.load(f)
            self.obs_rms, self.clip_obs, self.epsilon = vn.obs_rms, vn.clip_obs, vn.epsilon

    def act(self, obs, info):
        x = np.asarray(obs, dtype=np.float32)
        if self.obs_rms is not None:
            x = np.clip((x - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon), -self.clip_obs, self.clip_obs)
        action, _ = self.model.predict(x.astype(np.float32), deterministic=True)
        return np.asarray(action, dtype=np.float32).reshape(1)


def make_policy(desc: dict | str) -> Policy:
    """``{"name": "constant", "pressure_kpa": 3}``, ``"operator"``, ``{"name": "agent", "path": ...}``
    or the path of a saved model."""
    if isinstance(desc, str):
        desc = {"name": "agent", "path": desc} if desc.endswith(".zip") else {"name": desc}
    desc = dict(desc)
    name = desc.pop("name", None)
    if name == "agent":
        return SB3Policy(desc["path"])
    if name is None:
        raise ValueError("policy must have a name: constant, operator, tuned or agent")
    return make_baseline(name, **desc)
