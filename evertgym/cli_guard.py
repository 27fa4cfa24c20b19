"""The command line's edge: every expected error becomes one line and exit code 2.

``evertgym.cli.main`` runs each command through :func:`run_command`; the commands call the
``check_*`` helpers on their flags before any work starts.  Expected errors are the
package's validation errors (``ValueError`` and its subclasses), missing or unreadable
files (``OSError``), bad stores (``sqlite3.Error``), unknown env ids (Gymnasium's errors),
a model the rod solver cannot settle (``RodSolveError``) and missing optional extras
(``ImportError``, with the ``pip install 'evertgym[...]'`` that brings the module).  Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import json
import math
import os
import signal
import sqlite3
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from evertgym._extras import install_hint, require

#: Exit code of every expected error.
EXIT_USAGE = 2
#: Exit code after Ctrl-C (128 + SIGINT).
EXIT_INTERRUPTED = 130


def _expected_errors() -> tuple[type[BaseException], ...]:
    import gymnasium

    from evertgym.model.cosserat import RodSolveError

    return (ValueError, OSError, sqlite3.Error, gymnasium.error.Error, RodSolveError, ImportError)


def run_command(func: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    """Run one command: expected errors -> ``evertgym: error: ...`` on stderr and exit 2;
    Ctrl-C -> one line saying the same command resumes; a closed stdout pipe -> quiet."""
    try:
        with _interruptible():
            return func(args)
    except KeyboardInterrupt:
        kept = {"cmd_train": "the run's checkpoints are kept"}.get(getattr(func, "__name__", ""),
                                                                   "finished trials are kept in the command's store (--db)")
        print(f"evertgym: interrupted; {kept}: rerun the same command to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # e.g. `evertgym ... --json | head -c 100`
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's own flush at exit must not fail again
        return 1
    except _expected_errors() as e:
        text = " ".join(str(e).split()) or type(e).__name__
        hint = install_hint(e.name or "") if isinstance(e, ModuleNotFoundError) else None
        if hint and "pip install" not in text:  # an optional module imported without evertgym._extras.require
            text = f"{text}: this command needs {hint}"
        print(f"evertgym: error: {text}", file=sys.stderr)
        return EXIT_USAGE


#: Python code that a C call runs inside it, where a KeyboardInterrupt must not be raised: pymunk's callbacks (cffi
#: swallows it: "Exception ignored from cffi callback") and numba's unpickling of constants while it boxes a compiled
#: call's result (CPython then fails the call: "returned a result with an exception set").
_NOT_HERE = ("pymunk", os.path.join("numba", "core", "serialize.py"))


def _inside_c_call(frame) -> bool:
    """Whether ``frame`` or a caller of it is Python code run inside a C call (:data:`_NOT_HERE`)."""
    f = frame
    while f is not None:
        if any(part in f.f_code.co_filename for part in _NOT_HERE):
            return True
        f = f.f_back
    return False


@contextlib.contextmanager
def _interruptible():
    """Ctrl-C that reaches Python code: while Python code runs inside a C call (a pymunk callback, the
    boxing of a compiled call's result) the interrupt is redelivered 10 ms later instead."""
    if not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        if _inside_c_call(frame):
            signal.setitimer(signal.ITIMER_REAL, 0.01)  # retry once the call has returned
            return
        raise KeyboardInterrupt

    old_int, old_alrm = signal.signal(signal.SIGINT, handler), signal.signal(signal.SIGALRM, handler)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGALRM, old_alrm)


