"""load_policy: shipped policies by name, with the env they were trained on."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import evertgym  # noqa: F401
from evertgym.agents import load_policy, shipped_policies
from evertgym.agents.policies import resolve_policy_path
from evertgym.agents.tuned import shipped_dir

pytest.importorskip("stable_baselines3")

#: What agents/ ships, written out (not globbed) so that a policy added or lost shows here.
SHIPPED = ["colon_ppo_operator", "colon_residual_operator", "tortuous_residual_operator", "tortuous_v1_residual_operator",
           "ubend_ppo_operator", "ubend_residual_operator"]


def test_shipped_policy_loads_with_its_env_and_accepts_that_env_for_fine_tuning():
    from stable_baselines3.common.vec_env import DummyVecEnv

    policy, env_id, env_kwargs = load_policy("colon_ppo_operator")
    assert env_id == "evertgym/Colon-v0"
    assert env_kwargs == {"tip_sensing": False, "regulator_tau_s": [0.1, 0.6], "sim_config": {"engine": "quasistatic"}}
    env = gym.make(env_id, **env_kwargs)
    obs, info = env.reset(seed=0)
    policy.reset(env)
    action = policy.act(obs, info)
    assert action.shape == (1,) and -1 <= action[0] <= 1
    policy.model.set_env(DummyVecEnv([lambda: gym.make(env_id, **env_kwargs)] * policy.model.n_envs))
    assert policy.model.observation_space == env.observation_space


def test_a_model_saved_with_the_old_bounds_takes_the_envs_and_accepts_that_env_for_fine_tuning(tmp_path):
    """Models saved before 0.2.0 have observation bounds of +-10: the loaded model takes the env's, so SB3's check passes."""
    import shutil

    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    policy, env_id, env_kwargs = load_policy("colon_ppo_operator")
    old = gym.spaces.Box(-10.0, 10.0, policy.model.observation_space.shape, np.float32)
    policy.model.observation_space = policy.model.policy.observation_space = old
    policy.model.save(tmp_path / "final.zip")
    for f in ("final_env.json", "final_vecnormalize.pkl"):
        shutil.copy(shipped_dir() / "colon_ppo_operator" / f, tmp_path / f)
    assert PPO.load(tmp_path / "final.zip").observation_space == old  # saved with the old bounds
    policy, env_id, env_kwargs = load_policy(tmp_path, trust=True)
    env = gym.make(env_id, **env_kwargs)
    assert policy.model.observation_space == env.observation_space != old
    policy.model.set_env(DummyVecEnv([lambda: gym.make(env_id, **env_kwargs)] * policy.model.n_envs))
    obs, info = env.reset(seed=0)
    policy.reset(env)
    assert policy.act(obs, info).shape == (1,)


def test_a_path_a_run_folder_and_a_name_resolve_alike():
    zip_path = shipped_dir() / "ubend_ppo_operator" / "final.zip"
    assert resolve_policy_path("ubend_ppo_operator") == resolve_policy_path(zip_path.parent) == zip_path == resolve_policy_path(zip_path)
    assert shipped_policies() == SHIPPED


def test_unknown_policy_names_the_shipped_ones():
    with pytest.raises(ValueError, match=f"shipped: {re.escape(str(SHIPPED))}"):
        load_policy("no_such_policy")


def test_loaded_policy_acts_like_the_cli_path():
    from evertgym.agents.policies import make_policy

    a, env_id, kw = load_policy("ubend_ppo_operator")
    b = make_policy("ubend_ppo_operator")
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


@pytest.mark.parametrize("name", SHIPPED)
def test_no_shipped_policy_pins_a_non_default_engine_or_solver(name):
    """Every shipped policy was trained on the default physics, and neither its config nor its
    final_env.json pins a simulator setting (colon_ppo and ubend_ppo, trained on the dynamic
    engine, were retired for this: their configs are in agents/tries/)."""
    import json

    from evertgym.agents.policies import trained_engine
    from evertgym.agents.train import load_config
    from evertgym.sim.config import SimConfig

    meta = json.loads((shipped_dir() / name / "final_env.json").read_text())
    assert "sim_config" not in meta["env_kwargs"] and "sim_config" not in load_config(shipped_dir() / f"{name}.toml")["env_kwargs"]
    assert trained_engine(name) == meta["engine"] == SimConfig().engine == "quasistatic"


def test_a_retired_policy_is_neither_shipped_nor_trusted_and_its_config_trains_by_path():
    from evertgym.agents.train import load_config, resolve_config
    from evertgym.agents.trust import trusted_hashes

    tries = Path(__file__).resolve().parents[1] / "agents" / "tries"  # a checkout's: tries are not installed
    for name in ("colon_ppo", "ubend_ppo", "tortuous_ppo_operator"):
        assert name not in shipped_policies() and not (shipped_dir() / name).exists()
        with pytest.raises(ValueError, match="nor a shipped policy"):
            load_policy(name)
        with pytest.raises(ValueError, match="neither a file nor a shipped config"):
            resolve_config(name)
        retired = tries / f"{name}.toml"
        assert retired.read_text().startswith("# Retired, not a shipped policy")
        assert load_config(retired)["name"] == name
    assert len(trusted_hashes()) == 2 * len(SHIPPED)  # a model file and its statistics per shipped policy, no more


def test_compare_runs_tells_identical_policies_from_different_ones(capsys, tmp_path):
    import evertgym.agents.compare as mod  # evertgym compare-runs
    ubend, colon = shipped_dir() / "ubend_ppo_operator", shipped_dir() / "colon_ppo_operator"
    assert mod.main(str(ubend), str(ubend)) == 0
    assert "largest difference 0 (identical)" in capsys.readouterr().out
    assert mod.main(str(ubend), str(colon)) == 1
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
    ("tortuous_v1_residual_operator", "evertgym/TortuousHard-v0", "cycle", 0.25),
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
