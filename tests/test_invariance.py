"""Invariance harness: SimConfig overrides reach every simulation; the slow test
holds the criteria at full size (reproduce ubend, reproduce colon, operator on Colon-v0)."""

from __future__ import annotations

import os

import pytest

from evertgym.experiments.paper import colon_specs, ubend_specs
from evertgym.experiments.trial import make_trial_env
from evertgym.scoring.spec import TrialSpec

# keys of the first U-bend spec and of the colon specs on the default engine: pinned, since a change
# orphans every stored result.  They changed once, on purpose, when the default engine became the
# quasi-static one (0.3.0): a store filled by the dynamic default must not be reused for it.
UBEND_KEY_0 = "0dfb908034fdff8d5ade15366e8a619dcc46bc8205cb3449dafe2673a679b4db"
COLON_KEYS = ("5c1550f4e2a9f9135c50d2201d26e39d93c1d6bdd5e754ec90f3cea5d1498939",
              "9b83a69f1fb988fbbc54ffcc50ad23e54fd5a33ab3edc2c8aaea4a9ffc7ac8df")
#: the first U-bend spec's key before 0.3.0 (no engine in the spec: the dynamic default)
UBEND_KEY_0_DYNAMIC_DEFAULT = "181d9abba9a79a48397648a0681ad0f66fec4b96f624f491f388b2ac10d4fe52"


def test_the_engine_is_part_of_every_specs_identity():
    assert ubend_specs()[0].key == UBEND_KEY_0
    assert ubend_specs(sim=None)[0].key == UBEND_KEY_0
    assert ubend_specs(sim={})[0].key == UBEND_KEY_0
    assert ubend_specs(sim={"engine": "quasistatic"})[0].key == UBEND_KEY_0  # the default, named or not
    assert tuple(s.key for s in colon_specs()) == COLON_KEYS
    assert ubend_specs()[0].scene["episode"]["sim"] == {"engine": "quasistatic"}
    dynamic = ubend_specs(sim={"engine": "dynamic"})[0].key
    assert len({dynamic, UBEND_KEY_0, UBEND_KEY_0_DYNAMIC_DEFAULT}) == 3


def test_score_specs_name_the_engine():
    from evertgym.experiments.sweep import sweep_specs

    design = {"tube": {"diameter_mm": 40.0, "length_mm": 600.0}, "bands": []}
    specs = sweep_specs({"bare": design}, {"family": "ubend", "params": {}}, 1, 1, {"name": "constant", "pressure_kpa": 3.0},
                        {"max_s": 5.0, "sim": {"engine": "dynamic"}})
    assert specs[0].scene["episode"] == {"max_s": 5.0, "sim": {"engine": "dynamic"}}
    specs = sweep_specs({"bare": design}, {"family": "ubend", "params": {}}, 1, 1, {"name": "constant", "pressure_kpa": 3.0})
    assert specs[0].scene["episode"] == {"sim": {"engine": "quasistatic"}}


def test_sim_override_reaches_the_trial_env():
    spec = ubend_specs(trials=1, radii=(30.0,), reductions=(0.0,), sim={"dt_s": 0.001})[0]
    assert spec.scene["episode"]["sim"] == {"engine": "quasistatic", "dt_s": 0.001}
    assert spec.key != ubend_specs(trials=1, radii=(30.0,), reductions=(0.0,))[0].key
    env = make_trial_env(spec)
    env.reset(seed=0)
    assert env.sim.cfg.dt_s == 0.001
    env.close()
    colon = colon_specs(sim={"engine": "dynamic", "mass_ratio": 0.1})[1]
    env = make_trial_env(colon)
    env.reset(seed=0)
    assert env.sim.cfg.mass_ratio == 0.1 and env.sim.cfg.dt_s == 0.002
    env.close()
    # a plain trial spec carrying the override in its episode table
    plain = TrialSpec(design={"tube": {"diameter_mm": 40.0, "length_mm": 500.0}, "bands": []}, design_name="d",
                      scene={"family": "ubend", "params": {}, "seed": 0, "episode": {"sim": {"engine": "dynamic", "inertia_factor": 10.0}}},
                      policy={"name": "constant", "pressure_kpa": 3.0}, seed=0, index=0, group="g")
    assert make_trial_env(plain).sim_config.inertia_factor == 10.0


