"""Training pressure policies with stable-baselines3 (CPU torch).

A config is a TOML file in ``agents/`` in the spirit of rl-zoo3's hyperparameter files::

    env_id = "evertgym/Colon-v0"
    algo = "ppo"                 # ppo or sac
    seed = 0
    n_envs = 2                   # SubprocVecEnv workers
    n_timesteps = 200000
    normalize = true             # VecNormalize (observations and rewards)
    checkpoint_freq = 10000      # env steps between checkpoints
    eval_episodes = 20           # on held-out scene seeds after training
    deterministic = true         # act by the policy's mean (false: sample it; recorded in final_env.json)
    residual = "tuned"           # optional: learn a correction of this baseline (evertgym.agents.residual)
    residual_scale = 0.25        # its largest correction, in action units (0.25 = 1 kPa); zoo = false
    [env_kwargs]                 # overrides of the preset
    [hyperparams]                # passed to the SB3 algorithm
    learning_rate = 3e-4
    [hyperparams.policy_kwargs]
    net_arch = [64, 64]

``train(config)`` writes ``runs/<name>/``: TensorBoard logs, ``checkpoints/`` (model,
VecNormalize statistics and the env it was trained on, ``model_<N>_steps_env.json``, every
``checkpoint_freq`` steps), ``final.zip`` (+ its ``final_vecnormalize.pkl`` and
``final_env.json``) and ``eval.json``.  Training the same config into the same folder again
continues from the newest checkpoint and the step counter (SB3's
``reset_num_timesteps=False``): an interrupted run resumes, and a finished one is not
trained again (:func:`run_status`).  ``resume=True`` insists on a checkpoint;
``resume=False`` insists on a fresh folder.

Scene seeds: training episodes draw their scenes from the env's own ``np_random``, seeded
``seed + rank`` at the first reset of a run started from its config (so such a run is
repeatable); evaluation uses scene seeds from :data:`HELD_OUT_SEED_BASE` upwards, which
training never draws (:class:`evertgym.env.EversionEnv` keeps training seeds below it).
A resumed run continues with fresh episodes: loading a checkpoint re-seeds everything with
the config's ``seed`` (SB3 does), which would replay the scenes (and the exploration noise)
of the run's start, so the resumed run re-seeds the envs, the action noise and the global
generators with :func:`resume_seed` of the seed and the checkpoint's step count instead
(written to ``config.json`` as ``resume``).  Resuming twice from the same checkpoint
plays the same episodes: the ones the run lost with the kill.
"""

from __future__ import annotations

import json
import re
import sys
import time
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

import gymnasium as gym
import numpy as np

from evertgym._extras import require
from evertgym._validate import check_int
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, engine_of

ALGOS = ("ppo", "sac")
#: finished episodes the training bar's return and success rate average over
ROLLING_EPISODES = 100


def resolve_config(name_or_path: str | Path) -> Path:
    """A training config's file: ``name_or_path`` itself when it is a file, else the shipped config of
    that name (``"ubend_ppo_operator"`` -> ``agents/ubend_ppo_operator.toml``).  Raises ``ValueError`` naming the shipped ones."""
    from evertgym.agents.tuned import shipped_dir

    path = Path(name_or_path)
    if path.is_file():
        return path
    shipped = shipped_dir() / f"{name_or_path}.toml"
    if path.suffix == "" and shipped.is_file():
        return shipped
    names = sorted(p.stem for p in shipped_dir().glob("*.toml"))
    raise ValueError(f"config = {str(name_or_path)!r}: neither a file nor a shipped config; shipped: {names}")


