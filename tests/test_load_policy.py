"""load_policy: shipped policies by name, with the env they were trained on."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest

import evertgym  # noqa: F401
from evertgym.agents import load_policy, shipped_policies
from evertgym.agents.policies import resolve_policy_path
from evertgym.agents.tuned import shipped_dir

pytest.importorskip("stable_baselines3")

#: What agents/ ships, written out (not globbed) so that a policy added or lost shows here.
SHIPPED = ["colon_ppo", "colon_ppo_operator", "colon_residual_operator", "tortuous_ppo_operator", "tortuous_residual_operator",
           "tortuous_v1_residual_operator", "ubend_ppo", "ubend_ppo_operator", "ubend_residual_operator"]


def test_shipped_policy_loads_with_its_env_and_accepts_that_env_for_fine_tuning():
    from stable_baselines3.common.vec_env import DummyVecEnv

    policy, env_id, env_kwargs = load_policy("colon_ppo")
    assert env_id == "evertgym/Colon-v0" and env_kwargs == {"tip_sensing": True, "sim_config": {"engine": "dynamic"}}
    env = gym.make(env_id, **env_kwargs)
    obs, info = env.reset(seed=0)
    policy.reset(env)
    action = policy.act(obs, info)
    assert action.shape == (1,) and -1 <= action[0] <= 1
    # the saved space had +-10 bounds; the loaded model takes the env's, so SB3's check passes
    policy.model.set_env(DummyVecEnv([lambda: gym.make(env_id, **env_kwargs)] * policy.model.n_envs))
    assert policy.model.observation_space == env.observation_space


def test_a_path_a_run_folder_and_a_name_resolve_alike():
    zip_path = shipped_dir() / "ubend_ppo" / "final.zip"
    assert resolve_policy_path("ubend_ppo") == resolve_policy_path(zip_path.parent) == zip_path == resolve_policy_path(zip_path)
    assert shipped_policies() == SHIPPED


def test_unknown_policy_names_the_shipped_ones():
    with pytest.raises(ValueError, match=f"shipped: {re.escape(str(SHIPPED))}"):
        load_policy("no_such_policy")


def test_loaded_policy_acts_like_the_cli_path():
    from evertgym.agents.policies import make_policy

    a, env_id, kw = load_policy("ubend_ppo")
    b = make_policy("ubend_ppo")
    env = gym.make(env_id, **kw)
    obs, info = env.reset(seed=3)
    a.reset(env)
    b.reset(env)
    assert np.array_equal(a.act(obs, info), b.act(obs, info))


@pytest.mark.parametrize("name", SHIPPED)
def test_a_shipped_policy_was_trained_with_its_config_and_the_operator_ones_never_see_the_tip(name):
    """agents/<name>/final_env.json (written by the training) matches agents/<name>.toml, so
    `evertgym train agents/<name>.toml` reruns what is shipped; the *_operator policies
    observe only what an operator has (no tip force) and were trained under the randomised lag."""
    import json

    from evertgym.agents.train import load_config

    cfg = load_config(shipped_dir() / f"{name}.toml")
    meta = json.loads((shipped_dir() / name / "final_env.json").read_text())
    assert (meta["env_id"], meta["env_kwargs"]) == (cfg["env_id"], cfg["env_kwargs"])
    assert meta.get("deterministic", True) == cfg.get("deterministic", True)
    assert meta.get("residual") == cfg.get("residual_spec")  # a residual policy corrects the rule its config names
    policy, env_id, env_kwargs = load_policy(name)
    if name.endswith("_operator"):  # the lag comes from the config, or from the id's preset (TortuousHard-v0)
        env = gym.make(env_id, **env_kwargs)
        assert env_kwargs["tip_sensing"] is False and env.unwrapped.regulator_tau_range == (0.1, 0.6)
        assert env.observation_space.shape == (3 * (env.unwrapped.history + 1),)  # 3 per sample: no tip force
        env.close()


def test_compare_runs_tells_identical_policies_from_different_ones(capsys, tmp_path):
    import evertgym.agents.compare as mod  # evertgym compare-runs
    ubend, tortuous = shipped_dir() / "ubend_ppo_operator", shipped_dir() / "tortuous_ppo_operator"
    assert mod.main(str(ubend), str(ubend)) == 0
    assert "largest difference 0 (identical)" in capsys.readouterr().out
    assert mod.main(str(ubend), str(tortuous)) == 1
    assert "(different)" in capsys.readouterr().out
    assert mod.main(str(ubend), str(ubend / "nowhere")) == 2
    assert "has no model file" in capsys.readouterr().err
    # a checkpoint zip, its normaliser beside it under SB3's checkpoint names
    import shutil

    shutil.copy(ubend / "final.zip", tmp_path / "model_80000_steps.zip")
    shutil.copy(ubend / "final_vecnormalize.pkl", tmp_path / "model_vecnormalize_80000_steps.pkl")
    assert mod.main(str(ubend), str(tmp_path / "model_80000_steps.zip")) == 0
    (tmp_path / "model_vecnormalize_80000_steps.pkl").write_bytes(b"other statistics")
    assert mod.main(str(ubend), str(tmp_path / "model_80000_steps.zip")) == 1


@pytest.mark.parametrize(("name", "env_id", "rule", "scale"), [
    ("colon_residual_operator", "evertgym/Colon-v0", "cycle:low_kpa=0,high_kpa=3,period_s=1", 0.25),
    ("tortuous_residual_operator", "evertgym/Tortuous-v0", "cycle", 0.25),
    ("tortuous_v1_residual_operator", "evertgym/TortuousHard-v0", "cycle:low_kpa=2,high_kpa=8,period_s=2", 0.5),
    ("ubend_residual_operator", "evertgym/UBend-v0", "operator:start_kpa=0.8,step_kpa=0.1,stall_s=0.5,relax_kpa_per_s=0.25",
     0.05),
])
def test_a_shipped_residual_policy_plays_its_rule_within_its_scale(name, env_id, rule, scale):
    """A residual policy acts clip(rule + scale x correction): every command it plays lies within its scale of the
    rule's own command in the same state (Colon-v0: the 0 <-> 3 kPa wave, 1 kPa; Tortuous-v0: `cycle`'s 1 <-> 8 kPa
    wave, 1 kPa; UBend-v0: the tuned 0.1 kPa-step operator, 0.2 kPa), and it corrects the rule somewhere."""
    from evertgym.agents.policies import make_policy

    policy, got_env_id, env_kwargs = load_policy(name)
    assert (got_env_id, policy.residual) == (env_id, {"rule": rule, "scale": scale})
    env, rule_policy = gym.make(env_id, **env_kwargs), make_policy(rule)
    obs, info = env.reset(seed=1_000_000_000)
    policy.reset(env)
    rule_policy.reset(env)
    gaps = []
    for _ in range(20):
        a, b = policy.act(obs, info), rule_policy.act(obs, info)
        gaps.append(float(a[0] - b[0]))
        obs, _, term, trunc, info = env.step(a)
        if term or trunc:
            break
    assert max(abs(g) for g in gaps) <= scale + 1e-6
    assert max(abs(g) for g in gaps) > 0.01 * scale