def test_unknown_sim_field_is_refused():
    spec = ubend_specs(trials=1, radii=(30.0,), reductions=(0.0,), sim={"not_a_field": 1.0})[0]
    with pytest.raises(ValueError, match="sim_config"):
        make_trial_env(spec)


def test_operator_evaluation_takes_sim_config():
    """evaluate's env kwargs carry the override through the (JSON) TrialSpec into the env."""
    from evertgym.agents.evaluate import _policy_and_env, evaluate
    from evertgym.scoring.spec import canonical_json

    _, env = _policy_and_env(canonical_json({"name": "operator"}), "evertgym/Colon-v0", canonical_json({"sim_config": {"dt_s": 0.001}}))
    assert env.unwrapped.sim_config.dt_s == 0.001
    rows = evaluate(["operator"], "evertgym/Colon-v0", 1, env_kwargs={"sim_config": {"max_growth_speed_m_per_s": 0.5}, "max_episode_s": 1.0})
    assert rows[0]["episodes"] == 1 and 0.0 <= rows[0]["success_rate"] <= 1.0


def test_settings_and_table(tmp_path):
    """The settings change one knob at a time; compare/format_table on a hand-made result."""
    from evertgym.experiments.invariance import SETTINGS, compare, format_table, ubend_table
    from evertgym.sim.config import SimConfig

    dyn = {"engine": "dynamic"}  # the dynamic engine's knobs (the default engine is the quasi-static one)
    assert SETTINGS[0] == ("reference", dyn)
    assert [s for _, s in SETTINGS[1:]] == [{**dyn, "mass_ratio": 0.003}, {**dyn, "mass_ratio": 0.1}, {**dyn, "inertia_factor": 10.0},
                                           {**dyn, "dt_s": 0.001}]
    for _, sim in SETTINGS:
        SimConfig(**sim)  # valid, e.g. max_growth_speed * dt_s <= 0.2 ds

    def run(sim, succ, passed, op):
        return {"sim": sim, "ubend": [{"reduction": 0.0, "radius_mm": 30.0, "trials": 12, "successes": succ}],
                "colon": [{"reduction": 0.0, "passed": passed, "stall_position_mm": None if passed else 300.0, "peak_pressure_kpa": 8.0}],
                "operator": {"success_rate": op, "episodes": 50}}

    ref = run({}, 5, False, 0.4)
    rows = [compare("reference", ref, ref, 12), compare("mass_ratio=0.1", run({"mass_ratio": 0.1}, 8, True, 0.6), ref, 12)]
    assert rows[0]["holds"] and rows[0]["ubend_max_cell_change"] == 0
    bad = rows[1]
    assert bad["ubend_max_cell_change"] == 3 and not bad["ubend_ok"] and not bad["colon_same"]
    assert bad["operator_change"] == pytest.approx(0.2) and not bad["operator_ok"] and not bad["holds"]
    result = {"rows": rows, "runs": {"reference": ref, "mass_ratio=0.1": run({"mass_ratio": 0.1}, 8, True, 0.6)},
              "criteria": {"ubend_max_cell_change_of_12": 2, "colon_outcomes_equal": True, "operator_max_change": 0.1},
              "trials": 12, "episodes": 50}
    table = format_table(result)
    assert "| mass_ratio=0.1 | 3 (0.0/30) |" in table and "+0.20 | NO |" in table
    assert "| no bands | 30 | 5/12 | 8/12 |" in ubend_table(result)


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("EVERTGYM_INVARIANCE_FULL"),
                    reason="a 30-minute study of the dynamic engine, known not to hold: EVERTGYM_INVARIANCE_FULL=1 runs it")
@pytest.mark.xfail(strict=True, reason="the dynamic engine's rigid-column model: its U-bend cells move with mass_ratio, "
                   "inertia_factor and the step (docs/invariance.md); so do the section law's (docs/sim.md)")
