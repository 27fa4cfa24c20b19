"""Fuzzing the boundaries (hypothesis): random designs, scene specs, env kwargs and CLI
argument vectors raise nothing but the package's validation errors (``ValueError`` with a
one-line message); the slow test also runs every accepted input in a subprocess, so an
interpreter abort (Chipmunk's SIGABRT) fails the test instead of the run.

    python -m pytest -m slow tests/test_fuzz.py     # >= 5,000 examples
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evertgym.design import TubeDesign
from evertgym.env import EversionEnv
from evertgym.scenes import SceneSpec
from evertgym.scenes.families import FAMILIES

WORKER = Path(__file__).with_name("_fuzz_worker.py")
NASTY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**400), 10**400), st.booleans(), st.none(),
    st.text(max_size=4), st.sampled_from(["1", "0.3", "nan", "1e999"]), st.complex_numbers(max_magnitude=10),
    st.lists(st.floats(-100, 100), max_size=3), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


def number(lo: float, hi: float) -> st.SearchStrategy:
    """Mostly plausible numbers, sometimes anything."""
    return st.one_of(st.floats(lo, hi), st.integers(int(lo), int(hi)), NASTY) if hi - lo > 1 else st.one_of(st.floats(lo, hi), NASTY)


band = st.fixed_dictionaries({"position_mm": number(-50, 1000), "reduction": number(-0.2, 0.7)},
                             optional={"width_mm": number(-5, 60)})
designs = st.one_of(
    st.fixed_dictionaries({}, optional={
        "tube": st.fixed_dictionaries({}, optional={"diameter_mm": number(0, 120), "wall_thickness_mm": number(0, 1),
                                                    "length_mm": number(0, 1200)}),
        "bands": st.lists(band, max_size=4),
        "pressure_law": st.fixed_dictionaries({}, optional={"membrane_modulus_mpa": number(0, 50),
                                                            "pressure_stiffening": number(0, 12)}),
    }),
    NASTY,
)
PARAM_NAMES = sorted({name for fam in FAMILIES.values() for name in fam.params})
scene_specs = st.fixed_dictionaries(
    {"family": st.one_of(st.sampled_from(sorted(FAMILIES) + ["spiral"]), NASTY)},
    optional={"params": st.one_of(st.dictionaries(st.sampled_from(PARAM_NAMES), st.one_of(number(0, 400), st.sampled_from(["left", "right"]),
                                                                                        st.tuples(number(0, 200), number(0, 200))),
                                                  max_size=4), NASTY),
              "seed": st.one_of(st.integers(0, 100), NASTY)},
)
env_kwargs = st.fixed_dictionaries({}, optional={
    "scene": st.one_of(st.just({"family": "straight", "params": {"length_mm": 200.0}}), scene_specs),
    "design": st.one_of(st.just({"tube": {"length_mm": 300.0}}), designs),
    "band_offset_mm": st.one_of(st.tuples(number(-60, 60), number(-60, 60)), NASTY),
    "entry_offset_mm": st.one_of(st.tuples(number(-30, 30), number(-30, 30)), NASTY),
    "control_hz": st.one_of(st.sampled_from([5, 10, 20, 50, 3, 1000]), number(0, 2000)),
    "max_episode_s": number(-1, 100), "action_mode": st.one_of(st.sampled_from(["absolute", "increment"]), NASTY),
    "max_increment_kpa": number(-1, 10), "history": st.one_of(st.integers(-2, 120), NASTY),
    "tip_sensing": st.one_of(st.booleans(), NASTY), "scene_ahead": st.one_of(st.booleans(), NASTY),
    "rupture_kpa": number(-1, 20), "stall_weight": number(-1, 5),
    "sim_config": st.one_of(st.just({}), st.dictionaries(st.sampled_from(["dt_s", "segment_length_m", "iterations"]),
                                                        number(0, 0.01), max_size=2)),
})


def _build(kind: str, data):
    if kind == "design":
        return TubeDesign.from_dict(data)
    if kind == "scene":
        return SceneSpec.from_dict(data) if isinstance(data, dict) else SceneSpec(data, {})
    return EversionEnv(**data)


def _accepts(kind: str, data) -> bool:
    """True if the constructor accepts ``data``; a validation error must be one line."""
    try:
        _build(kind, data)
        return True
    except ValueError as e:
        assert str(e) and "\n" not in str(e), repr(e)
        return False


FAST = settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))


@FAST
@given(designs)
def test_fuzz_designs_raise_only_validation_errors(data):
    _accepts("design", data)


@FAST
@given(scene_specs)
def test_fuzz_scene_specs_raise_only_validation_errors(data):
    _accepts("scene", data)


@FAST
@given(env_kwargs)
def test_fuzz_env_kwargs_raise_only_validation_errors(data):
    _accepts("env", data)


FLAG_VALUES = st.one_of(st.text(max_size=6), st.sampled_from(["-1", "0", "1e999", "nan", "inf", "3", "0.5", "{}", "[]", "x.zip"]))


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.sampled_from(["score", "eval", "rollout"]),
       st.lists(st.tuples(st.sampled_from(["--scenes", "--trials", "--max-s", "--band-jitter-mm", "--policy", "--workers",
                                           "--reduction", "--length-mm", "--diameter-mm", "--scene", "--scene-params",
                                           "--episodes", "--seed", "--bands-mm", "--trial", "--env"]), FLAG_VALUES), max_size=4))
def test_fuzz_cli_argument_vectors(monkeypatch_module, capsys, command, flags):
    from evertgym.cli import main

    argv = [command] + (["operator", "--env", "evertgym/UBend-v0", "--out", "/tmp/evertgym_fuzz.gif"] if command == "rollout"
                        else ["operator", "--env", "evertgym/UBend-v0"] if command == "eval" else ["--db", "/tmp/evertgym_fuzz.sqlite"])
    for flag, value in flags:
        argv += [flag, value]
    capsys.readouterr()  # the fixture spans every example: start clean
    try:
        code = main(argv)
    except SystemExit as e:  # argparse: usage and exit 2
        assert e.code == 2
        return
    err = capsys.readouterr().err
    assert code in (0, 2), err
    if code == 2:
        assert err.startswith("evertgym: error: ") and "Traceback" not in err


@pytest.fixture(scope="module")
def monkeypatch_module():
    """The CLI's work replaced by no-ops: the fuzz checks the flags, not the trials."""
    from evertgym.agents import evaluate, rollout
    from evertgym.scoring import runner

    mp = pytest.MonkeyPatch()
    mp.setattr(runner, "run_trials", lambda *a, **k: [])
    mp.setattr(evaluate, "evaluate", lambda *a, **k: [])
    mp.setattr(rollout, "rollout_gif", lambda *a, **k: {"frames": 1, "success": False, "time_s": 0.0, "peak_pressure_kpa": 0.0,
                                                         "command_kpa": [], "out": "/tmp/evertgym_fuzz.gif"})
    yield
    mp.undo()


