"""Policies by description: baselines by name (:mod:`evertgym.agents.describe`), trained SB3 models by path."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from evertgym._extras import require
from evertgym.agents.baselines import BASELINES, Policy
from evertgym.agents.describe import for_env, make_baseline, policy_desc
from evertgym.agents.residual import check_residual, combine, make_rule, with_base
from evertgym.agents.tuned import shipped_dir

__all__ = ["SB3Policy", "check_observation_shape", "engine_mismatch", "for_env", "on_trained_engine", "trained_engine",
           "make_baseline", "make_policy", "model_meta", "observation_fix", "refuse_trust_field",
           "policy_cards", "policy_desc", "resolve_policy_path", "shipped_policies", "vecnormalize_path"]

_CHECKPOINT = re.compile(r"(?P<prefix>.+)_(?P<steps>\d+)_steps")


def vecnormalize_path(path: str | Path) -> Path:
    """Where a saved model's VecNormalize statistics lie: ``<stem>_vecnormalize.pkl`` beside
    ``<stem>.zip`` (``final.zip``), or SB3's checkpoint name ``<prefix>_vecnormalize_<N>_steps.pkl``
    beside a checkpoint ``<prefix>_<N>_steps.zip``.  The file need not exist."""
    path = Path(path)
    m = _CHECKPOINT.fullmatch(path.stem)
    if m and not path.with_name(path.stem + "_vecnormalize.pkl").exists():
        return path.with_name(f"{m['prefix']}_vecnormalize_{m['steps']}_steps.pkl")
    return path.with_name(path.stem + "_vecnormalize.pkl")


def model_meta(path: str | Path) -> dict:
    """The env a saved model was trained with: ``{"env_id", "env_kwargs", "deterministic"}``
    from ``<stem>_env.json`` beside it (shipped policies, a run's ``final.zip`` and its
    checkpoints), else, for a checkpoint in a run's ``checkpoints/`` folder, from the run's
    ``config.json`` (runs trained before checkpoints carried their own); ``{}`` without
    either.  Only JSON is read: nothing is unpickled."""
    from evertgym.env import current_id

    path = Path(path)
    meta = path.with_name(path.stem + "_env.json")
    if meta.is_file():
        found = dict(json.loads(meta.read_text(encoding="utf-8")))
        if "env_id" in found:
            found["env_id"] = current_id(found["env_id"])  # a model saved under an env's former id
        return found
    run_config = path.parent.parent / "config.json"
    if path.parent.name == "checkpoints" and _CHECKPOINT.fullmatch(path.stem) and run_config.is_file():
        cfg = json.loads(run_config.read_text(encoding="utf-8")).get("config", {})
        if "env_id" in cfg:
            found = {"env_id": current_id(cfg["env_id"]), "env_kwargs": cfg.get("env_kwargs", {}), "deterministic": cfg.get("deterministic", True)}
            if cfg.get("residual_spec") is not None:
                found["residual"] = cfg["residual_spec"]
            return found
    return {}


def observation_fix(model_shape: tuple, env_id: str, env_kwargs: dict) -> dict | None:
    """The observation flags (:data:`~evertgym.env.eversion_env.OBSERVATION_KWARGS`, on/off)
    that give ``env_id`` with ``env_kwargs`` observations of ``model_shape``: the fewest
    changes first; None when no combination does."""
    import itertools

    import gymnasium as gym

    from evertgym.env.eversion_env import OBSERVATION_KWARGS

    flags = [k for k in OBSERVATION_KWARGS if isinstance(env_kwargs.get(k, False), bool)]
    for n in range(1, len(flags) + 1):
        for names in itertools.combinations(flags, n):
            change = {k: not env_kwargs.get(k, False) for k in names}
            try:
                env = gym.make(env_id, **{**env_kwargs, **change})
            except (TypeError, ValueError):
                continue
            shape = env.observation_space.shape
            env.close()
            if shape == tuple(model_shape):
                return change
    return None


def check_observation_shape(policy: Policy, env: Any, label: str) -> None:
    """A one-line ``ValueError`` when ``env``'s observations do not have the shape a trained
    ``policy`` takes: both shapes, and the env kwargs that would fix it (``--env-kwargs`` at
    the command line).  Baselines take any observation."""
    from evertgym.env.eversion_env import OBSERVATION_KWARGS

    model = getattr(policy, "model", None)
    if model is None:
        return
    want, got = tuple(getattr(policy, "env_observation_shape", model.observation_space.shape)), tuple(env.observation_space.shape)
    if want == got:
        return
    env_id = env.spec.id if env.spec is not None else type(env.unwrapped).__name__
    kwargs = {k: v for k, v in (env.spec.kwargs if env.spec is not None else {}).items() if k in OBSERVATION_KWARGS}
    fix = observation_fix(want, env_id, kwargs) if env.spec is not None else None
    how = (f"pass --env-kwargs '{json.dumps(fix)}' (env_kwargs={fix!r} in Python)" if fix is not None
           else "no observation flag of the env gives that shape: was it trained on another env?")
    raise ValueError(f"policy {label!r} takes observations of shape {want} but {env_id} gives {got}: {how}")


def _meta_engine(meta: dict) -> str | None:
    """The engine a model's metadata says it was trained on (None without metadata)."""
    from evertgym.env.eversion_env import engine_of

    if not meta:
        return None
    return str(meta.get("engine") or engine_of(meta.get("env_kwargs", {})))


