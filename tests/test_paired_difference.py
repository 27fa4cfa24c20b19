"""evertgym paired: pairs two policies' stored episodes by seed, picks the episodes played with the
env kwargs asked for (an outcome check's replays among them), and refuses bad --env-kwargs in one line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE
from evertgym.scoring.spec import TrialSpec
from evertgym.scoring.store import ResultStore

#: the scripts run on this checkout's package, whatever is installed
_ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
CLI = [sys.executable, "-m", "evertgym.cli", "paired"]
KW = {"regulator_tau_s": [0.1, 0.6]}
REPLAY = {**KW, "sim_config": {"solver_tolerance": 0.0001}}
SEED = HELD_OUT_SEED_BASE


def _add(store: ResultStore, group: str, params: dict, base: int, episodes: int, force: float) -> None:
    """``episodes`` passed UBend-v0 episodes of ``group`` from seed ``base`` up, at ``force`` N (B's rising 1 mN each)."""
    for i in range(episodes):
        spec = TrialSpec(design={}, design_name="evertgym/UBend-v0",
                         scene={"family": "evertgym/UBend-v0", "params": params, "seed": base + i},
                         policy={"name": group}, seed=base + i, index=i, group=group)
        store.add(spec, {"success": True, "time_s": 1.0, "peak_pressure_kpa": 1.0,
                         "max_contact_force_n": force + 0.001 * i * (group == "B"), "stall_position_mm": None})


def _store(path: Path) -> None:
    """Policy A at 1.0 N in every episode; B at 0.9 N under the default kwargs and 1.1 N in the replays."""
    with ResultStore(path) as store:
        for group, params, force in [("A", KW, 1.0), ("B", KW, 0.9), ("A", REPLAY, 1.0), ("B", REPLAY, 1.1)]:
            _add(store, group, params, SEED, 5, force)


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, "--env", "evertgym/UBend-v0", *args], capture_output=True,
                          text=True, timeout=120, env=_ENV)


def test_pairs_the_default_episodes_and_an_outcome_checks_replays(tmp_path):
    db = tmp_path / "s.sqlite"
    _store(db)
    done = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "5")
    assert done.returncode == 0, done.stderr
    assert "5 episodes in both" in done.stdout and "second - first: -0.0980" in done.stdout
    assert "second lower in 5 of 5" in done.stdout
    done = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "5", "--env-kwargs", json.dumps(REPLAY))
    assert done.returncode == 0, done.stderr
    assert "second - first: +0.1020" in done.stdout and "second lower in 0 of 5" in done.stdout


def test_bad_env_kwargs_get_one_line(tmp_path):
    for bad, says in [("{bad", "is not JSON"), ("[1]", "a JSON object of env kwargs")]:
        done = _run("--a", f"{tmp_path}/s.sqlite:A", "--b", f"{tmp_path}/s.sqlite:B", "--env-kwargs", bad)
        assert done.returncode == 2 and "Traceback" not in done.stderr
        assert done.stderr.strip().count("\n") == 0 and "--env-kwargs" in done.stderr and says in done.stderr
    assert not (tmp_path / "s.sqlite").exists()  # refused before any store is opened


def test_an_id_that_draws_the_lag_itself_pairs_its_plain_episodes(tmp_path):
    """TortuousHard-v0's preset draws the regulator lag, so its episodes are stored with no env kwargs: that is the
    default there, while a bare default on such a store would find none."""
    db = tmp_path / "v1.sqlite"
    with ResultStore(db) as store:
        for group, force in [("A", 2.0), ("B", 1.5)]:
            for i in range(4):
                spec = TrialSpec(design={}, design_name="evertgym/TortuousHard-v0",
                                 scene={"family": "evertgym/TortuousHard-v0", "params": {}, "seed": SEED + i},
                                 policy={"name": group}, seed=SEED + i, index=i, group=group)
                store.add(spec, {"success": True, "time_s": 1.0, "peak_pressure_kpa": 1.0,
                                 "max_contact_force_n": force - 0.01 * i, "stall_position_mm": None})
    args = [*CLI, "--env", "evertgym/TortuousHard-v0", "--a", f"{db}:A", "--b", f"{db}:B",
            "--episodes", "4"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120, env=_ENV)
    assert done.returncode == 0, done.stderr
    assert "4 episodes in both" in done.stdout and "second - first: -0.5000" in done.stdout
    done = subprocess.run(args + ["--env-kwargs", json.dumps(KW)], capture_output=True, text=True, timeout=120, env=_ENV)
    assert done.returncode == 2 and "only 0 episodes in both stores" in done.stderr


