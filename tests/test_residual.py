"""Residual policies: a learned correction on top of a rule (evertgym.agents.residual)."""

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from evertgym.agents import OperatorProtocol
from evertgym.agents.residual import ResidualOnRule, check_residual, combine, with_base
from evertgym.agents.train import load_config


def test_a_zero_correction_plays_the_rule_step_for_step():
    """The wrapper's action 0 is the rule's action: the same pressures, lengths and rewards as the
    rule alone, and the rule's command is the observation's last entry."""
    kwargs = {"max_episode_s": 2.0}
    plain = gym.make("evertgym/UBend-v0", **kwargs)
    rule = OperatorProtocol(start_kpa=2.5)
    obs, info = plain.reset(seed=3)
    rule.reset(plain)
    trace = []
    while True:
        obs, r, term, trunc, info = plain.step(rule.act(obs, info))
        trace.append((info["pressure_kpa"], info["insertion_length_mm"], r))
        if term or trunc:
            break
    wrapped = ResidualOnRule(gym.make("evertgym/UBend-v0", **kwargs), OperatorProtocol(start_kpa=2.5), 0.25)
    assert wrapped.observation_space.shape == (plain.observation_space.shape[0] + 1,)
    obs, info = wrapped.reset(seed=3)
    assert obs[-1] == pytest.approx(2.0 * 2.5 / 8.0 - 1.0)
    assert info["rule_command_kpa"] == pytest.approx(2.5)
    got = []
    while True:
        obs, r, term, trunc, info = wrapped.step(np.zeros(1, np.float32))
        got.append((info["pressure_kpa"], info["insertion_length_mm"], r))
        assert wrapped.observation_space.contains(obs)
        if term or trunc:
            break
    assert got == trace


def test_the_correction_is_scaled_and_the_action_clipped():
    np.testing.assert_allclose(combine(np.array([0.0]), np.array([1.0]), 0.25), [0.25])
    np.testing.assert_allclose(combine(np.array([0.9]), np.array([1.0]), 0.25), [1.0])
    np.testing.assert_allclose(combine(np.array([-1.0]), np.array([-1.0]), 0.5), [-1.0])
    assert combine(np.array([0.0]), np.array([0.5]), 0.25).dtype == np.float32
    np.testing.assert_array_equal(with_base(np.zeros(3, np.float32), np.array([0.5])), [0, 0, 0, 0.5])


@pytest.mark.parametrize("spec, field", [
    ({"rule": "colon_ppo_operator", "scale": 0.25}, "residual ="),  # a trained model is not a rule
    ({"rule": "nosuch", "scale": 0.25}, "residual ="),
    ({"rule": "tuned", "scale": 0.0}, "residual_scale = 0.0"),
    ({"rule": "tuned", "scale": 3}, "residual_scale = 3"),
    ({"rule": "tuned", "scale": "big"}, "residual_scale = 'big'"),
    ({"rule": "tuned", "scale": True}, "residual_scale = True"),
    ({"rule": "tuned", "extra": 1}, "residual ="),
])
def test_bad_residual_specs_are_refused_in_one_line(spec, field):
    with pytest.raises(ValueError) as e:
        check_residual(spec)
    assert str(e.value).startswith(field) and "allowed" in str(e.value) and "\n" not in str(e.value)


def test_a_rule_with_parameters_is_a_residual_rule():
    assert check_residual({"rule": "cycle:low_kpa=0,high_kpa=3,period_s=1", "scale": 0.5}) == {
        "rule": "cycle:low_kpa=0,high_kpa=3,period_s=1", "scale": 0.5}
    assert check_residual(None) is None


def _config(tmp_path: Path, extra: str, name: str = "res") -> Path:
    p = tmp_path / f"{name}.toml"
    p.write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nseed = 1\nn_envs = 1\nn_timesteps = 128\nnormalize = true\n'
                 "checkpoint_freq = 64\neval_episodes = 0\n" + extra +
                 "[env_kwargs]\nmax_episode_s = 1.0\n[hyperparams]\nn_steps = 64\nbatch_size = 32\nn_epochs = 1\n")
    return p


@pytest.mark.parametrize("extra, message", [
    ("zoo = false\nresidual_scale = 0.5\n", "residual_scale = 0.5 without residual"),
    ('residual = "tuned"\n', "zoo = true with residual"),
    ('zoo = false\nresidual = "tuned"\nresidual_scale = 9\n', "residual_scale = 9 is out of range"),
    ('zoo = false\nresidual = "operator:start_kpa=20"\n', "start_kpa = 20"),
])
def test_training_configs_with_a_bad_residual_are_refused(tmp_path, extra, message):
    with pytest.raises(ValueError, match=message):
        load_config(_config(tmp_path, extra))


def test_a_trained_residual_model_is_played_with_its_rule(tmp_path):
    """A model trained on a correction of the tuned operator carries its rule in ``final_env.json``;
    evaluation plays the rule with it: at a correction scale of 1e-6 the episode is the rule's."""
    pytest.importorskip("stable_baselines3")
    from evertgym.agents.evaluate import evaluate
    from evertgym.agents.policies import make_policy
    from evertgym.agents.train import train

    cfg = _config(tmp_path, 'zoo = false\nresidual = "tuned"\nresidual_scale = 1e-6\n')
    out = train(cfg, tmp_path / "runs", progress=False)
    model = Path(out["run_dir"]) / "final.zip"
    policy = make_policy(str(model), trust=True)
    assert policy.residual == {"rule": "tuned", "scale": 1e-6}
    assert policy.env_observation_shape == (15,) and policy.model.observation_space.shape == (16,)
    rows = evaluate([{"name": "agent", "path": str(model)}, "tuned"], "evertgym/UBend-v0", 2, trust=True,
                    env_kwargs={"max_episode_s": 3.0})
    assert rows[0]["mean_peak_pressure_kpa"] == pytest.approx(rows[1]["mean_peak_pressure_kpa"], abs=1e-3)
    assert rows[0]["mean_max_contact_force_n"] == pytest.approx(rows[1]["mean_max_contact_force_n"], abs=1e-3)
    assert rows[0]["success_rate"] == rows[1]["success_rate"]
