"""``evaluate(check_outcomes=True)`` / ``evertgym eval --check-outcomes``: episodes whose outcome moves with a
solver setting are reported as undecided (knife edge, docs/quasistatic.md)."""

import json

import pytest

import evertgym.agents.evaluate as ev
from evertgym.agents.evaluate import OUTCOME_CHECKS, evaluate, outcome_check_kwargs
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.sim.config import SimConfig


def test_the_replays_divide_the_envs_own_settings_and_keep_the_rest():
    assert [name for name, _ in OUTCOME_CHECKS] == ["solver_tolerance", "growth_increment_m"]
    plays = outcome_check_kwargs({"regulator_tau_s": [0.1, 0.6]})
    assert plays == [{"regulator_tau_s": [0.1, 0.6], "sim_config": {"solver_tolerance": 1e-4}},
                     {"regulator_tau_s": [0.1, 0.6], "sim_config": {"growth_increment_m": SimConfig().growth_increment_m / 2}}]
    own = outcome_check_kwargs({"sim_config": {"solver_tolerance": 1e-2, "growth_increment_m": 2e-3}})
    assert [p["sim_config"] for p in own] == [{"solver_tolerance": 1e-3, "growth_increment_m": 2e-3},
                                              {"solver_tolerance": 1e-2, "growth_increment_m": 1e-3}]


@pytest.mark.parametrize("kwargs, words", [
    ({"sim_config": {"engine": "dynamic"}}, ["quasi-static", "'dynamic'"]),
    ({"sim_config": {"solver_tolerance": 1e-5}}, ["solver_tolerance / 10 = 1e-06", "not allowed"]),
])
def test_a_check_that_cannot_run_is_refused_in_one_line(kwargs, words):
    with pytest.raises(ValueError) as e:
        outcome_check_kwargs(kwargs)
    assert all(w in str(e.value) for w in words) and "\n" not in str(e.value)


def test_undecided_episodes_are_those_whose_success_differs_between_the_plays(monkeypatch):
    """Three plays of 4 episodes: 0 passes in all, 1 fails in all, 2 passes only with the env's settings,
    3 passes only under a replay: 2 undecided, success between 1/4 and 3/4, the row's rate the env's own."""
    outcomes = [[True, False, True, False], [True, False, False, False], [True, False, True, True]]
    plays = iter(outcomes)

    def fake_play(policies, descs, env_id, episodes, env_kwargs, *rest):
        won = next(plays)
        return [[{"success": w, "time_s": 1.0, "peak_pressure_kpa": 3.0, "max_contact_force_n": 0.1,
                  "peak_pressure_bend_kpa": 3.0, "bend_entry_time_s": None, "peak_pressure_time_s": 0.5} for w in won]]

    monkeypatch.setattr(ev, "_play", fake_play)
    (row,) = evaluate(["constant"], "evertgym/UBend-v0", 4, check_outcomes=True)
    assert row["success_rate"] == 0.5
    assert row["undecided_episodes"] == 2 and row["undecided_seeds"] == [HELD_OUT_SEED_BASE + 2, HELD_OUT_SEED_BASE + 3]
    assert (row["success_low"], row["success_high"]) == (0.25, 0.75)


def test_a_checked_evaluation_plays_each_episode_under_each_setting(monkeypatch):
    played: list[dict] = []
    real = ev.episode_trial
    monkeypatch.setattr(ev, "episode_trial", lambda spec: played.append(spec.scene["params"]) or real(spec))
    kw = {"max_episode_s": 0.5}
    (row,) = evaluate(["operator"], "evertgym/UBend-v0", 1, env_kwargs=kw, check_outcomes=True)
    assert played == [kw, *outcome_check_kwargs(kw)]
    assert row["success_low"] <= row["success_rate"] <= row["success_high"]
    assert row["undecided_episodes"] == len(row["undecided_seeds"])


def test_the_cli_flag_reports_the_checks_and_refuses_the_dynamic_engine(capsys, monkeypatch):
    from evertgym.cli import main

    played: list[int] = []
    monkeypatch.setattr(ev, "episode_trial", lambda spec: played.append(spec.seed))
    argv = ["eval", "constant", "--env", "evertgym/UBend-v0", "--episodes", "1", "--check-outcomes",
            "--env-kwargs", json.dumps({"sim_config": {"engine": "dynamic"}})]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--check-outcomes" in err and "'dynamic'" in err and "Traceback" not in err
    assert played == []
    monkeypatch.undo()
    assert main(["eval", "constant", "--env", "evertgym/UBend-v0", "--episodes", "1", "--check-outcomes", "--json",
                 "--env-kwargs", json.dumps({"max_episode_s": 0.5})]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["outcome_checks"] == [{"solver_tolerance": 1e-4}, {"growth_increment_m": SimConfig().growth_increment_m / 2}]
    assert {"undecided_episodes", "undecided_seeds", "success_low", "success_high"} <= set(out["rows"][0])
