"""scripts/engine_digest.py, scripts/solve_iterations.py and scripts/kernel_parts.py: the bit-for-bit check of an
engine change, the solves by their Newton iterations and the compiled solve's time per part; one line for bad input."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

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
    assert iterations_script.main(["--sim", '{"linear_solver": "lu"}']) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "linear_solver = 'lu' is out of range" in err[0]


def test_solves_are_grouped_by_their_iterations():
    r = iterations_script.measure("evertgym/UBend-v0", 20)
    assert r["solves"] == sum(b["solves"] for b in r["buckets"]) > 0
    dense = iterations_script.measure("evertgym/UBend-v0", 20, {"linear_solver": "dense"})
    assert dense["solves"] == r["solves"]  # the same trajectory for 20 steps (the solvers agree to rounding)
    assert abs(sum(b["time_share"] for b in r["buckets"]) - 1.0) < 1e-9
    assert 0.0 < r["compiled_share"] < 1.0
    walls = iterations_script.measure("evertgym/UBend-v0", 60)  # (by then the tip is at the walls: solves iterate)
    assert abs(sum(b["iteration_share"] for b in walls["buckets"]) - 1.0) < 1e-9
    assert 1.0 < walls["refreshes_per_solve"] < walls["iterations_per_solve"]  # a lag refresh is followed by an iteration


def _store(path, results: dict[int, dict], group: str = "g") -> None:
    from evertgym.scoring.spec import TrialSpec
    from evertgym.scoring.store import ResultStore

    with ResultStore(path) as store:
        for seed, res in results.items():
            store.add(TrialSpec(design={}, design_name="d", scene={"family": "ubend", "params": {}, "seed": seed},
                                policy={"name": group}, seed=seed, index=seed, group=group), res)


def test_two_stores_are_compared_trial_by_trial(tmp_path, capsys):
    compare = _load("compare_stores")
    base = {"time_s": 5.0, "peak_pressure_kpa": 3.0, "max_contact_force_n": 1.0, "stall_position_mm": None}
    _store(tmp_path / "a.sqlite", {1: {**base, "success": True}, 2: {**base, "success": True}, 3: {**base, "success": False}}, "rule")
    _store(tmp_path / "b.sqlite", {1: {**base, "success": True}, 2: {**base, "success": False, "time_s": 30.0},
                                   4: {**base, "success": True}}, "other")
    r = compare.compare(compare.load(str(tmp_path / "a.sqlite"), None), compare.load(str(tmp_path / "b.sqlite"), "other"))
    assert r["pairs"] == 1 + 1 and r["only_a"] == 1 and r["only_b"] == 1  # seeds 1 and 2 pair across the two groups
    assert r["success_differs"] == [["d", "", 2]]
    assert r["fields"]["time_s"] == {"pairs_differing": 1, "median": 12.5, "max": 25.0, "mean_a": 5.0, "mean_b": 17.5}
    assert compare.main([str(tmp_path / "a.sqlite"), str(tmp_path / "b.sqlite"), "--group-a", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds no trials of group 'nope'" in err[0]
    assert compare.main([str(tmp_path / "missing.sqlite"), str(tmp_path / "b.sqlite")]) == 2
    assert "is not a file" in capsys.readouterr().err


def test_sim_fields_reach_the_quasistatic_runs_and_bad_ones_get_one_line(capsys):
    """``--sim``: the default is the O(m) solver (its digest equals ``linear_solver="semiseparable"``'s); the dense
    solver's answers differ from it in the last bits once the body touches the bend (40 U-bend steps); a field that
    is unknown, foreign to the quasi-static engine or another engine is refused in one line, before any run."""
    default = digest_script.digest("evertgym/UBend-v0", "quasistatic", 40)
    assert default == digest_script.digest("evertgym/UBend-v0", "quasistatic", 40, {"linear_solver": "semiseparable"})
    assert default != digest_script.digest("evertgym/UBend-v0", "quasistatic", 40, {"linear_solver": "dense"})
    for bad, says in (('{"nope": 1}', "--sim: nope = 1 is not a SimConfig field"),
                      ('{"engine": "dynamic"}', "--sim: engine = 'dynamic' is out of range here: allowed 'quasistatic'"),
                      ('{"mass_ratio": 0.1}', "means nothing to engine 'quasistatic'")):
        assert digest_script.main(["--sim", bad]) == 2
        err = capsys.readouterr().err
        assert says in err and err.strip().count("\n") == 0


parts_script = _load("kernel_parts")


def test_kernel_parts_refuses_bad_input_in_one_line(capsys):
    assert parts_script.main(["--windows", "0"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == ["--windows = 0 is out of range: allowed [1, 10000]"]
    assert parts_script.main(["--env", "evertgym/Nope-v0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("--env = 'evertgym/Nope-v0' is not an env id")


@pytest.mark.slow
def test_kernel_parts_times_every_part_of_captured_windows():
    caps = parts_script.capture("evertgym/UBend-v0", 200, 200)
    assert len(caps) == 200
    r = parts_script.measure(caps, 2)
    assert 0 < r["windows"] <= 200 and r["iterations"] > 0
    assert all(r["us"][k] > 0 for k in ("gradient and Hessian", "linear solve", "solve with the lag", "candidate listing"))