class _Worker:
    """A subprocess that runs accepted inputs; it dying is the failure the fuzz looks for."""

    def __init__(self) -> None:
        self.runs = 0
        self._start()

    def _start(self) -> None:
        self.proc = subprocess.Popen([sys.executable, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)

    def run(self, kind: str, data) -> str:
        if self.proc.poll() is not None:  # died on an earlier example (already reported): a fresh one
            self._start()
        self.proc.stdin.write(json.dumps({"kind": kind, "input": data}) + "\n")
        self.proc.stdin.flush()
        reply = self.proc.stdout.readline()
        if not reply:
            err = self.proc.stderr.read()
            self.proc.wait()
            raise AssertionError(f"the worker died (exit {self.proc.returncode}) on {kind} {data!r}: {err[-2000:]}")
        self.runs += 1
        return reply


@pytest.fixture(scope="module")
def worker():
    w = _Worker()
    yield w
    w.proc.stdin.close()
    w.proc.wait(timeout=60)
    print(f"\nfuzz: {w.runs} accepted inputs simulated in a subprocess")


SLOW = settings(max_examples=1700, deadline=None, suppress_health_check=list(HealthCheck))


def _fuzz_and_run(worker, kind, data):
    if _accepts(kind, data):
        try:
            json.dumps(data, allow_nan=True)
        except (TypeError, ValueError):
            return  # accepted but not JSON (e.g. numpy): the in-process check covered it
        worker.run(kind, data)


@pytest.mark.slow
@pytest.mark.timeout(7200)
@SLOW
@given(designs)
def test_fuzz_slow_designs(worker, data):
    _fuzz_and_run(worker, "design", data)


@pytest.mark.slow
@pytest.mark.timeout(7200)
@SLOW
@given(scene_specs)
def test_fuzz_slow_scene_specs(worker, data):
    _fuzz_and_run(worker, "scene", data)


@pytest.mark.slow
@pytest.mark.timeout(7200)
@SLOW
@given(env_kwargs)
def test_fuzz_slow_env_kwargs(worker, data):
    _fuzz_and_run(worker, "env", data)
