"""Fuzzing edges (hypothesis): ``--sim`` text, store and study files, scene seeds and
policy descriptions.  Each either is accepted with the right types or is refused with one line naming
what is wrong; a refused file is never changed; a description never turns on trust."""

import hashlib
import json
import math
import string
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from evertgym.cli import CLIError, _sim_overrides
from evertgym.sim.config import SimConfig

FIELDS = sorted(SimConfig.__dataclass_fields__)
INTS = ("iterations", "law_interval", "max_relax_steps", "friction_lag_iterations", "max_newton_iterations")
NASTY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**30), 10**30), st.booleans(), st.none(),
    st.text(max_size=4), st.lists(st.integers(0, 3), max_size=2), st.sampled_from(["dynamic", "quasistatic", "dense", 1e-9, 1.5]),
)
JSON = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=False), st.text(max_size=3)),
                    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=3), inner, max_size=3)),
                    max_leaves=6)
SIM_TEXT = st.one_of(
    st.dictionaries(st.sampled_from(FIELDS), st.one_of(NASTY, st.floats(1e-6, 0.1), st.integers(0, 100)), max_size=3).map(json.dumps),
    JSON.map(json.dumps),
    st.text(alphabet=string.printable, max_size=20),
)
FAST = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@FAST
@given(SIM_TEXT)
@example(json.dumps({"\n": None}))  # a field name with a newline once broke the one line
def test_fuzz_sim_text_is_an_object_of_typed_settings_or_one_line(text):
    try:
        sim = _sim_overrides(text)
    except CLIError as e:
        assert "\n" not in str(e) and str(e).startswith("--sim")
        return
    assert isinstance(sim, dict)
    cfg = SimConfig(**sim)
    for name in INTS:
        assert type(getattr(cfg, name)) is int
    if cfg.engine == "quasistatic":
        assert cfg.solver_tolerance >= 1e-5


HEADER = b"SQLite format 3\x00"


@FAST
@given(st.one_of(st.binary(max_size=300), st.binary(min_size=84, max_size=300).map(lambda b: HEADER + b)))
def test_fuzz_files_that_are_not_stores_are_refused_unchanged(tmp_path, data):
    from evertgym.scoring.store import identify_store, identify_study

    path = tmp_path / "f.sqlite"
    path.write_bytes(data)
    digest = hashlib.sha256(data).hexdigest()
    for identify in (identify_store, identify_study):
        try:
            kind = identify(path)
        except ValueError as e:
            assert "\n" not in str(e) and "f.sqlite" in str(e)
        else:
            assert kind == "new" and data == b""
        assert hashlib.sha256(path.read_bytes()).hexdigest() == digest
        assert not any(Path(str(path) + s).exists() for s in ("-wal", "-shm", "-journal"))


@pytest.fixture(scope="module")
def env():
    from evertgym.env import EversionEnv

    return EversionEnv(scene={"family": "straight", "params": {"length_mm": 200.0}}, design={"tube": {"length_mm": 300.0}})


@FAST
@given(st.one_of(NASTY, st.integers(0, 2**62)))
def test_fuzz_scene_seed_is_a_non_negative_integer_or_one_line(env, seed):
    try:
        env.reset(seed=0, options={"scene_seed": seed})
    except ValueError as e:
        assert "scene_seed" in str(e) and "\n" not in str(e)
        assert isinstance(seed, bool) or not isinstance(seed, int) or seed < 0
        return
    assert seed is None or (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0)  # None: the episode's own


@FAST
@given(st.dictionaries(st.sampled_from(["name", "path", "pressure_kpa", "deterministic"]), NASTY, max_size=3),
       st.one_of(NASTY, st.just(True)))
def test_fuzz_a_policy_description_never_carries_trust(desc, trust):
    from evertgym.agents.policies import make_policy

    with pytest.raises(ValueError, match="'trust'"):
        make_policy({**desc, "trust": trust})


def test_the_fuzz_strategies_reach_both_outcomes():
    """The ``--sim`` strategy accepts some inputs (a fuzz that only refuses proves little)."""
    assert _sim_overrides(json.dumps({"max_newton_iterations": 7}))["max_newton_iterations"] == 7
    assert math.isclose(_sim_overrides('{"solver_tolerance": 1e-5}')["solver_tolerance"], 1e-5)