def trained_engine(desc: str | dict) -> str | None:
    """The simulator engine a trained policy (a description :func:`make_policy` takes) was trained
    on, from its metadata (:func:`model_meta`; only JSON is read); None for a baseline or a model
    without metadata."""
    d = policy_desc(desc)
    name = d.get("name")
    if name == "agent":
        path = resolve_policy_path(d["path"])
    elif name in shipped_policies():
        path = resolve_policy_path(name)
    else:
        return None
    return _meta_engine(model_meta(path))


def _names_engine(env_kwargs: dict) -> bool:
    from evertgym.sim import SimConfig

    sim = env_kwargs.get("sim_config")
    return isinstance(sim, SimConfig) or (isinstance(sim, dict) and "engine" in sim)


def _with_engine(env_kwargs: dict, engine: str) -> dict:
    sim = env_kwargs.get("sim_config")
    if sim is not None and not isinstance(sim, dict):
        import dataclasses

        return {**env_kwargs, "sim_config": dataclasses.replace(sim, engine=engine)}
    return {**env_kwargs, "sim_config": {**(sim or {}), "engine": engine}}


def engine_mismatch(label: str, trained: str, running: str, override: str, python: bool = False) -> str:
    """One line: a model trained on one engine about to run on another, and the two ways on
    (command-line flags, or Python arguments with ``python=True``)."""
    fix = (f"make the env with load_policy's env_kwargs (sim_config={{'engine': {trained!r}}})" if python
           else f"pass --env-kwargs '{{\"sim_config\": {{\"engine\": \"{trained}\"}}}}'")
    return (f"policy {label!r} was trained on the {trained} engine but the env runs the {running} engine: {fix} to run it "
            f"on its own engine, or {override} to run it on the {running} engine anyway")


def on_trained_engine(policies: list, env_kwargs: dict | None, allow_mismatch: bool = False,
                      override: str = "--allow-engine-mismatch") -> dict:
    """The env kwargs on which ``policies`` (descriptions) run: ``env_kwargs`` when they name an
    engine, else with the engine the trained policies among them were trained on (when it is not the
    default already).  Raises a one-line ``ValueError`` when a trained policy would run on another
    engine than its own (policies trained on different engines, or ``env_kwargs`` naming another),
    naming the difference and ``override``; ``allow_mismatch=True`` runs them anyway."""
    from evertgym.env.eversion_env import engine_of

    kwargs = dict(env_kwargs or {})
    engines = {str(p if isinstance(p, str) else p.get("name", p)): e for p in policies if (e := trained_engine(p)) is not None}
    if not engines or allow_mismatch:
        return kwargs
    if not _names_engine(kwargs) and len(set(engines.values())) == 1:
        engine = next(iter(engines.values()))
        return kwargs if engine == engine_of(kwargs) else _with_engine(kwargs, engine)
    running = engine_of(kwargs)
    if not _names_engine(kwargs):
        trained = ", ".join(f"{label} on the {engine}" for label, engine in engines.items())
        raise ValueError(f"the trained policies were trained on different engines ({trained}): run them one engine at a time, "
                         f"or pass {override} to run them all on the {running} engine")
    for label, engine in engines.items():
        if engine != running:
            raise ValueError(engine_mismatch(label, engine, running, override))
    return kwargs


