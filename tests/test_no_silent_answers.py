"""Results that must not be wrong without a word: a study of one scene is not the answer for
another, a model runs on the engine it was trained on, an action outside the action space is
not clipped in silence, and the band-design objective states its tie-break."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from evertgym.cli import main


def _quick_trial(spec) -> dict:
    """A trial that runs no simulation: success drawn from the seed and the scene."""
    rng = np.random.default_rng([spec.seed or 0, int(spec.scene["params"].get("radius_mm", 0))])
    success = bool(rng.random() < 0.5)
    return {"success": success, "time_s": 5.0, "peak_pressure_kpa": 3.0, "max_contact_force_n": 0.5,
            "stall_position_mm": None if success else 100.0, "n_steps": 10}


# ---- a band-design study is kept per scene and settings ---------------------------------------
def test_optimize_starts_a_new_study_for_another_scene_and_says_so(tmp_path, monkeypatch, capsys):
    pytest.importorskip("optuna")
    import evertgym.experiments.optimize as optimize
    from evertgym.scoring.store import ResultStore

    monkeypatch.setattr(optimize, "run_trial", _quick_trial)
    kw = dict(study_path=tmp_path / "s.sqlite", store_path=tmp_path / "t.sqlite", n_trials=2, n_scenes=1, trials_per_scene=1,
              held_out_scenes=1, backend="serial")
    first = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, **kw)
    assert first["study"]["new"] and first["study"]["other_studies"] == []
    other = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 25.0}}, **kw)
    # a search for 25 mm: its own designs on 25 mm training scenes, not the 30 mm answer
    assert other["study"]["new"] and other["study"]["resumed_designs"] == 0 and other["trials"] == 2
    with ResultStore(tmp_path / "t.sqlite") as store:
        searched = {r.spec.scene["params"]["radius_mm"] for r in store.results() if r.spec.design_name.startswith("candidate")}
    assert searched == {25.0, 30.0}
    assert "radius_mm = 30.0" in optimize.study_text(other["study"])
    again = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, **kw)  # resumes the 30 mm study
    assert not again["study"]["new"] and again["study"]["resumed_designs"] == 2 and again["best_params"] == first["best_params"]
    with pytest.raises(ValueError, match="budget_kpa"):
        optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, budget_kpa=9.0, **kw)


def test_optimize_prints_its_study_and_its_tie_break(tmp_path, monkeypatch, capsys):
    pytest.importorskip("optuna")
    import evertgym.experiments.optimize as optimize

    monkeypatch.setattr(optimize, "run_trial", _quick_trial)
    argv = ["optimize", "--trials", "2", "--scenes", "1", "--trials-per-scene", "1", "--held-out", "1", "--backend", "serial",
            "--study", str(tmp_path / "s.sqlite"), "--db", str(tmp_path / "t.sqlite")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "study: a new one in" in out
    assert "minus 0.001 per band" in out and "fewer bands is best" in out
    assert main([*argv, "--scene-params", '{"radius_mm": 25}']) == 0
    out = capsys.readouterr().out
    assert "study: a new one in" in out and "other study is kept" in out
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "0.001 per band" in out["objective"] and out["study"]["resumed_designs"] == 2


# ---- an action outside the action space --------------------------------------------------------
def test_an_action_outside_the_action_space_warns_once_per_env():
    import gymnasium as gym

    import evertgym  # noqa: F401 - registers the envs

    env = gym.make("evertgym/UBend-v0", max_episode_s=1.0)
    env.reset(seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.step(np.array([0.5], dtype=np.float32))  # inside: no warning
        assert not [w for w in caught if "action space" in str(w.message)]
        env.step(np.array([10.0], dtype=np.float32))  # 10 kPa meant, 8 kPa played
        env.step(np.array([-3.0], dtype=np.float32))
    found = [str(w.message) for w in caught if "action space" in str(w.message)]
    assert len(found) == 1, found
    assert "action = 10 is outside the action space [-1, 1] and is clipped to 1" in found[0] and "kPa" in found[0]
    assert env.unwrapped.command_pa == 0.0  # -3 clipped to -1: 0 kPa
    env.close()
    other = gym.make("evertgym/UBend-v0", max_episode_s=1.0)  # a new env warns again
    other.reset(seed=0)
    with pytest.warns(UserWarning, match="outside the action space"):
        other.step(np.array([1.5]))
    other.close()


# ---- a trained model runs on the engine it was trained on ---------------------------------------
@pytest.fixture
def dynamic_model(tmp_path):
    """A model whose metadata says it was trained on the dynamic engine: a copy of ubend_ppo_operator (no
    shipped policy is), so loading it needs --trust-model / trust=True."""
    pytest.importorskip("stable_baselines3")
    import shutil

    from evertgym.agents.tuned import shipped_dir

    run = tmp_path / "dynamic_run"
    shutil.copytree(shipped_dir() / "ubend_ppo_operator", run)
    meta = json.loads((run / "final_env.json").read_text())
    (run / "final_env.json").write_text(json.dumps({**meta, "engine": "dynamic"}))
    return str(run / "final.zip")


def test_eval_runs_a_model_on_the_engine_it_was_trained_on(dynamic_model, capsys):
    # the model was trained on the dynamic engine; the default is the quasi-static one
    assert main(["eval", dynamic_model, "--trust-model", "--env", "evertgym/UBend-v0", "--episodes", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["engine"] == "dynamic" and out["env_kwargs"] == {"sim_config": {"engine": "dynamic"}}


def test_eval_and_rollout_refuse_another_engine_in_one_line_naming_the_flag(dynamic_model, tmp_path, capsys):
    qs = '{"sim_config": {"engine": "quasistatic"}}'
    for argv, says in (
            (["eval", dynamic_model, "operator", "--env", "evertgym/UBend-v0", "--episodes", "1", "--env-kwargs", qs],
             "trained on the dynamic engine but the env runs the quasistatic engine"),
            (["rollout", dynamic_model, "--env", "evertgym/UBend-v0", "--out", str(tmp_path / "x.gif"), "--env-kwargs", qs],
             "trained on the dynamic engine but the env runs the quasistatic engine"),
            (["eval", dynamic_model, "ubend_ppo_operator", "--env", "evertgym/UBend-v0", "--episodes", "1"],  # two engines
             f"trained on different engines ({dynamic_model} on the dynamic, ubend_ppo_operator on the quasistatic)")):
        assert main([*argv, "--trust-model"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert says in err and "--allow-engine-mismatch" in err, err
    assert not (tmp_path / "x.gif").exists()


def test_a_checkpoint_whose_metadata_names_the_dynamic_engine_runs_there(dynamic_model, capsys):
    from evertgym.agents.policies import on_trained_engine

    model = dynamic_model
    assert on_trained_engine([model, "operator"], {}) == {"sim_config": {"engine": "dynamic"}}
    assert on_trained_engine([model], {"regulator_tau_s": 0.2}) == {"regulator_tau_s": 0.2, "sim_config": {"engine": "dynamic"}}
    assert on_trained_engine(["operator"], {}) == {}  # baselines run on what they are given
    assert on_trained_engine([model], {"sim_config": {"engine": "quasistatic"}}, allow_mismatch=True) == {
        "sim_config": {"engine": "quasistatic"}}
    with pytest.raises(ValueError, match="allow_engine_mismatch=True"):
        from evertgym.agents.evaluate import evaluate

        evaluate([model], "evertgym/UBend-v0", 1, env_kwargs={"sim_config": {"engine": "quasistatic"}}, trust=True)
    assert main(["eval", model, "--trust-model", "--env", "evertgym/UBend-v0", "--episodes", "1",
                 "--env-kwargs", '{"sim_config": {"engine": "quasistatic"}}']) == 2
    assert "--allow-engine-mismatch" in capsys.readouterr().err


def test_load_policy_names_the_engine_and_its_policy_refuses_another(dynamic_model):
    import gymnasium as gym

    from evertgym.agents import load_policy

    policy, env_id, env_kwargs = load_policy(dynamic_model, trust=True)
    assert env_kwargs["sim_config"]["engine"] == "dynamic"
    env = gym.make(env_id, **env_kwargs)
    obs, info = env.reset(seed=0)
    policy.reset(env)  # its own engine
    env.close()
    other = gym.make(env_id)  # the default engine: quasi-static
    other.reset(seed=0)
    with pytest.raises(ValueError, match="trained on the dynamic engine but the env runs the quasistatic engine.*allow_engine_mismatch"):
        policy.reset(other)
    policy, _, _ = load_policy(dynamic_model, trust=True, allow_engine_mismatch=True)
    policy.reset(other)
    other.close()
    _, _, kw = load_policy("ubend_ppo_operator")  # trained on the quasi-static engine: named, not left to the default
    assert kw["sim_config"] == {"engine": "quasistatic"}
