"""One configuration path: SimConfig's fields each belong to both engines or to one; ``--sim`` text is parsed
by one function (``parse_sim``) for every command and script, and refused in one line."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import pytest

from evertgym.sim import SimConfig, parse_sim
from evertgym.sim.config import BOTH, DYNAMIC_ONLY, ENGINES, QUASISTATIC_ONLY, engine_fields

ROOT = Path(__file__).parents[1]


def test_every_field_belongs_to_both_engines_or_to_one():
    owners = {f.name: f.metadata["engine"] for f in fields(SimConfig)}
    assert set(owners.values()) == {BOTH, *ENGINES}
    assert set(DYNAMIC_ONLY) == set(engine_fields("dynamic")) and set(QUASISTATIC_ONLY) == set(engine_fields("quasistatic"))
    assert not set(DYNAMIC_ONLY) & set(QUASISTATIC_ONLY)
    assert {"engine", "segment_length_m", "dt_s", "wall_friction", "regulator_tau_s", "stall_time_s"} <= set(engine_fields(BOTH))
    assert {"mass_ratio", "section_law", "dormant_walls"} <= set(DYNAMIC_ONLY)
    assert {"growth_increment_m", "linear_solver", "band_fold", "threshold_z"} <= set(QUASISTATIC_ONLY)
    for engine in ENGINES:  # a shared field is set on either engine
        assert SimConfig(engine=engine, wall_friction=0.5).wall_friction == 0.5
    with pytest.raises(ValueError, match="allowed 'quasistatic' or 'dynamic' or 'both'"):
        engine_fields("implicit")


@pytest.mark.parametrize("text, expected", [
    ('{"growth_increment_m": 0.0005}', {"growth_increment_m": 0.0005}),
    ('{"engine": "dynamic"}', {"engine": "dynamic"}),
    ('{"engine": "dynamic", "mass_ratio": 0.02}', {"engine": "dynamic", "mass_ratio": 0.02}),
    ('{"wall_friction": 0.8, "linear_solver": "dense"}', {"wall_friction": 0.8, "linear_solver": "dense"}),
    ("", {}), (None, {}), ("  ", {}),
])
def test_parse_sim_keeps_the_flat_keys(text, expected):
    assert parse_sim(text) == expected


def test_parse_sim_takes_every_field_at_its_engine():
    for engine in ENGINES:
        for name in (*engine_fields(BOTH), *engine_fields(engine)):
            value = getattr(SimConfig(engine=engine), name)
            assert parse_sim(json.dumps({name: value, "engine": engine})) == {name: value, "engine": engine}


@pytest.mark.parametrize("text, kwargs, says", [
    ('{"no_such_field": 1}', {}, "no_such_field = 1 is not a SimConfig field"),
    ('{"growth_incremnt_m": 1}', {}, "did you mean 'growth_increment_m'?"),
    ('{"mass_ratio": 0.1}', {}, "mass_ratio = 0.1 means nothing to engine 'quasistatic': it is a setting of engine 'dynamic' only"),
    ('{"engine": "dynamic", "growth_increment_m": 0.002}', {}, "growth_increment_m = 0.002 means nothing to engine 'dynamic'"),
    ('{"growth_increment_m": 0.5}', {}, "growth_increment_m = 0.5 is out of range: allowed"),
    ('{"iterations": 1.5}', {"extra": {"engine": "dynamic"}}, "iterations = 1.5 is out of range: allowed integers"),
    ("[1, 2]", {}, "'[1, 2]' is a JSON array: allowed a JSON object of SimConfig fields"),
    ('"dynamic"', {}, "is a JSON string: allowed a JSON object"),
    ("3", {}, "'3' is a JSON number"),
    ("{nope", {}, "'{nope' is not JSON ("),
    ('{"engine": "dynamic"}', {"engine": "quasistatic"}, "engine = 'dynamic' is out of range here: allowed 'quasistatic'"),
    ('{"dt_s": 1e-5, "engine": "dynamic"}', {}, "segment passes per simulated second: out of range"),
])
def test_parse_sim_refuses_in_one_line_naming_the_field(text, kwargs, says):
    with pytest.raises(ValueError) as e:
        parse_sim(text, **kwargs)
    assert says in str(e.value) and "\n" not in str(e.value)


def test_parse_sim_with_an_engine_checks_its_fields_against_it():
    assert parse_sim('{"solver_tolerance": 0.01}', engine="quasistatic") == {"solver_tolerance": 0.01}
    assert parse_sim('{"engine": "quasistatic"}', engine="quasistatic") == {"engine": "quasistatic"}
    assert parse_sim('{"mass_ratio": 0.02}', engine="dynamic") == {"mass_ratio": 0.02}
    assert parse_sim('{"damping": 1e-5}', {"engine": "dynamic"}) == {"damping": 1e-5, "engine": "dynamic"}


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"script_{name}", ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("run, flag", [
    (lambda argv: _script("engine_digest").main(argv), "--sim"),
    (lambda argv: _script("solve_iterations").main(argv), "--sim"),
    (lambda argv: _script("overlap_check").main(argv), "--sim"),
    (lambda argv: _script("invariance").main(["--engine", "quasistatic", *argv]), "--sim"),
    (lambda argv: _script("bench_engines").main([a.replace("--sim", "--setting") for a in argv]), "--setting"),
    (lambda argv: __import__("evertgym.experiments.ubend_jams", fromlist=["main"]).main([*argv, "--write", ""]), "--sim"),
])
@pytest.mark.parametrize("text, says", [
    ('{"bogus": 1}', "bogus = 1 is not a SimConfig field"),
    ('{"mass_ratio": 0.1}', "mass_ratio = 0.1 means nothing to engine 'quasistatic'"),
    ('{"barrier_gap_m": 1.0}', "barrier_gap_m = 1.0 is out of range"),
    ("[1]", "is a JSON array"),
])
def test_every_script_refuses_bad_sim_text_the_same_way(run, flag, text, says, capsys):
    try:
        code = run(["--sim", text])
    except SystemExit as e:
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"{flag}: ") and says in err[0], err
    assert "Traceback" not in err[0]


@pytest.mark.parametrize("text, says", [
    ('{"bogus": 1}', "--sim: bogus = 1 is not a SimConfig field"),
    ('{"engine": "quasistatic", "relax_force_n": 1.0}', "--sim: relax_force_n = 1.0 means nothing to engine 'quasistatic'"),
    ('{"stall_time_s": -1}', "--sim: stall_time_s = -1 is out of range"),
    ("[]", "--sim: '[]' is a JSON array"),
])
def test_the_cli_wraps_the_parser_in_one_line_without_a_traceback(text, says, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-m", "evertgym.cli", "reproduce", "colon", "--sim", text, "--db", str(tmp_path / "c.sqlite")],
                       capture_output=True, text=True, cwd=ROOT, env=env)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()] and says in r.stderr
    assert not (tmp_path / "c.sqlite").exists()
