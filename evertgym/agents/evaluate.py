"""Side-by-side evaluation of policies on the same held-out episodes.

The episodes run through the scoring layer's backends (:mod:`evertgym.scoring.backends`):
one episode is one :class:`~evertgym.scoring.spec.TrialSpec` whose ``scene`` names the env id
and its kwargs, so evaluation and scored trials share one process-pool runner.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from evertgym.agents.baselines import Policy, run_episode
from evertgym.agents.policies import (
    SB3Policy,
    check_observation_shape,
    for_env,
    make_policy,
    on_trained_engine,
    resolve_policy_path,
    shipped_policies,
)
from evertgym.agents.trust import sha256_of
from evertgym.agents.tuned import tuned_file
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, engine_of
from evertgym.limits import MAX_EPISODES
from evertgym.scoring.backends import process_backend, serial_backend
from evertgym.scoring.runner import TrialsFailed, run_trials
from evertgym.scoring.spec import TrialSpec, canonical_json
from evertgym.scoring.stats import wilson_interval
from evertgym.scoring.store import ResultStore


@functools.lru_cache(maxsize=4)
def _policy_and_env(policy_json: str, env_id: str, kwargs_json: str, trust: bool = False) -> tuple[Policy, Any]:
    """One policy and env per (policy, env) in each worker: a model loads once, not per episode.
    ``trust`` is the caller's (never the description's: :func:`make_policy` refuses a ``"trust"`` field)."""
    import json

    policy = make_policy(json.loads(policy_json), trust=trust)
    # the engine was settled before any episode (on_trained_engine), with the override if given
    if isinstance(policy, SB3Policy):
        policy.check_engine = False
    # observation flags a trained model needs; they do not change the physics (its other
    # training kwargs, e.g. a randomised lag, do not apply: the evaluation's are the same for all)
    env = gym.make(env_id, **{**json.loads(kwargs_json), **getattr(policy, "observation_kwargs", {})})
    if getattr(policy, "name", "") == "agent":
        import torch

        torch.set_num_threads(1)  # one episode per process: no thread oversubscription
    return policy, env


def episode_trial(spec: TrialSpec, trust: bool = False) -> dict:
    """Trial function of one evaluation episode: ``spec.scene`` is ``{"family": env id,
    "params": env kwargs, "seed": episode seed}``; episode and scene seed are ``spec.seed``.
    The episode's info, plus ``stall_position_mm``: the insertion length (mm) where a failed
    episode ended, ``None`` for a success (the scoring store's trial-result contract)."""
    policy, env = _policy_and_env(canonical_json(spec.policy), spec.scene["family"], canonical_json(spec.scene["params"]), trust)
    info = run_episode(env, policy, spec.seed, options={"scene_seed": spec.seed})
    return {**info, "stall_position_mm": None if info["success"] else float(info["insertion_length_mm"])}


def trusted_episode_trial(spec: TrialSpec) -> dict:
    """:func:`episode_trial` with ``trust=True``, sent to the workers when the caller opted in."""
    return episode_trial(spec, trust=True)


def _bend_columns(infos: list[dict]) -> dict:
    """Peak pressure at the bend (mean over the episodes whose tip reached a bend; NaN if none
    did) and how many episodes reached their overall peak before the tip reached a bend (a
    start-up or approach peak, not one the bend asked for)."""
    at_bend = [i["peak_pressure_bend_kpa"] for i in infos if i["bend_entry_time_s"] is not None]
    before = sum(1 for i in infos if i["bend_entry_time_s"] is None or i["peak_pressure_time_s"] < i["bend_entry_time_s"])
    return {"mean_peak_pressure_bend_kpa": float(np.mean(at_bend)) if at_bend else math.nan,
            "bend_reached_episodes": len(at_bend), "peak_before_bend_episodes": before}


def _identities(descs: list[dict], env_kwargs: dict | None) -> list[dict]:
    """What makes a stored episode reusable beyond its spec: the engine it runs on (the default's
    when ``env_kwargs`` do not name one), for a trained model its file's SHA-256, and for ``tuned``
    the parameters its file holds (so a retuned operator is played again, not read back)."""
    engine = engine_of(env_kwargs or {})
    out = []
    for d in descs:
        ident: dict[str, Any] = {"engine": engine}
        name = d.get("name")
        if name == "agent" or name in shipped_policies():
            ident["model_sha256"] = sha256_of(resolve_policy_path(d["path"] if name == "agent" else name))
        elif name == "tuned":
            ident["tuned_params"] = tuned_file(d.get("path"), d.get("env_id"))["best"]["params"]
        out.append(ident)
    return out


def _unconverged(info: dict) -> int:
    """An episode's quasi-static solves that ended above the tolerance (an episode stored before the key: its failures)."""
    return int(info.get("unconverged_solves", info.get("solve_failures", 0)) or 0)


def _label(desc: str | dict) -> str:
    return desc if isinstance(desc, str) else str(desc.get("name", desc))


#: The quasi-static engine's settings an episode is replayed under by ``evaluate(check_outcomes=True)``, each
#: as (SimConfig field, divisor of the env's own value): neither means anything physical, so an episode whose
#: outcome moves with one is undecided (the colon's knife edge, docs/quasistatic.md).
OUTCOME_CHECKS: tuple[tuple[str, float], ...] = (("solver_tolerance", 10.0), ("growth_increment_m", 2.0))


def outcome_check_kwargs(env_kwargs: dict | None) -> list[dict]:
    """The env kwargs of each replay of :data:`OUTCOME_CHECKS`: ``env_kwargs`` with the one setting divided.

    Raises ``ValueError`` (one line) for the dynamic engine, which has no such settings, or for a
    setting that its divisor takes out of its allowed range."""
    import dataclasses

    from evertgym.sim.config import SimConfig

    kwargs = dict(env_kwargs or {})
    engine = engine_of(kwargs)
    if engine != "quasistatic":
        raise ValueError(f"check_outcomes needs the quasi-static engine (it replays its solver settings); "
                         f"the env kwargs run engine = {engine!r}")
    sim = kwargs.get("sim_config")
    fields = dataclasses.asdict(sim) if isinstance(sim, SimConfig) else dict(sim or {})
    base = SimConfig(**fields)
    out = []
    for name, divisor in OUTCOME_CHECKS:
        changed = {**fields, name: getattr(base, name) / divisor}
        try:
            SimConfig(**changed)
        except ValueError as e:
            raise ValueError(f"check_outcomes: {name} / {divisor:g} = {changed[name]:g} is not allowed ({e})") from None
        out.append({**kwargs, "sim_config": changed})
    return out


def evaluate(policies: list[str | dict], env_id: str, episodes: int, env_kwargs: dict | None = None,
             seed_base: int = HELD_OUT_SEED_BASE, workers: int = 1, trust: bool = False,
             progress: bool = False, db: str | Path | None = None, check_outcomes: bool = False,
             allow_engine_mismatch: bool = False) -> list[dict]:
    """One row per policy: success rate (Wilson 95%), mean time to goal, peak pressure and
    max contact force (and ``unconverged_solves``, ``episodes_unconverged``: the quasi-static solves
    that ended above the tolerance and the episodes that had any) over ``episodes`` episodes whose seeds (and scene seeds) are
    ``seed_base + i``, the same for every policy.  ``tuned`` is the operator tuned on
    ``env_id`` (:func:`evertgym.agents.policies.for_env`).  ``workers > 1`` spreads the episodes
    over that many processes; every episode is seeded, so the rows do not change.
    ``trust=True`` loads saved models that are not shipped policies (model files are code).
    ``progress`` shows a bar over all policies' episodes (on stderr).  ``db``: a SQLite result
    store (:class:`~evertgym.scoring.store.ResultStore`) that keeps every finished episode, so a
    killed evaluation resumes where it stopped; an episode's identity holds the engine it runs
    on and, for a trained model, the SHA-256 of its file, so a store is never reused for
    another engine or a retrained model.

    ``check_outcomes=True`` (quasi-static engine only) also plays every episode under each setting of
    :data:`OUTCOME_CHECKS` (tolerance / 10, growth increment / 2; three times the episodes).  An episode
    whose success differs between the plays is undecided: the settings, not the physics, choose its
    outcome.  Each row then adds ``undecided_episodes``, ``undecided_seeds`` and ``success_low`` /
    ``success_high``: the success rate with every undecided episode counted a failure / a success.
    The other columns stay those of the env's own settings.

    A trained model runs on the simulator engine it was trained on: without an engine in
    ``env_kwargs`` the episodes run on the trained models' engine
    (:func:`~evertgym.agents.policies.on_trained_engine`); a model trained on another engine
    than the one ``env_kwargs`` name, or models trained on different engines, raise a one-line
    ``ValueError`` unless ``allow_engine_mismatch=True``."""
    if not (isinstance(episodes, int) and 1 <= episodes <= MAX_EPISODES):
        raise ValueError(f"episodes = {episodes!r} is out of range: allowed integers in [1, {MAX_EPISODES}]")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers = {workers!r} is out of range: allowed integers >= 1")
    # "tuned" means the parameters tuned on this env; baselines are built once here, so a
    # bad parameter or a missing tuned file fails before any episode, in one line
    descs = [for_env(desc, env_id) for desc in policies]
    env_kwargs = on_trained_engine(descs, env_kwargs, allow_engine_mismatch, "allow_engine_mismatch=True")
    models = {"agent", *shipped_policies()}
    for desc, d in zip(policies, descs):
        if d.get("name") not in models:
            make_policy(d)
        else:  # a trained model meets its env's observations here, not in a worker's traceback
            policy, env = _policy_and_env(canonical_json(d), env_id, canonical_json(dict(env_kwargs or {})), trust)
            check_observation_shape(policy, env, _label(desc))
    plays = [env_kwargs] + (outcome_check_kwargs(env_kwargs) if check_outcomes else [])
    results = [_play(policies, descs, env_id, episodes, kw, seed_base, workers, trust, progress, db) for kw in plays]
    rows = []
    for k, desc in enumerate(policies):
        episode_infos = results[0][k]
        wins = [i for i in episode_infos if i["success"]]
        lo, hi = wilson_interval(len(wins), episodes)
        row = {
            "policy": _label(desc),
            "episodes": episodes,
            "successes": len(wins),
            "success_rate": len(wins) / episodes,
            "ci_low": lo,
            "ci_high": hi,
            "mean_time_to_goal_s": float(np.mean([i["time_s"] for i in wins])) if wins else math.nan,
            "mean_peak_pressure_kpa": float(np.mean([i["peak_pressure_kpa"] for i in episode_infos])),
            "mean_max_contact_force_n": float(np.mean([i["max_contact_force_n"] for i in episode_infos])),
            **_bend_columns(episode_infos),
            # the quasi-static solves that ended above the tolerance, and the episodes that had any
            "unconverged_solves": sum(_unconverged(i) for i in episode_infos),
            "episodes_unconverged": sum(1 for i in episode_infos if _unconverged(i)),
        }
        if check_outcomes:
            success = [[r[k][i]["success"] for r in results] for i in range(episodes)]
            undecided = [seed_base + i for i, s in enumerate(success) if len(set(s)) > 1]
            passes = sum(1 for s in success if all(s))
            row.update(undecided_episodes=len(undecided), undecided_seeds=undecided,
                       success_low=passes / episodes, success_high=(passes + len(undecided)) / episodes)
        rows.append(row)
    return rows


def _play(policies: list[str | dict], descs: list[dict], env_id: str, episodes: int, env_kwargs: dict | None,
          seed_base: int, workers: int, trust: bool, progress: bool, db: str | Path | None) -> list[list[dict]]:
    """Every policy's ``episodes`` episodes under ``env_kwargs``: per policy, the episodes' infos in seed order."""
    from tqdm import tqdm

    identity = _identities(descs, env_kwargs) if db is not None else [{} for _ in policies]
    # trust reaches only a saved model's loader, through the trial function (never through the spec):
    # the stored episodes are found with or without it
    trial_fn = trusted_episode_trial if trust else episode_trial
    specs = [
        TrialSpec(design={}, design_name=env_id,
                  scene={"family": env_id, "params": dict(env_kwargs or {}), "seed": seed_base + i, **ident},
                  policy=d, seed=seed_base + i, index=i,
                  group=_label(desc))
        for desc, d, ident in zip(policies, descs, identity) for i in range(episodes)
    ]
    infos: dict[str, dict] = {}
    if db is not None:
        with ResultStore(db) as store:
            try:
                records = run_trials(specs, trial_fn, store, backend="process" if workers > 1 else "serial",
                                     workers=workers, progress=progress)
            except TrialsFailed as e:
                f = e.failures[0]
                raise RuntimeError(f"policy {f.spec.group!r}, episode seed {f.spec.seed}: {f.error}") from None
            infos = {r.spec.key: r.result for r in records}
    else:
        backend = process_backend if workers > 1 else serial_backend
        for spec, out in tqdm(backend(trial_fn, specs, min(workers, len(specs))), total=len(specs), desc="eval",
                              unit="episode", disable=not progress):
            if out.error is not None:
                raise RuntimeError(f"policy {spec.group!r}, episode seed {spec.seed}: {out.error}")
            infos[spec.key] = out.result
    return [[infos[s.key] for s in specs[k * episodes:(k + 1) * episodes]] for k in range(len(policies))]