def no_abbreviations(parser: argparse.ArgumentParser) -> None:
    """Refuse prefixes of long flags (``--trial`` is not ``--trials``) in every subcommand."""
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                no_abbreviations(sub)


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by None (JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy scalars and arrays
        return json_safe(obj.tolist())
    return obj


def dumps(obj: Any, **kw: Any) -> str:
    """Strict JSON: NaN and inf become null."""
    return json.dumps(json_safe(obj), allow_nan=False, **kw)


def check_input_file(flag: str, path: str) -> Path:
    """An existing regular file."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{flag} = {path!r}: {'is a directory' if p.is_dir() else 'no such file'}: allowed an existing file")
    return p


def check_output_file(flag: str, path: str, suffixes: tuple[str, ...] = ()) -> Path:
    """A file we can create: its folder exists or can be made, and is writable."""
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise ValueError(f"{flag} = {path!r}: allowed a {' or '.join(suffixes)} file")
    if p.is_dir():
        raise ValueError(f"{flag} = {path!r} is a directory: allowed a file path")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"{flag} = {path!r}: cannot create its folder ({e.strerror})") from None
    existed = p.exists()
    try:  # the one reliable test: open it for appending (and remove it again if it is new)
        with open(p, "ab"):
            pass
        if not existed:
            p.unlink()
    except OSError as e:
        raise ValueError(f"{flag} = {path!r}: not writable ({e.strerror})") from None
    return p


def check_store(flag: str, path: str) -> Path:
    """A result store we may write: a new file in a writable folder, or an evertgym store of this
    schema version, found without writing to it (:func:`~evertgym.scoring.store.identify_store`);
    anything else is refused in one line and left unchanged."""
    from evertgym.scoring.store import identify_store

    identify_store(path, flag)  # (before the writability test below, which opens it for appending)
    return check_output_file(flag, path)


def check_study(flag: str, path: str | Path) -> Path:
    """An optuna study file, identified without writing to it (:func:`~evertgym.scoring.store.identify_study`)."""
    from evertgym.scoring.store import identify_study

    identify_study(path, flag)
    return Path(path)


def check_env_id(flag: str, env_id: str) -> str:
    """A registered Gymnasium id."""
    import gymnasium as gym

    from evertgym.env import RENAMED_IDS

    if env_id in RENAMED_IDS:
        raise ValueError(f"{flag} = {env_id!r}: renamed {RENAMED_IDS[env_id]} (the same env)")
    try:
        gym.spec(env_id)
    except gym.error.Error as e:
        raise ValueError(f"{flag} = {env_id!r}: {e}") from None
    return env_id


def is_local_address(address: str) -> bool:
    """Whether a Dask address points at this machine (loopback or a local socket)."""
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    host = parts.hostname or ""
    if parts.scheme in ("inproc", "ipc") or host in ("localhost", ""):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def warn_remote_dask(address: str, trusted: bool) -> None:
    """One warning line for a scheduler that is not on this machine (unless ``trusted``)."""
    if not trusted and not is_local_address(address):
        print(f"evertgym: warning: --address = {address!r} is not local: the connection has no TLS and the cluster "
              "exchanges pickles (code) with this process; use it only with a cluster you trust "
              "(--trust-cluster silences this)", file=sys.stderr)


def check_policy(flag: str, desc: Any, trust: bool) -> None:
    """A policy description that will load: baselines are built (their parameters checked);
    a saved model must exist and be a shipped policy unless ``trust`` (nothing is unpickled)."""
    from evertgym.agents.policies import make_policy, refuse_trust_field, vecnormalize_path
    from evertgym.agents.trust import check_trusted

    d = {"name": "agent", "path": desc} if isinstance(desc, str) and desc.endswith(".zip") else desc
    if isinstance(d, str) and ".zip:" in d:
        d = {"name": "agent", "path": d.partition(".zip:")[0] + ".zip"}
    if isinstance(d, dict):  # trust comes from the flag only, never from the description
        refuse_trust_field(d, flag)
    if isinstance(d, dict) and d.get("name") == "agent":
        path = check_input_file(flag, str(d.get("path", "")))
        stats = vecnormalize_path(path)
        for f in (path, stats) if stats.exists() else (path,):
            check_trusted(f, trust)
        if trust:
            check_model_archive(flag, path)
        require("a trained policy", "stable_baselines3", "torch")  # here, not in a trial's worker
        return
    try:
        make_policy(d)
    except ValueError as e:
        raise ValueError(f"{flag} = {desc!r}: {e}") from None


def check_model_archive(flag: str, path: Path) -> None:
    """A trusted model file is still checked to be a stable-baselines3 archive before it is loaded:
    a zip with a ``data`` member and a ``policy.pth`` (one line otherwise, not a loader's traceback)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
    except (zipfile.BadZipFile, OSError) as e:
        raise ValueError(f"{flag} = {str(path)!r} is not a saved model: not a zip archive ({e})") from None
    missing = sorted({"data", "policy.pth"} - names)
    if missing:
        raise ValueError(f"{flag} = {str(path)!r} is not a saved stable-baselines3 model: the zip has no {', '.join(missing)}")


def check_eval_flags(args: argparse.Namespace) -> dict:
    """``evertgym eval``: counts, workers, the env id, ``--env-kwargs`` and every policy,
    before any episode.  Returns the env kwargs (``{}`` without the flag)."""
    from evertgym.limits import MAX_EPISODES, check_workers

    if not 1 <= args.episodes <= MAX_EPISODES:
        raise ValueError(f"--episodes = {args.episodes} is out of range: allowed [1, {MAX_EPISODES}]")
    check_workers(args.workers, args.force_workers, "--workers")
    check_env_id("--env", args.env)
    env_kwargs = check_env_kwargs("--env-kwargs", getattr(args, "env_kwargs", None), args.env)
    for desc in args.policies:
        check_policy("policy", desc, args.trust_model)
    if getattr(args, "db", None) is not None:
        check_store("--db", args.db)
    if getattr(args, "check_outcomes", False):
        from evertgym.agents.evaluate import outcome_check_kwargs

        try:
            outcome_check_kwargs(env_kwargs)
        except ValueError as e:
            raise ValueError(f"--check-outcomes: {e}") from None
    return env_kwargs


def check_env_kwargs(flag: str, text: str | None, env_id: str) -> dict:
    """A JSON object of env arguments, checked by building the env once (its own one-line errors)."""
    import json

    import gymnasium as gym

    if text is None:
        return {}
    try:
        kwargs = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{flag} = {text!r:.80}: not JSON ({e.msg} at character {e.pos}); "
                         "expected an object such as '{\"regulator_tau_s\": [0.1, 0.6]}'") from None
    if not isinstance(kwargs, dict):
        raise ValueError(f"{flag} = {text!r:.80}: expected a JSON object of env arguments, got {type(kwargs).__name__}")
    try:
        gym.make(env_id, **kwargs).close()
    except TypeError as e:  # an unknown argument name
        raise ValueError(f"{flag}: {str(e).split(' was raised from')[0]}") from None
    return kwargs


def check_rollout_flags(args: argparse.Namespace) -> dict:
    """``evertgym rollout``: seed, env id, env kwargs, policy and a writable ``--out`` before
    the episode.  Returns the env kwargs."""
    if not 0 <= args.seed < 2**62:
        raise ValueError(f"--seed = {args.seed} is out of range: allowed integers in [0, 2^62)")
    check_env_id("--env", args.env)
    env_kwargs = check_env_kwargs("--env-kwargs", getattr(args, "env_kwargs", None), args.env)
    check_policy("policy", args.policy, args.trust_model)
    check_output_file("--out", args.out, (".gif",))
    return env_kwargs


def check_score_flags(args: argparse.Namespace, designs: dict[str, dict], params: Any, episode: dict, policy: dict) -> dict:
    """``evertgym score``: every flag, each design in the scene with the band jitter, counts,
    workers, store, cluster and policy, before any trial.  Returns the policy description
    (``--trust-model`` reaches the trials through the trial function, never through it)."""
    from evertgym.env import EversionEnv
    from evertgym.limits import MAX_SCENES, MAX_SPECS, MAX_TRIALS_PER_SCENE, check_workers

    if not 1 <= args.scenes <= MAX_SCENES:
        raise ValueError(f"--scenes = {args.scenes} is out of range: allowed [1, {MAX_SCENES}]")
    if not 1 <= args.trials <= MAX_TRIALS_PER_SCENE:
        raise ValueError(f"--trials = {args.trials} is out of range: allowed [1, {MAX_TRIALS_PER_SCENE}]")
    n = args.scenes * args.trials * len(designs)
    if n > MAX_SPECS:
        raise ValueError(f"--scenes x --trials x designs = {n} is out of range: allowed at most {MAX_SPECS} trials per run")
    if not (math.isfinite(args.max_s) and 0.1 <= args.max_s <= 3600):
        raise ValueError(f"--max-s = {args.max_s} is out of range: allowed [0.1, 3600] s")
    if not (math.isfinite(args.band_jitter_mm) and 0 <= args.band_jitter_mm <= 1000):
        raise ValueError(f"--band-jitter-mm = {args.band_jitter_mm} is out of range: allowed [0, 1000] mm")
    for name, design in designs.items():
        try:  # the same constructor the trials use, without running one
            EversionEnv(scene={"family": args.scene, "params": params}, design=design, max_episode_s=args.max_s,
                        band_offset_mm=tuple(episode["band_offset_mm"]), entry_offset_mm=tuple(episode["entry_offset_mm"]),
                        sim_config=episode.get("sim") or None)
        except ValueError as e:
            raise ValueError(f"design {name!r} with --scene {args.scene!r}: {e}") from None
    check_workers(args.workers, args.force_workers, "--workers")
    check_store("--db", args.db)
    if args.address:
        warn_remote_dask(args.address, args.trust_cluster)
    check_policy("--policy", policy, args.trust_model)
    return policy


def check_optimize_flags(args: argparse.Namespace, params: Any = None, sim: dict | None = None) -> None:
    """``evertgym optimize``: counts, the pressure budget, the scene with its parameters and the
    ``--sim`` settings (the paper's design built in the scene, as every trial will be), the study
    and the store, before the study starts (nothing is written to either on a refusal)."""
    from evertgym.env import EversionEnv
    from evertgym.experiments.optimize import BAND_JITTER_MM, band_design

    for flag, v, hi in (("--trials", args.trials, 10_000), ("--scenes", args.scenes, 1000),
                        ("--trials-per-scene", args.trials_per_scene, 1000), ("--held-out", args.held_out, 1000)):
        if not 1 <= v <= hi:
            raise ValueError(f"{flag} = {v} is out of range: allowed [1, {hi}]")
    if not (math.isfinite(args.budget_kpa) and 0 < args.budget_kpa <= 8.0):
        raise ValueError(f"--budget-kpa = {args.budget_kpa} is out of range: allowed (0, 8] kPa")
    for flag, v, low, high, unit in (("--diameter-mm", args.diameter_mm, 5.0, 500.0, "mm"),
                                     ("--length-mm", args.length_mm, 100.0, 20_000.0, "mm"), ("--max-s", args.max_s, 0.1, 3600.0, "s")):
        if not (math.isfinite(v) and low <= v <= high):
            raise ValueError(f"{flag} = {v} is out of range: allowed [{low:g}, {high:g}] {unit}")
    try:  # the paper's design and the bare robot, in the scene, as the trials build them
        for n in (3, 0):
            EversionEnv(scene={"family": args.scene, "params": {} if params is None else params},
                        design=band_design(n, 50.0, 0.1, 300.0, args.diameter_mm, args.length_mm), max_episode_s=args.max_s,
                        band_offset_mm=(-BAND_JITTER_MM, BAND_JITTER_MM), entry_offset_mm=(-5.0, 5.0), sim_config=sim or None)
    except ValueError as e:
        raise ValueError(f"--scene {args.scene!r} with --scene-params {json.dumps(params)[:80]}: {e}") from None
    study, db = check_output_file("--study", args.study), check_output_file("--db", args.db)
    if study.resolve() == db.resolve() or (study.exists() and db.exists() and os.path.samefile(study, db)):
        raise ValueError(f"--study = {args.study!r} and --db = {args.db!r} are the same file: allowed two files "
                         "(the optuna study and the result store each have their own tables)")
    check_study("--study", study)
    check_store("--db", args.db)