class SB3Policy(Policy):
    """A saved stable-baselines3 model (``.zip``), with its VecNormalize statistics if they
    lie beside it (:func:`vecnormalize_path`), and the env it was trained with (:func:`model_meta`).

    Actions are the policy's mean (``deterministic=True``) or drawn from its Gaussian
    (PPO only) with a generator seeded by each episode's seed, so a stochastic evaluation
    is repeatable too.  ``deterministic=None`` takes the mode the model was shipped with
    (``"deterministic"`` in ``<stem>_env.json``; default True).

    A residual model (its ``_env.json`` names a ``residual`` rule, :mod:`evertgym.agents.residual`)
    is played with its rule: the rule acts, the model sees the observation with the rule's action
    appended, and the action played is the rule's corrected by the model's.

    The zip and the ``.pkl`` are code (pickles): they load only if their SHA-256 is in the
    manifest of shipped policies or ``trust=True`` (:mod:`evertgym.agents.trust`).
    """

    name = "agent"

    def __init__(self, path: str | Path, deterministic: bool | None = None, trust: bool = False):
        require("a trained policy", "stable_baselines3", "torch")
        from stable_baselines3 import PPO, SAC

        from evertgym.agents.trust import check_trusted
        from evertgym.env.eversion_env import OBSERVATION_KWARGS

        path = Path(path)
        if not path.is_file():
            raise ValueError(f"policy path = {str(path)!r} is not a file")
        self.path = path
        stats = vecnormalize_path(path)
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
        shipped = model_meta(path)
        #: the env id the model was trained on (None when nothing beside the model says)
        self.env_id: str | None = shipped.get("env_id")
        #: env kwargs the model was trained with; evaluation applies only the observation
        #: flags among them (``observation_kwargs``), so every policy meets the same physics
        self.env_kwargs = shipped.get("env_kwargs", {})
        self.observation_kwargs = {k: v for k, v in self.env_kwargs.items() if k in OBSERVATION_KWARGS}
        #: the simulator engine it was trained on (None when nothing beside the model says)
        self.engine: str | None = _meta_engine(shipped)
        #: whether ``reset`` refuses an env on another engine (:func:`evertgym.agents.load_policy` sets it)
        self.check_engine = False
        self.deterministic = bool(shipped.get("deterministic", True)) if deterministic is None else bool(deterministic)
        if not self.deterministic and not isinstance(self.model, PPO):
            raise ValueError(f"policy path = {str(path)!r}: stochastic actions are supported for PPO models only")
        #: the rule a residual model corrects (None for a plain model) and its spec
        self.residual = check_residual(shipped.get("residual"))
        self.rule: Policy | None = None
        if self.residual is not None:
            if self.env_id is None:
                raise ValueError(f"policy path = {str(path)!r}: a residual model needs the env id it was trained on (its _env.json)")
            self.rule = make_rule(self.residual, self.env_id)
        shape = tuple(self.model.observation_space.shape or ())
        #: the shape of the env's observation the policy takes (the model's, less the rule's action of a residual)
        self.env_observation_shape = (shape[0] - 1,) if self.rule is not None else shape
        self.rng = np.random.default_rng(0)
        self.obs_rms = None
        if stats.exists():
            import pickle

            with open(stats, "rb") as fh:
                vn = pickle.load(fh)
            self.obs_rms, self.clip_obs, self.epsilon = vn.obs_rms, vn.clip_obs, vn.epsilon

    def reset(self, env) -> None:
        check_observation_shape(self, env, str(self.path))
        running = getattr(getattr(env.unwrapped, "sim_config", None), "engine", None)
        if self.check_engine and self.engine is not None and running is not None and running != self.engine:
            raise ValueError(engine_mismatch(str(self.path), self.engine, running, "load_policy(..., allow_engine_mismatch=True)",
                                             python=True))
        super().reset(env)
        seed = getattr(env.unwrapped, "np_random_seed", None)
        self.rng = np.random.default_rng(None if seed is None or seed < 0 else int(seed))
        if self.rule is not None:
            self.rule.reset(env)

    def act(self, obs, info):
        if self.rule is None:
            return self._act(np.asarray(obs, dtype=np.float32))
        assert self.residual is not None
        base = self.rule.act(obs, info)
        return combine(base, self._act(with_base(obs, base)), self.residual["scale"])

    def _act(self, x):
        """The model's action for observation ``x`` (normalised here)."""
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


