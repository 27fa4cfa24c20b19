"""Fuzzing the boundaries (hypothesis): random designs, scene specs, env kwargs and CLI
argument vectors raise nothing but the package's validation errors (``ValueError`` with a
one-line message); the slow test also runs every accepted input in a subprocess, so an
interpreter abort (Chipmunk's SIGABRT) fails the test instead of the run.

    python -m pytest -m slow tests/test_fuzz.py     # >= 5,000 examples
"""

import json
import os
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


PARAM_NAMES = sorted({name for fam in FAMILIES.values() for name in fam.params})


def _strategies(nasty: bool) -> tuple[st.SearchStrategy, st.SearchStrategy, st.SearchStrategy]:
    """Designs, scene specs and env kwargs.  ``nasty``: any field may be anything (most
    inputs are then rejected); otherwise values have the right types in ranges around the
    allowed ones, so that most inputs are accepted and simulated."""
    def number(lo: float, hi: float) -> st.SearchStrategy:
        plain = st.one_of(st.floats(lo, hi), st.integers(int(lo), int(hi))) if hi - lo > 1 else st.floats(lo, hi)
        return st.one_of(plain, NASTY) if nasty else plain

    def anything(s: st.SearchStrategy) -> st.SearchStrategy:
        return st.one_of(s, NASTY) if nasty else s

    def field(lo: float, hi: float, valid_lo: float, valid_hi: float) -> st.SearchStrategy:
        """``nasty``: [lo, hi] around the allowed range, and anything; plain: inside the
        allowed [valid_lo, valid_hi] (hypothesis still tries its ends), so most designs are
        accepted and simulated."""
        return number(lo, hi) if nasty else st.floats(valid_lo, valid_hi)

    band = st.fixed_dictionaries({"position_mm": field(-50, 1000, 7.5, 590), "reduction": field(-0.2, 0.7, 0, 0.59)},
                                 optional={"width_mm": field(-5, 60, 1, 60)})
    designs = anything(st.fixed_dictionaries({}, optional={
        "tube": st.fixed_dictionaries({}, optional={"diameter_mm": field(0, 120, 1, 120),
                                                    "wall_thickness_mm": field(0, 1, 0.001, 0.05),
                                                    "length_mm": field(0, 1200, 25, 1200)}),
        "bands": st.lists(band, max_size=4),
        "pressure_law": st.fixed_dictionaries({}, optional={"membrane_modulus_mpa": field(0, 50, 1e-3, 50),
                                                            "pressure_stiffening": field(0, 12, 0, 10)}),
    }))
    params = st.dictionaries(st.sampled_from(PARAM_NAMES), st.one_of(number(0, 400), st.sampled_from(["left", "right"]),
                                                                     st.tuples(number(0, 200), number(0, 200))), max_size=4)
    scene_specs = st.fixed_dictionaries(
        {"family": anything(st.sampled_from(sorted(FAMILIES) + ["spiral"]))},
        optional={"params": anything(params), "seed": anything(st.integers(0, 100))},
    )
    sim_config = st.dictionaries(st.sampled_from(["dt_s", "segment_length_m", "iterations"]), number(0, 0.01), max_size=2) \
        if nasty else st.fixed_dictionaries({}, optional={"dt_s": st.sampled_from([0.0005, 0.001, 0.002, 0.004, 1e-6]),
                                                          "segment_length_m": st.floats(0.003, 0.02),
                                                          "iterations": st.integers(0, 30)})
    def ordered(lo: float, hi: float) -> st.SearchStrategy:
        """A (lo, hi) pair inside [lo, hi]: plain ranges are ordered."""
        return st.tuples(st.floats(lo, hi), st.floats(lo, hi)).map(lambda t: (min(t), max(t)))

    def pair(lo: float, hi: float, valid_lo: float, valid_hi: float) -> st.SearchStrategy:
        return anything(st.tuples(number(lo, hi), number(lo, hi))) if nasty else ordered(valid_lo, valid_hi)

    env_kwargs = st.fixed_dictionaries({}, optional={
        "scene": st.one_of(st.just({"family": "straight", "params": {"length_mm": 200.0}}), scene_specs),
        "design": st.one_of(st.just({"tube": {"length_mm": 300.0}}), designs),
        "band_offset_mm": pair(-60, 60, -5, 5),
        "entry_offset_mm": pair(-30, 30, -5, 5),
        "control_hz": st.one_of(st.sampled_from([5, 10, 20, 50, 3, 1000]), number(0, 2000)) if nasty
        else st.sampled_from([1, 2, 5, 10, 20, 50, 100, 200]),
        "max_episode_s": field(-1, 100, 1.0, 100.0), "action_mode": anything(st.sampled_from(["absolute", "increment"])),
        "max_increment_kpa": field(-1, 10, 0.01, 8.0), "history": anything(st.integers(-2, 120)) if nasty else st.integers(0, 100),
        "tip_sensing": anything(st.booleans()), "scene_ahead": anything(st.booleans()),
        "rupture_kpa": field(-1, 20, 0.01, 20.0), "stall_weight": field(-1, 5, 0.0, 5.0),
        "sim_config": st.one_of(st.just({}), sim_config),
        "regulator_tau_s": pair(-0.1, 1.0, 0.0, 1.0),
        "wall_friction": pair(-0.1, 2.0, 0.0, 2.0),
        "pressure_noise_kpa": field(-0.1, 2.0, 0.0, 2.0), "insertion_noise_mm": field(-1, 10, 0.0, 10.0),
    })
    return designs, scene_specs, env_kwargs


designs, scene_specs, env_kwargs = _strategies(nasty=True)
plain_designs, plain_scene_specs, plain_env_kwargs = _strategies(nasty=False)


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
@given(st.one_of(designs, plain_designs))
def test_fuzz_designs_raise_only_validation_errors(data):
    _accepts("design", data)


@FAST
@given(st.one_of(scene_specs, plain_scene_specs))
def test_fuzz_scene_specs_raise_only_validation_errors(data):
    _accepts("scene", data)


@FAST
@given(st.one_of(env_kwargs, plain_env_kwargs))
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
                                                         "command_kpa": [], "out": "/tmp/evertgym_fuzz.gif",
                                                         "episode_seed": 1_000_000_000})
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


def _mostly_plain(nasty: st.SearchStrategy, plain: st.SearchStrategy) -> st.SearchStrategy:
    """One nasty input in four: the rest are plain, so that most are accepted and simulated."""
    return st.one_of(nasty, plain, plain, plain)


#: examples per slow fuzz test: 1700 by hand (>= 5,000 in all); `.ci/run` sets EVERTGYM_FUZZ_EXAMPLES lower to fit its budget
SLOW = settings(max_examples=int(os.environ.get("EVERTGYM_FUZZ_EXAMPLES", "1700")), deadline=None,
                suppress_health_check=list(HealthCheck))


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
@given(_mostly_plain(designs, plain_designs))
def test_fuzz_slow_designs(worker, data):
    _fuzz_and_run(worker, "design", data)


@pytest.mark.slow
@pytest.mark.timeout(7200)
@SLOW
@given(_mostly_plain(scene_specs, plain_scene_specs))
def test_fuzz_slow_scene_specs(worker, data):
    _fuzz_and_run(worker, "scene", data)


@pytest.mark.slow
@pytest.mark.timeout(7200)
@SLOW
@given(_mostly_plain(env_kwargs, plain_env_kwargs))
def test_fuzz_slow_env_kwargs(worker, data):
    _fuzz_and_run(worker, "env", data)