def test_invariance_full_size(tmp_path):
    """The dynamic engine's invariance criteria at full size (30+ min on 2 cores; not in `.ci/run`'s
    budget, and known to fail: the default quasi-static engine's own criteria are
    :func:`test_quasistatic_invariance`).  EVERTGYM_INVARIANCE_DIR keeps the stores between runs
    (start it empty after a change to the physics)."""
    from evertgym.experiments.invariance import CRITERIA, format_table, run_invariance

    out = os.environ.get("EVERTGYM_INVARIANCE_DIR") or tmp_path
    result = run_invariance(out, trials=12, episodes=50, workers=2)
    table = format_table(result)
    for row in result["rows"]:
        assert row["ubend_max_cell_change"] <= CRITERIA["ubend_max_cell_change_of_12"], table
        assert row["colon_same"], table
        assert abs(row["operator_change"]) <= CRITERIA["operator_max_change"] + 1e-9, table


def test_quasistatic_settings_vary_only_its_own_numerical_knobs():
    from evertgym.experiments.invariance import QUASISTATIC_CRITERIA, QUASISTATIC_SETTINGS, compare
    from evertgym.sim.config import DYNAMIC_ONLY, SimConfig

    assert QUASISTATIC_SETTINGS[0] == ("quasistatic", {"engine": "quasistatic"})
    for _, sim in QUASISTATIC_SETTINGS:
        cfg = SimConfig(**sim)  # valid, and not a mass, inertia or damping setting among them
        assert cfg.engine == "quasistatic" and not set(sim) & set(DYNAMIC_ONLY)

    def run(stall):
        return {"sim": {}, "ubend": [{"reduction": 0.0, "radius_mm": 30.0, "trials": 12, "successes": 5}],
                "colon": [{"reduction": 0.0, "passed": False, "stall_position_mm": stall, "peak_pressure_kpa": 8.0}],
                "operator": {"success_rate": 0.5, "episodes": 50}}

    ref = run(300.0)
    assert compare("a", run(301.5), ref, 12, QUASISTATIC_CRITERIA)["holds"]
    moved = compare("b", run(303.0), ref, 12, QUASISTATIC_CRITERIA)  # the stall moved by 3 mm: more than 2
    assert moved["colon_stall_change_mm"] == pytest.approx(3.0) and not moved["holds"]


@pytest.mark.slow
@pytest.mark.timeout(5400)
def test_quasistatic_invariance(tmp_path):
    """The quasi-static engine's invariance criteria (a subset of the U-bend table: the five paper radii from 40 to 20 mm, 4
    trials per cell; both colon robots; the operator on 50 held-out Colon-v0 episodes): the growth
    increment halved, the tolerance ten times tighter and the pressure increment five times finer
    move no U-bend cell by more than 1 trial, no colon outcome or stall (by 2 mm), and the operator's
    success by at most 0.05.  About 20 minutes on 2 cores.  EVERTGYM_INVARIANCE_DIR keeps the stores."""
    from evertgym.experiments.invariance import QUASISTATIC_CRITERIA, QUASISTATIC_SETTINGS, format_table, run_invariance

    out = os.environ.get("EVERTGYM_INVARIANCE_DIR") or tmp_path
    result = run_invariance(out, trials=4, episodes=50, radii=(40.0, 35.0, 30.0, 25.0, 20.0), settings=QUASISTATIC_SETTINGS,
                            workers=2, criteria=QUASISTATIC_CRITERIA)
    table = format_table(result)
    for row in result["rows"]:
        assert row["ubend_max_cell_change"] <= 1, table
        assert row["colon_same"], table
        assert abs(row["operator_change"]) <= QUASISTATIC_CRITERIA["operator_max_change"] + 1e-9, table
        assert row["operator_episodes"] == 50, table


def test_the_script_puts_sim_fields_under_every_setting_and_refuses_bad_ones_in_one_line(capsys):
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("invariance_script", Path(__file__).parents[1] / "scripts" / "invariance.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    for sim, says in (('{"linear_solver": "lu"}', "linear_solver = 'lu' is out of range"), ("[1]", "is a JSON array"),
                      ('{"bogus": 1}', "bogus")):
        with pytest.raises(SystemExit) as e:
            script.main(["--engine", "quasistatic", "--sim", sim])
        assert e.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("--sim: ") and says in err[0]
