"""evertgym headroom: which stored policies pass the held-out episodes a reference fails, the per-episode oracle
over them, and one line for bad input."""

from __future__ import annotations

import json
from pathlib import Path

from evertgym.scoring.spec import TrialSpec
from evertgym.scoring.store import ResultStore

SEED = 1_000_000_000
ENV = "evertgym/TortuousHard-v0"
import evertgym.agents.headroom as headroom  # noqa: E402 - `evertgym headroom`


def _store(path: Path, outcomes: dict[str, str], params: dict | None = None) -> None:
    """One trial per character of each policy's outcome string ('1' passed, '0' failed), at seeds 1e9 + i."""
    with ResultStore(path) as store:
        for group, passes in outcomes.items():
            for i, c in enumerate(passes):
                store.add(TrialSpec(design={}, design_name=ENV, scene={"family": ENV, "params": params or {}, "seed": SEED + i},
                                    policy={"name": group}, seed=SEED + i, index=i, group=group),
                          {"success": c == "1", "time_s": 1.0, "peak_pressure_kpa": 1.0, "max_contact_force_n": 1.0,
                           "stall_position_mm": None if c == "1" else 10.0})


def test_counts_the_references_failures_each_policy_passes(tmp_path, capsys):
    db = tmp_path / "a.sqlite"
    _store(db, {"ref": "110100", "A": "111000", "B": "010010", "short": "111"})
    _store(db, {"lag": "111111"}, params={"regulator_tau_s": [0.1, 0.6]})  # other env kwargs: not these episodes
    assert headroom.main(["--env", ENV, "--ref", f"{db}:ref", "--stores", str(db), "--episodes", "6", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["ref_successes"], out["ref_failures"]) == (3, 3)
    rows = {r["policy"]: r for r in out["rows"]}
    assert set(rows) == {"A", "B"} and out["partial"] == ["short (3)"]
    assert (rows["A"]["successes"], rows["A"]["passes_of_ref_failures"], rows["A"]["fails_of_ref_passes"]) == (3, 1, 1)
    assert (rows["B"]["successes"], rows["B"]["passes_of_ref_failures"], rows["B"]["fails_of_ref_passes"]) == (2, 1, 2)
    assert out["oracle_successes"] == 5 and out["ref_failures_passed_by_any"] == 2 and out["failed_by_all"] == [5]


def test_bad_input_gets_one_line(tmp_path, capsys):
    db = tmp_path / "a.sqlite"
    _store(db, {"ref": "10"})
    for argv, says in [(["--ref", f"{db}:ref", "--episodes", "0"], "--episodes = 0 is out of range"),
                       (["--ref", str(db)], "expected STORE:POLICY"),
                       (["--ref", f"{db}:ref", "--env-kwargs", "[1]"], "a JSON object of env kwargs"),
                       (["--ref", f"{db}:ref", "--episodes", "5"], "has 2 of the 5 held-out episodes")]:
        assert headroom.main(["--env", ENV, "--stores", str(db), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and says in err, err
    assert headroom.main(["--env", "evertgym/Nope-v0", "--ref", f"{db}:ref", "--stores", str(db)]) == 2
    assert "--env = 'evertgym/Nope-v0' is not allowed" in capsys.readouterr().err
