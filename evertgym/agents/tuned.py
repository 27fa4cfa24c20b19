"""The tuned heuristic: the operator protocol with the best parameters of a small search,
one set per env, searched on that env's training scenes.

:func:`tune_operator` (run by ``evertgym tune``) tries every point of
:data:`GRID` on the same training episodes of an env and keeps the best: the highest
success rate, then the lowest mean peak pressure.  Training episodes are
``reset(seed=k)`` for ``k < episodes``: their scene seeds are drawn from the env's
generator below :data:`~evertgym.env.eversion_env.HELD_OUT_SEED_BASE`, so they are never
the held-out evaluation scenes (checked on every episode).  The result goes to
:func:`tuned_path` of the env: ``agents/tuned_operator_<name>.json`` (``Colon-v0``,
``Tortuous-v0``, ...), except UBend-v0, whose file keeps its original name
``agents/tuned_operator.json``.  :func:`load_tuned` builds the policy from it.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from evertgym.agents.baselines import OperatorProtocol, run_episode

#: the search: start pressure (kPa), step (kPa), stall window (s), relaxation (kPa/s)
GRID: dict[str, list[float]] = {"start_kpa": [1.0, 2.0, 3.0], "step_kpa": [0.25, 0.5, 1.0], "stall_s": [0.5, 1.0],
                                "relax_kpa_per_s": [0.0, 0.5]}

#: envs whose tuned file predates per-env files keep its name
_LEGACY_FILES = {"evertgym/UBend-v0": "tuned_operator.json"}


def shipped_dir() -> Path:
    """The shipped ``agents/`` folder: the checkout's, else the installed ``evertgym.shipped_agents``."""
    repo = Path(__file__).resolve().parents[2] / "agents"
    if repo.is_dir():
        return repo
    from importlib.resources import files

    return Path(str(files("evertgym.shipped_agents")))


TUNED_PATH = shipped_dir() / "tuned_operator.json"


def tuned_path(env_id: str, folder: str | Path | None = None) -> Path:
    """The tuned-parameter file of ``env_id`` in ``folder`` (default: the shipped ``agents/``):
    ``tuned_operator_<name>.json`` for ``evertgym/<name>``; UBend-v0's is ``tuned_operator.json``."""
    if not (isinstance(env_id, str) and env_id.strip()):
        raise ValueError(f"env_id = {env_id!r} is not allowed: allowed a registered env id, e.g. 'evertgym/Colon-v0'")
    base = Path(folder) if folder is not None else shipped_dir()
    name = _LEGACY_FILES.get(env_id) or f"tuned_operator_{env_id.split('/')[-1].replace(':', '_')}.json"
    return base / name


def tuned_envs() -> list[str]:
    """The env ids with shipped tuned parameters."""
    envs = set()
    for p in shipped_dir().glob("tuned_operator*.json"):
        try:
            envs.add(str(json.loads(p.read_text())["env"]))
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return sorted(envs)


def tuned_file(path: str | Path | None = None, env_id: str | None = None) -> dict:
    """The tuned-parameter file :func:`load_tuned` reads (same arguments), as a dict."""
    if path:
        p = Path(path)
    elif env_id is not None:
        p = tuned_path(env_id)
        if not p.exists():
            raise ValueError(f"tuned: env_id = {env_id!r} has no tuned operator parameters: tuned for {tuned_envs()}; "
                             f"run evertgym tune --env {env_id}")
    else:
        p = TUNED_PATH
    if not p.exists():
        raise ValueError(f"tuned heuristic file {str(p)!r} does not exist: run evertgym tune --env ENV")
    data = json.loads(p.read_text())
    if env_id is not None and data.get("env") != env_id:
        raise ValueError(f"tuned: {str(p)!r} was tuned on env {data.get('env')!r}, not env_id = {env_id!r}")
    return data


def load_tuned(path: str | Path | None = None, env_id: str | None = None) -> OperatorProtocol:
    """The operator protocol with the parameters tuned on ``env_id`` (its :func:`tuned_path`),
    or those of an explicit ``path``; with neither, the shipped ``tuned_operator.json``
    (tuned on UBend-v0, the default before per-env files).  A file tuned on another env
    than ``env_id`` is refused."""
    data = tuned_file(path, env_id)
    policy = OperatorProtocol(**data["best"]["params"])
    policy.name = "tuned"
    policy.tuned_on = str(data.get("env"))  # type: ignore[attr-defined]
    return policy


def tune_operator(env_id: str, episodes: int, log: str | Path | None = None, grid: dict[str, list[float]] | None = None,
                  on_result: Callable[[dict], Any] | None = None) -> dict:
    """Run every point of ``grid`` (default :data:`GRID`) on the training episodes
    ``reset(seed=k)``, ``k < episodes``, of ``env_id``; returns ``{"env", "episodes", "grid",
    "training_scene_seeds", "best"}``.  Each point's result is appended to ``log`` (JSON
    lines) as it is produced, and points already in it are not rerun: a killed search
    resumes.  ``on_result(record)`` sees each new record.  Raises ``ValueError`` if an
    episode's scene is a held-out one."""
    import gymnasium as gym

    import evertgym.env  # noqa: F401  (registers the presets)
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    if not (isinstance(episodes, int) and not isinstance(episodes, bool) and 1 <= episodes <= 10_000):
        raise ValueError(f"episodes = {episodes!r} is out of range: allowed integers in [1, 10000]")
    grid = dict(GRID if grid is None else grid)
    done: dict[str, dict] = {}
    if log is not None and Path(log).exists():
        for line in Path(log).read_text().splitlines():
            rec = json.loads(line)
            if rec["env"] == env_id and rec["episodes"] == episodes:
                done[json.dumps(rec["params"], sort_keys=True)] = rec
    env = gym.make(env_id)
    scene_seeds = []
    for k in range(episodes):  # the scenes the episodes will play: training ones only
        env.reset(seed=k)
        scene_seeds.append(int(env.unwrapped.scene.spec.seed))  # type: ignore[attr-defined]
        if scene_seeds[-1] >= HELD_OUT_SEED_BASE:
            raise ValueError(f"tuning episode {k} of {env_id} draws scene seed {scene_seeds[-1]}, a held-out scene "
                             f"(>= {HELD_OUT_SEED_BASE}): tuning uses training scenes only")
    for values in itertools.product(*grid.values()):
        params = dict(zip(grid, values))
        key = json.dumps(params, sort_keys=True)
        if key in done:
            continue
        infos = [run_episode(env, OperatorProtocol(**params), k) for k in range(episodes)]
        rec = {
            "env": env_id,
            "episodes": episodes,
            "params": params,
            "success_rate": sum(bool(i["success"]) for i in infos) / len(infos),
            "mean_peak_pressure_kpa": sum(float(i["peak_pressure_kpa"]) for i in infos) / len(infos),
        }
        if log is not None:
            with open(log, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
        done[key] = rec
        if on_result is not None:
            on_result(rec)
    env.close()
    keys = [json.dumps(dict(zip(grid, v)), sort_keys=True) for v in itertools.product(*grid.values())]
    best = max((done[k] for k in keys), key=lambda r: (r["success_rate"], -r["mean_peak_pressure_kpa"]))
    return {"env": env_id, "episodes": episodes, "grid": grid, "training_scene_seeds": scene_seeds, "best": best}