def shipped_policies() -> list[str]:
    """Names of the shipped trained policies (``load_policy`` accepts each)."""
    return sorted(p.parent.name for p in shipped_dir().glob("*/final.zip"))


def policy_cards() -> list[dict]:
    """One row per shipped policy (:func:`shipped_policies`): ``name``, ``env_id``, the
    observation flags it was trained with (``observations``), whether it acts by its mean
    (``deterministic``), its training config (``config``, a path; None if not shipped) and
    its held-out success (``held_out``: ``episodes``, ``successes``, ``ci_low``,
    ``ci_high``, the evaluation's ``env_kwargs``, ``engine`` and ``source``, from the shipped
    ``held_out.json`` written by ``python -m evertgym.agents.held_out``; None if not listed), the engine
    it was trained on (``engine``: its ``final_env.json``'s, else the one its ``sim_config``
    names, else the default) and whether it senses the tip (``senses_tip``: a tip force sensor,
    which an operator does not have).  Only JSON is read: no model is loaded."""
    from evertgym.env.eversion_env import OBSERVATION_KWARGS, engine_of

    index = shipped_dir() / "held_out.json"
    held_out = json.loads(index.read_text(encoding="utf-8"))["policies"] if index.is_file() else {}
    rows = []
    for name in shipped_policies():
        meta = model_meta(shipped_dir() / name / "final.zip")
        config = shipped_dir() / f"{name}.toml"
        rows.append({
            "name": name, "env_id": meta.get("env_id"),
            "observations": {k: v for k, v in meta.get("env_kwargs", {}).items() if k in OBSERVATION_KWARGS},
            "deterministic": bool(meta.get("deterministic", True)), "config": str(config) if config.is_file() else None,
            "held_out": held_out.get(name),
            "engine": meta.get("engine") or engine_of(meta.get("env_kwargs", {})),
            "senses_tip": bool(meta.get("env_kwargs", {}).get("tip_sensing", False)),
            "residual": meta.get("residual"),
        })
    return rows


def resolve_policy_path(name_or_path: str | Path) -> Path:
    """``"colon_ppo_operator"`` -> the shipped ``agents/colon_ppo_operator/final.zip``; a run folder -> its
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


def refuse_trust_field(desc: dict, field: str = "policy") -> None:
    """One line if a policy description holds ``"trust"``: trust to unpickle a model comes only from
    the person running the code (``trust=True``, ``--trust-model``), never from a spec, file or store."""
    if "trust" in desc:
        raise ValueError(f"{field} field 'trust' = {desc['trust']!r:.40} is not allowed: a description never turns on "
                         "loading an untrusted model (model files are code); pass --trust-model at the command line or "
                         "trust=True in Python")


def make_policy(desc: dict | str, trust: bool = False) -> Policy:
    """``{"name": "constant", "pressure_kpa": 3}``, ``"operator"``, ``{"name": "agent", "path": ...,
    "deterministic": ...}`` or the path of a saved model, optionally with its action mode
    (``"model.zip:stochastic"``, ``"model.zip:deterministic"``), or a shipped policy by name
    (``"colon_ppo_operator"``).  A saved model loads only if it is a shipped policy or the caller sets
    ``trust``; a description never carries trust (a ``"trust"`` field is refused: it is data,
    and whoever wrote it is not the person running the code)."""
    desc = policy_desc(desc)
    refuse_trust_field(desc)
    name = desc.pop("name", None)
    if name == "agent":
        return SB3Policy(desc["path"], desc.get("deterministic"), trust=trust)
    if name is None:
        raise ValueError("policy must have a name: constant, operator, cycle, deflate, tuned or agent")
    if name in shipped_policies():  # a shipped trained policy by name, e.g. "colon_ppo_operator"
        return SB3Policy(resolve_policy_path(name), desc.get("deterministic"), trust=trust)
    if name not in BASELINES and name != "tuned":
        raise ValueError(f"unknown policy {name!r}: allowed a baseline {sorted(BASELINES) + ['tuned']}, "
                         f"a shipped policy {shipped_policies()} (evertgym policies lists them) or a saved model (.zip)")
    return make_baseline(name, **desc)
