"""Policies by description: baselines by name, trained SB3 models by path."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from evertgym.agents.baselines import BASELINES, Policy
from evertgym.agents.tuned import load_tuned, shipped_dir


class SB3Policy(Policy):
    """A saved stable-baselines3 model (``.zip``), with its VecNormalize statistics if a
    ``vecnormalize.pkl`` sits beside it.

    Actions are the policy's mean (``deterministic=True``) or drawn from its Gaussian
    (PPO only) with a generator seeded by each episode's seed, so a stochastic evaluation
    is repeatable too.  ``deterministic=None`` takes the mode the model was shipped with
    (``"deterministic"`` in ``<stem>_env.json``; default True).

    The zip and the ``.pkl`` are code (pickles): they load only if their SHA-256 is in the
    manifest of shipped policies or ``trust=True`` (:mod:`evertgym.agents.trust`).
    """

    name = "agent"

    def __init__(self, path: str | Path, deterministic: bool | None = None, trust: bool = False):
        from stable_baselines3 import PPO, SAC

        from evertgym.agents.trust import check_trusted
        from evertgym.env.eversion_env import OBSERVATION_KWARGS

        path = Path(path)
        if not path.is_file():
            raise ValueError(f"policy path = {str(path)!r} is not a file")
        stats = path.with_name(path.stem + "_vecnormalize.pkl")
        for f in (path, stats) if stats.exists() else (path,):
            check_trusted(f, trust)
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
        #: env kwargs the model was trained with; evaluation applies only the observation
        #: flags among them (``observation_kwargs``), so every policy meets the same physics
        shipped = json.loads(meta.read_text()) if meta.exists() else {}
        self.env_kwargs = shipped.get("env_kwargs", {})
        self.observation_kwargs = {k: v for k, v in self.env_kwargs.items() if k in OBSERVATION_KWARGS}
        self.deterministic = bool(shipped.get("deterministic", True)) if deterministic is None else bool(deterministic)
        if not self.deterministic and not isinstance(self.model, PPO):
            raise ValueError(f"policy path = {str(path)!r}: stochastic actions are supported for PPO models only")
        self.rng = np.random.default_rng(0)
        self.obs_rms = None
        if stats.exists():
            import pickle

            with open(stats, "rb") as fh:
                vn = pickle.load(fh)
            self.obs_rms, self.clip_obs, self.epsilon = vn.obs_rms, vn.clip_obs, vn.epsilon

    def reset(self, env) -> None:
        super().reset(env)
        seed = getattr(env.unwrapped, "np_random_seed", None)
        self.rng = np.random.default_rng(None if seed is None or seed < 0 else int(seed))

    def act(self, obs, info):
        x = np.asarray(obs, dtype=np.float32)
        if self.obs_rms is not None:
            x = np.clip((x - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon), -self.clip_obs, self.clip_obs)
        if self.deterministic:
            action, _ = self.model.predict(x.astype(np.float32), deterministic=True)
            return np.asarray(action, dtype=np.float32).reshape(1)
        import torch

        with torch.no_grad():
            obs_t, _ = self.model.policy.obs_to_tensor(x.astype(np.float32))
            dist = self.model.policy.get_distribution(obs_t).distribution
            mean, std = dist.mean.numpy().reshape(-1), dist.stddev.numpy().reshape(-1)
        action = mean + std * self.rng.standard_normal(mean.shape)
        return np.clip(action, -1.0, 1.0).astype(np.float32).reshape(1)


def make_baseline(name: str, **kwargs) -> Policy:
    """A baseline policy by name (``constant``, ``operator``, ``cycle``, ``deflate``, ``tuned``) with its parameters
    (``tuned`` takes ``env_id``, the env whose tuned parameters to load, or a ``path``)."""
    if name == "tuned":
        return load_tuned(**kwargs)
    if name not in BASELINES:
        raise ValueError(f"unknown baseline {name!r}: allowed {sorted(BASELINES) + ['tuned']}")
    try:
        return BASELINES[name](**kwargs)
    except TypeError as e:  # an unknown parameter: name it, as for any bad field
        raise ValueError(f"policy {name!r}: {e}") from None


def _parse_params(desc: str, name: str, rest: str) -> dict:
    """``"low_kpa=0,high_kpa=3"`` -> ``{"name": name, "low_kpa": 0.0, "high_kpa": 3.0}`` (numbers only)."""
    out: dict = {"name": name}
    for kv in rest.split(","):
        k, eq, v = (x.strip() for x in kv.partition("="))
        if not (k and eq):
            raise ValueError(f"policy = {desc!r}: {kv.strip()!r} is not a parameter: allowed name:key=value,key=value")
        if k in out:
            raise ValueError(f"policy = {desc!r}: {k} is given twice: allowed each parameter once")
        try:
            out[k] = float(v)
        except ValueError:
            raise ValueError(f"policy = {desc!r}: {k} must be a number (got {v!r})") from None
    return out


def policy_desc(desc: dict | str) -> dict:
    """A policy description as a dict with a ``name``: ``"operator"`` -> ``{"name": "operator"}``,
    ``"cycle:low_kpa=0,high_kpa=3,period_s=1"`` -> ``{"name": "cycle", "low_kpa": 0.0, ...}``
    (the CLI's spelling of a baseline with parameters: numbers, kPa/s/mm as the names say),
    ``"model.zip"`` (optionally ``"model.zip:deterministic"`` / ``":stochastic"``) ->
    ``{"name": "agent", "path": ..., ...}``; dicts pass through (copied)."""
    if isinstance(desc, str):
        path, _, mode = desc.partition(".zip:")
        if mode:  # "model.zip:deterministic" or "model.zip:stochastic"
            if mode not in ("deterministic", "stochastic"):
                raise ValueError(f"policy = {desc!r}: the mode after '.zip:' must be 'deterministic' or 'stochastic'")
            return {"name": "agent", "path": path + ".zip", "deterministic": mode == "deterministic"}
        if desc.endswith(".zip"):
            return {"name": "agent", "path": desc}
        name, colon, rest = desc.partition(":")
        if colon and "=" in rest:  # "constant:pressure_kpa=3"
            return _parse_params(desc, name.strip(), rest)
        return {"name": name.strip() if colon and not rest.strip() else desc}
    if not isinstance(desc, dict):
        raise ValueError(f"policy = {desc!r}: allowed a name, a model path or a dict with a name")
    return dict(desc)


def for_env(desc: dict | str, env_id: str) -> dict:
    """The description of ``desc`` as evaluated on ``env_id``: ``tuned`` without a ``path``
    or ``env_id`` of its own takes the parameters tuned on ``env_id`` (its training scenes);
    every other description is unchanged."""
    d = policy_desc(desc)
    if d.get("name") == "tuned" and "path" not in d and "env_id" not in d:
        d["env_id"] = env_id
    return d


def shipped_policies() -> list[str]:
    """Names of the shipped trained policies (``load_policy`` accepts each)."""
    return sorted(p.parent.name for p in shipped_dir().glob("*/final.zip"))


def resolve_policy_path(name_or_path: str | Path) -> Path:
    """``"colon_ppo"`` -> the shipped ``agents/colon_ppo/final.zip``; a run folder -> its
    ``final.zip``; a ``.zip`` path -> itself.  Raises ``ValueError`` naming the shipped ones."""
    p = Path(name_or_path)
    if p.suffix == ".zip" and p.is_file():
        return p
    if p.is_dir() and (p / "final.zip").is_file():
        return p / "final.zip"
    shipped = shipped_dir() / str(name_or_path) / "final.zip"
    if shipped.is_file():
        return shipped
    raise ValueError(f"policy {str(name_or_path)!r}: neither a saved model (.zip), a run folder with final.zip, "
                     f"nor a shipped policy; shipped: {shipped_policies()}")


def make_policy(desc: dict | str, trust: bool = False) -> Policy:
    """``{"name": "constant", "pressure_kpa": 3}``, ``"operator"``, ``{"name": "agent", "path": ...,
    "deterministic": ...}`` or the path of a saved model, optionally with its action mode
    (``"model.zip:stochastic"``, ``"model.zip:deterministic"``), or a shipped policy by name
    (``"colon_ppo"``).  A saved model loads only if it is a shipped policy or ``trust`` is set
    (or the dict holds ``"trust": True``)."""
    desc = policy_desc(desc)
    name = desc.pop("name", None)
    trust = bool(desc.pop("trust", False)) or trust
    if name == "agent":
        return SB3Policy(desc["path"], desc.get("deterministic"), trust=trust)
    if name is None:
        raise ValueError("policy must have a name: constant, operator, cycle, deflate, tuned or agent")
    if name in shipped_policies():  # a shipped trained policy by name, e.g. "colon_ppo"
        return SB3Policy(resolve_policy_path(name), desc.get("deterministic"), trust=trust)
    return make_baseline(name, **desc)