def load_config(path: str | Path, seed: int | None = None, timesteps: int | None = None) -> dict:
    """Read and validate a training config (errors name the field); ``path`` may name a shipped
    config (:func:`resolve_config`).  ``seed`` replaces the config's seed and names the run
    ``<name>_seed<seed>``, so the seeds of one config train side by side into their own folders.
    ``timesteps`` replaces ``n_timesteps`` and names the run ``<name>_<timesteps>steps``: a short
    try never resumes, or counts as, the full run."""
    path = resolve_config(path)
    try:
        cfg = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise ValueError(f"{path}: cannot read the config: {e}") from None
    cfg.setdefault("name", path.stem)
    if seed is not None:
        cfg["seed"] = check_int("seed", seed, 0, 2**31 - 1)
        cfg["name"] = f"{cfg['name']}_seed{seed}"
    if timesteps is not None:
        cfg["n_timesteps"] = check_int("timesteps", timesteps, 1, 10**9)
        cfg["name"] = f"{cfg['name']}_{timesteps}steps"
    # the run folder is <out>/<name>: a plain folder name keeps every output inside --out
    if not (isinstance(cfg["name"], str) and re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}", cfg["name"])):
        raise ValueError(f"{path}: name = {cfg['name']!r} is not allowed: allowed a folder name of letters, digits, "
                         "'_', '-', '.' (no path separators, not starting with '.'), at most 100 characters")
    for key, kind in (("env_id", str), ("algo", str), ("n_timesteps", int)):
        if not isinstance(cfg.get(key), kind):
            raise ValueError(f"{path}: {key} is required ({kind.__name__})")
    if not isinstance(cfg.get("zoo", True), bool):
        raise ValueError(f"{path}: zoo = {cfg['zoo']!r}: allowed true or false")
    if not isinstance(cfg.get("deterministic", True), bool):
        raise ValueError(f"{path}: deterministic = {cfg['deterministic']!r}: allowed true or false")
    if "residual" in cfg or "residual_scale" in cfg:  # a learned correction of a rule (evertgym.agents.residual)
        from evertgym.agents.residual import check_residual, make_rule

        if "residual" not in cfg:
            raise ValueError(f"{path}: residual_scale = {cfg['residual_scale']!r} without residual: allowed only with "
                             "residual = a baseline (e.g. \"tuned\")")
        try:
            spec = check_residual({"rule": cfg["residual"], "scale": cfg.get("residual_scale", 0.25)})
            assert spec is not None
            make_rule(spec, str(cfg.get("env_id")))  # the rule's parameters (and a tuned file for the env) exist
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
        if cfg.get("zoo", True):
            raise ValueError(f"{path}: zoo = true with residual = {cfg['residual']!r}: rl-zoo3 cannot play a residual "
                             "policy's rule; allowed zoo = false")
        cfg["residual_spec"] = spec
    if cfg["algo"] not in ALGOS:
        raise ValueError(f"{path}: algo = {cfg['algo']!r}: allowed {ALGOS}")
    for key, lo, hi in (("n_envs", 1, 64), ("n_timesteps", 1, 10**9), ("checkpoint_freq", 1, 10**9), ("eval_episodes", 0, 10**6)):
        v = cfg.get(key, lo)
        if not (isinstance(v, int) and lo <= v <= hi):
            raise ValueError(f"{path}: {key} = {v!r} is out of range: allowed integers in [{lo}, {hi}]")
    return cfg


def _make_env_fn(env_id: str, env_kwargs: dict, residual: dict | None = None):
    """An env factory for SB3's vector envs.  It does not reset the env: the algorithm's
    first ``VecEnv.reset()`` seeds env ``rank`` with the run's env seed ``+ rank``.  With a
    ``residual`` spec the learner acts on a correction of its rule
    (:class:`~evertgym.agents.residual.ResidualOnRule`)."""

    def make():
        from stable_baselines3.common.monitor import Monitor

        env = gym.make(env_id, **env_kwargs)
        if residual is not None:
            from evertgym.agents.residual import ResidualOnRule, make_rule

            env = ResidualOnRule(env, make_rule(residual, env_id), residual["scale"])
        return Monitor(env)

    return make


def resume_seed(seed: int, num_timesteps: int) -> int:
    """The seed a run resumed at ``num_timesteps`` gives its envs (``+ rank``), its action
    noise and the global generators: a hash of the config's ``seed`` and the step count
    (a uint32, never ``seed`` itself for a checkpoint after step 0), so the resumed run's
    scene draws are a fresh stream, not the run's start again."""
    if num_timesteps <= 0:
        return int(seed)
    return int(np.random.SeedSequence([int(seed) & 0xFFFFFFFF, int(num_timesteps), 0x5EED]).generate_state(1)[0])