def test_unknown_env_gets_one_line(tmp_path):
    done = subprocess.run([*CLI, "--env", "evertgym/Nope-v0", "--a", f"{tmp_path}/s.sqlite:A",
                           "--b", f"{tmp_path}/s.sqlite:B"], capture_output=True, text=True, timeout=120, env=_ENV)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip().count("\n") == 0 and "--env = 'evertgym/Nope-v0' is not allowed" in done.stderr
    assert not (tmp_path / "s.sqlite").exists()


def test_successes_are_compared_by_the_exact_mcnemar_test(tmp_path):
    """12 shared episodes: A passes all, B fails the first 9 and passes the last 3; the discordant
    pairs are 9 to 0, whose exact two-sided binomial p is 2 / 2**9 = 0.0039."""
    db = tmp_path / "s.sqlite"
    with ResultStore(db) as store:
        for group in ("A", "B"):
            for i in range(12):
                spec = TrialSpec(design={}, design_name="evertgym/UBend-v0",
                                 scene={"family": "evertgym/UBend-v0", "params": KW, "seed": SEED + i},
                                 policy={"name": group}, seed=SEED + i, index=i, group=group)
                store.add(spec, {"success": group == "A" or i >= 9, "time_s": 1.0, "peak_pressure_kpa": 1.0,
                                 "max_contact_force_n": 1.0 + 0.01 * i, "stall_position_mm": None})
    done = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "12")
    assert done.returncode == 0, done.stderr
    assert ("success: first 12/12, second 3/12; passed by the first only 9, by the second only 0, "
            "exact McNemar p = 0.0039") in done.stdout
    done = _run("--a", f"{db}:B", "--b", f"{db}:A", "--episodes", "12")
    assert "passed by the first only 0, by the second only 9, exact McNemar p = 0.0039" in done.stdout


def test_a_label_played_by_two_versions_of_its_policy_is_refused_in_one_line(tmp_path):
    """A store that holds a retuned operator's (or a retrained model's) episodes beside the old ones under one label
    would pair a mix of both: refused, naming the label."""
    db = tmp_path / "mixed.sqlite"
    with ResultStore(db) as store:
        for group, start_kpa, seeds in [("tuned", 1.0, range(3)), ("tuned", 2.0, range(3, 5)), ("B", None, range(5))]:
            for i in seeds:
                ident = {} if start_kpa is None else {"tuned_params": {"start_kpa": start_kpa}}
                spec = TrialSpec(design={}, design_name="evertgym/UBend-v0",
                                 scene={"family": "evertgym/UBend-v0", "params": KW, "seed": SEED + i, **ident},
                                 policy={"name": group}, seed=SEED + i, index=i, group=group)
                store.add(spec, {"success": True, "time_s": 1.0, "peak_pressure_kpa": 1.0,
                                 "max_contact_force_n": 1.0, "stall_position_mm": None})
    done = _run("--a", f"{db}:tuned", "--b", f"{db}:B", "--episodes", "5")
    assert done.returncode == 2 and "Traceback" not in done.stderr and done.stderr.strip().count("\n") == 0
    assert "'tuned'" in done.stderr and "2 versions" in done.stderr
    done = _run("--a", f"{db}:B", "--b", f"{db}:B", "--episodes", "5")  # one version: pairs
    assert done.returncode == 0, done.stderr


def test_validation_pairs_the_validation_episodes_only(tmp_path):
    """A store holding both held-out (1e9 + i) and validation (2e9 + i) episodes: ``--validation`` pairs the
    validation ones (B 0.3 N lower there, 0.1 N on held-out), the default the held-out ones."""
    db = tmp_path / "s.sqlite"
    with ResultStore(db) as store:
        for base, gap in [(SEED, 0.1), (VALIDATION_SEED_BASE, 0.3)]:
            for group, force in [("A", 1.0), ("B", 1.0 - gap)]:
                _add(store, group, KW, base, 3, force)
    held = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "3")
    val = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "3", "--validation")
    assert held.returncode == 0 and val.returncode == 0, held.stderr + val.stderr
    assert "3 episodes in both" in held.stdout and "second - first: -0.0990" in held.stdout
    assert "3 episodes in both" in val.stdout and "second - first: -0.2990" in val.stdout
    none = _run("--a", f"{db}:A", "--b", f"{db}:B", "--episodes", "3", "--validation", "--env-kwargs", "{}")
    assert none.returncode == 2 and "only 0 episodes in both stores" in none.stderr and "(validation episodes)" in none.stderr
