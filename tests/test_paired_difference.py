"""scripts/paired_difference.py: pairs two policies' stored episodes by seed, picks the episodes played with the
env kwargs asked for (an outcome check's replays among them), and refuses bad --env-kwargs in one line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from evertgym.scoring.spec import TrialSpec
from evertgym.scoring.store import ResultStore

SCRIPT = Path(__file__).parents[1] / "scripts" / "paired_difference.py"
KW = {"regulator_tau_s": [0.1, 0.6]}
REPLAY = {**KW, "sim_config": {"solver_tolerance": 0.0001}}
SEED = 1_000_000_000


def _store(path: Path) -> None:
    """Policy A at 1.0 N in every episode; B at 0.9 N under the default kwargs and 1.1 N in the replays."""
    with ResultStore(path) as store:
        for group, params, force in [("A", KW, 1.0), ("B", KW, 0.9), ("A", REPLAY, 1.0), ("B", REPLAY, 1.1)]:
            for i in range(5):
                spec = TrialSpec(design={}, design_name="evertgym/UBend-v0",
                                 scene={"family": "evertgym/UBend-v0", "params": params, "seed": SEED + i},
                                 policy={"name": group}, seed=SEED + i, index=i, group=group)
                store.add(spec, {"success": True, "time_s": 1.0, "peak_pressure_kpa": 1.0,
                                 "max_contact_force_n": force + 0.001 * i * (group == "B"), "stall_position_mm": None})


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), "--env", "evertgym/UBend-v0", *args], capture_output=True,
                          text=True, timeout=120)


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
        assert done.returncode == 1 and "Traceback" not in done.stderr
        assert done.stderr.strip().count("\n") == 0 and "--env-kwargs" in done.stderr and says in done.stderr
    assert not (tmp_path / "s.sqlite").exists()  # refused before any store is opened