def _checkpoints(ckpt_dir: Path, normalize: bool) -> list[tuple[Path, int]]:
    """Complete-looking checkpoints, newest first: a zip whose archive reads back (and its
    VecNormalize statistics when the run normalises)."""
    import zipfile

    found = []
    for p in ckpt_dir.glob("model_*_steps.zip"):
        m = re.match(r"model_(\d+)_steps\.zip", p.name)
        if not m:
            continue
        try:
            with zipfile.ZipFile(p) as z:
                if z.testzip() is not None:
                    continue
        except (zipfile.BadZipFile, OSError, EOFError):
            continue
        steps = int(m.group(1))
        if normalize and not (ckpt_dir / f"model_vecnormalize_{steps}_steps.pkl").exists():
            continue
        found.append((p, steps))
    return sorted(found, key=lambda c: -c[1])


def _load_checkpoint(ckpt_dir: Path, normalize: bool, load):
    """``load(zip, pkl_or_None)`` on the newest checkpoint that loads; a torn zip or pkl
    (EOFError, UnpicklingError, a bad archive) falls back to the one before.  Only the
    run's own ``checkpoints/`` folder is read: files the run wrote itself."""
    import pickle
    import zipfile

    errors = []
    for ckpt, steps in _checkpoints(ckpt_dir, normalize):
        stats = ckpt_dir / f"model_vecnormalize_{steps}_steps.pkl" if normalize else None
        try:
            return load(ckpt, stats)
        except (EOFError, pickle.UnpicklingError, zipfile.BadZipFile, ValueError, KeyError) as e:
            errors.append(f"{ckpt.name}: {type(e).__name__}")
    raise ValueError(f"--resume: no complete checkpoint in {ckpt_dir}" + (f" (torn: {', '.join(errors)})" if errors else ""))


def run_status(config_path: str | Path, out_dir: str | Path = "runs", seed: int | None = None, timesteps: int | None = None) -> dict:
    """What training the config into ``out_dir`` would do: ``{"run_dir", "n_timesteps",
    "checkpoint_steps", "finished"}``.  ``checkpoint_steps`` is the step count of the newest
    complete checkpoint (None without one); ``finished`` says the run folder holds a final
    model trained to the config's ``n_timesteps`` (its ``eval.json``).  Raises ``ValueError``
    when the folder has checkpoint files of which none is complete."""
    cfg = load_config(config_path, seed, timesteps)
    run_dir = Path(out_dir) / cfg["name"]
    ckpt_dir = run_dir / "checkpoints"
    found = _checkpoints(ckpt_dir, cfg.get("normalize", False)) if ckpt_dir.is_dir() else []
    if not found and ckpt_dir.is_dir() and any(ckpt_dir.glob("model_*_steps.zip")):
        raise ValueError(f"{ckpt_dir}: checkpoint files but none complete (a model zip with its statistics): "
                         f"remove {run_dir} to train from step 0")
    finished = False
    summary = run_dir / "eval.json"
    if (run_dir / "final.zip").is_file() and summary.is_file():
        try:
            finished = int(json.loads(summary.read_text(encoding="utf-8"))["num_timesteps"]) >= cfg["n_timesteps"]
        except (ValueError, KeyError, TypeError):
            finished = False
    return {"run_dir": str(run_dir), "n_timesteps": cfg["n_timesteps"], "checkpoint_steps": found[0][1] if found else None,
            "finished": finished}


