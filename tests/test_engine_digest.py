"""scripts/engine_digest.py and scripts/solve_iterations.py: the bit-for-bit check of an engine change, and the
solves by their Newton iterations; one line for bad input."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

SCRIPTS = Path(__file__).parents[1] / "scripts"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


digest_script = _load("engine_digest")
iterations_script = _load("solve_iterations")


def test_a_digest_is_the_same_for_the_same_run_and_changes_with_the_run():
    a = digest_script.digest("evertgym/UBend-v0", "quasistatic", 6)
    assert a == digest_script.digest("evertgym/UBend-v0", "quasistatic", 6)
    assert a != digest_script.digest("evertgym/UBend-v0", "quasistatic", 7)
    assert a != digest_script.digest("evertgym/UBend-v0", "dynamic", 6)


def test_against_a_different_digest_exits_1(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(digest_script, "RUNS", (("evertgym/UBend-v0", "quasistatic", 3),))
    saved = tmp_path / "before.json"
    saved.write_text(json.dumps({"evertgym/UBend-v0 quasistatic 3": "0" * 64}))
    assert digest_script.main(["--against", str(saved)]) == 1
    assert "DIFFERENT" in capsys.readouterr().out
    saved.write_text(json.dumps({"evertgym/UBend-v0 quasistatic 3": digest_script.digest("evertgym/UBend-v0", "quasistatic", 3)}))
    assert digest_script.main(["--against", str(saved)]) == 0


def test_bad_input_gets_one_line(tmp_path, capsys):
    assert digest_script.main(["--against", str(tmp_path / "missing.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("--against: cannot read") and "missing.json" in err[0]
    assert iterations_script.main(["--steps", "-3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["--steps = -3 is out of range: allowed 1 or more (0: the default)"]
    assert iterations_script.main(["--env", "evertgym/Nope-v0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("--env = 'evertgym/Nope-v0' is not an env id")


def test_solves_are_grouped_by_their_iterations():
    r = iterations_script.measure("evertgym/UBend-v0", 20)
    assert r["solves"] == sum(b["solves"] for b in r["buckets"]) > 0
    assert abs(sum(b["time_share"] for b in r["buckets"]) - 1.0) < 1e-9
    assert 0.0 < r["compiled_share"] < 1.0