def train(config_path: str | Path, out_dir: str | Path = "runs", resume: bool | None = None, progress: bool = True,
          seed: int | None = None, timesteps: int | None = None) -> dict:
    """Train (or resume) the config's agent; returns the final evaluation summary with the
    training's wall time (``train_wall_s``, s), the run folder (``run_dir``), the step count
    it resumed from (``resumed_from_steps``, None for a fresh run) and ``already_trained``.
    ``seed`` and ``timesteps`` override the config's (see :func:`load_config`).

    ``resume=None`` (the default, and the command line without ``--resume``) continues from
    the newest checkpoint of the run folder when it has one and starts at step 0 when it has
    none; a run already trained to ``n_timesteps`` is not trained again (its stored summary
    is returned, ``already_trained`` true).  ``resume=True`` raises ``ValueError`` without a
    checkpoint; ``resume=False`` raises ``ValueError`` when the folder has one (a fresh start
    never overwrites a run: remove the folder, or train into another ``out_dir``/``seed``)."""
    from evertgym.agents.load import require_rl

    require_rl("training")
    require("training (its TensorBoard log)", "tensorboard")
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback
    from stable_baselines3.common.vec_env import (
        DummyVecEnv,
        SubprocVecEnv,
        VecEnv,
        VecNormalize,
    )

    torch.set_num_threads(1)  # small MLPs: threads only fight the env workers for the cores
    cfg = load_config(config_path, seed, timesteps)
    status = run_status(config_path, out_dir, seed, timesteps)
    run_dir = Path(out_dir) / cfg["name"]
    if status["finished"] and resume is not False:
        done = json.loads((run_dir / "eval.json").read_text(encoding="utf-8"))
        return {**done, "run_dir": str(run_dir), "already_trained": True}
    if resume is False and status["checkpoint_steps"] is not None:
        raise ValueError(f"resume = False: {run_dir} already holds a run with a checkpoint at {status['checkpoint_steps']} steps: "
                         "allowed resume=None or True to continue it; remove the folder to train from step 0")
    if resume is False and (run_dir / "final.zip").exists():
        raise ValueError(f"resume = False: {run_dir} already holds a trained model (final.zip): remove the folder to train from step 0")
    resume = status["checkpoint_steps"] is not None if resume is None else resume
    ckpt_dir = run_dir / "checkpoints"
    ckpt_dir.mkdir(parents=True, exist_ok=True)
    n_envs, seed = cfg.get("n_envs", 1), cfg.get("seed", 0)
    residual = cfg.get("residual_spec")
    fns = [_make_env_fn(cfg["env_id"], cfg.get("env_kwargs", {}), residual) for _ in range(n_envs)]
    venv: VecEnv = SubprocVecEnv(fns) if n_envs > 1 else DummyVecEnv(fns)
    algos: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC}
    algo_cls = algos[cfg["algo"]]
    resumed: dict[str, int] | None = None
    if resume:
        def load(ckpt: Path, stats: Path | None) -> tuple[BaseAlgorithm, VecEnv]:
            env = VecNormalize.load(str(stats), venv) if stats is not None else venv
            return algo_cls.load(str(ckpt), env=env, device="cpu", tensorboard_log=str(run_dir / "tb")), env

        model, venv = _load_checkpoint(ckpt_dir, cfg.get("normalize", False), load)
        # SB3's load re-seeded the envs' next reset (and the noise) with the config's seed:
        # the start of the run again.  Continue with fresh episodes instead.
        resumed = {"num_timesteps": int(model.num_timesteps), "env_seed": resume_seed(seed, model.num_timesteps)}
        model.set_random_seed(resumed["env_seed"])
    else:
        if cfg.get("normalize", False):
            venv = VecNormalize(venv, norm_obs=True, norm_reward=True)
        hp = dict(cfg.get("hyperparams", {}))
        policy = hp.pop("policy", "MlpPolicy")
        model = algo_cls(policy, venv, seed=seed, device="cpu", verbose=0, tensorboard_log=str(run_dir / "tb"), **hp)
    (run_dir / "config.json").write_text(json.dumps({"config": cfg, "argv": sys.argv, "resume": resumed}, indent=2, default=str))
    # the observation options the policy was trained with travel with it and its checkpoints
    # (and whether it acts by its mean or by sampling, the config's ``deterministic``)
    meta = {"env_id": cfg["env_id"], "env_kwargs": cfg.get("env_kwargs", {}), "deterministic": cfg.get("deterministic", True),
            "engine": engine_of(cfg.get("env_kwargs", {}))}
    if residual is not None:  # the rule the model corrects travels with it (SB3Policy plays both)
        meta["residual"] = residual

    class _Checkpoints(CheckpointCallback):
        """SB3's checkpoints, each with ``<stem>_env.json`` (the env it was trained on) beside it."""

        def _on_step(self) -> bool:
            go_on = super()._on_step()
            if self.n_calls % self.save_freq == 0:
                Path(self.save_path, f"{self.name_prefix}_{self.num_timesteps}_steps_env.json").write_text(json.dumps(meta, indent=2))
            return go_on

    ckpt_cb = _Checkpoints(
        save_freq=max(1, cfg.get("checkpoint_freq", 10000) // n_envs),
        save_path=str(ckpt_dir),
        name_prefix="model",
        save_vecnormalize=cfg.get("normalize", False),
    )
    callbacks: list[Any] = [ckpt_cb]
    if progress:
        callbacks.append(_TqdmCallback(cfg["n_timesteps"], model.num_timesteps))
    remaining = cfg["n_timesteps"] - model.num_timesteps
    t0 = time.perf_counter()
    if remaining > 0:
        model.learn(total_timesteps=remaining, callback=CallbackList(callbacks), reset_num_timesteps=False, tb_log_name=cfg["name"])
    model.save(str(run_dir / "final"))
    (run_dir / "final_env.json").write_text(json.dumps(meta, indent=2))
    if isinstance(venv, VecNormalize):
        venv.save(str(run_dir / "final_vecnormalize.pkl"))
    venv.close()
    summary: dict[str, Any] = {"num_timesteps": int(model.num_timesteps), "train_wall_s": time.perf_counter() - t0,
                               "run_dir": str(run_dir), "resumed_from_steps": resumed["num_timesteps"] if resumed else None,
                               "already_trained": False}
    if cfg.get("eval_episodes", 0) > 0:
        from evertgym.agents.evaluate import evaluate

        # the run wrote final.zip itself: trusted
        rows = evaluate([str(run_dir / "final.zip"), "operator"], cfg["env_id"], cfg["eval_episodes"], env_kwargs=cfg.get("env_kwargs", {}),
                        trust=True)
        summary["eval"] = rows
    (run_dir / "eval.json").write_text(json.dumps(summary, indent=2))
    return summary


class _TqdmCallback:
    """A tqdm progress bar over env steps (SB3's own needs ``rich``): steps, rate and ETA, and
    the mean return and success rate of the last :data:`ROLLING_EPISODES` finished episodes."""

    def __new__(cls, total: int, start: int):
        from collections import deque

        from stable_baselines3.common.callbacks import BaseCallback
        from tqdm.auto import tqdm

        class _Cb(BaseCallback):
            def _on_training_start(self) -> None:
                self.bar = tqdm(total=total, initial=start, unit="step", desc="train")
                self.returns: deque[float] = deque(maxlen=ROLLING_EPISODES)
                self.successes: deque[bool] = deque(maxlen=ROLLING_EPISODES)

            def _on_step(self) -> bool:
                for done, info in zip(self.locals.get("dones", ()), self.locals.get("infos", ())):
                    if done and "episode" in info:  # Monitor's record of the finished episode
                        self.returns.append(float(info["episode"]["r"]))
                        self.successes.append(bool(info.get("success", False)))
                if self.returns:
                    self.bar.set_postfix({"return": f"{np.mean(self.returns):.2f}", "success": f"{np.mean(self.successes):.2f}",
                                          "episodes": len(self.returns)}, refresh=False)
                self.bar.update(self.training_env.num_envs)
                return True

            def _on_training_end(self) -> None:
                self.bar.close()

        return _Cb()


def held_out_seeds(n: int) -> np.ndarray:
    """Scene seeds for evaluation: never drawn in training."""
    return HELD_OUT_SEED_BASE + np.arange(n)
