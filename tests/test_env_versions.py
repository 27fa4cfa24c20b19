"""TortuousHard-v0, the harder tortuous variant, beside Tortuous-v0, which stays as it was; the harder
variant's former id, evertgym/Tortuous-v1, is refused naming the new one."""

import gymnasium as gym
import numpy as np
import pytest

import evertgym.env as env_pkg
from evertgym.env import preset_kwargs, register_envs


def test_v0_and_v1_are_both_registered():
    ids = register_envs()
    assert "evertgym/Tortuous-v0" in ids and "evertgym/TortuousHard-v0" in ids


def test_v0_is_unchanged_and_v1_is_harder():
    v0, v1 = preset_kwargs("evertgym/Tortuous-v0"), preset_kwargs("evertgym/TortuousHard-v0")
    assert v0["scene"]["params"] == {"n_bends": [2, 4]}
    assert "regulator_tau_s" not in v0
    assert v1["scene"]["params"] == {"n_bends": [3, 6], "radius_mm": [20.0, 40.0]}
    assert v1["regulator_tau_s"] == (0.1, 0.6)
    # the robot, the rewards, the observations and the clock are v0's
    for key in ("design", "band_offset_mm", "control_hz", "max_episode_s", "history",
                "progress_weight", "pressure_weight", "contact_weight", "stall_weight", "success_weight"):
        assert v1[key] == v0[key], key
    assert gym.spec("evertgym/TortuousHard-v0").max_episode_steps == gym.spec("evertgym/Tortuous-v0").max_episode_steps == 300


def test_v1_draws_the_regulator_lag_per_episode():
    env = gym.make("evertgym/TortuousHard-v0").unwrapped
    taus = []
    for seed in range(6):
        env.reset(seed=seed)
        taus.append(env.sim.cfg.regulator_tau_s)
    assert all(0.1 <= t <= 0.6 for t in taus)
    assert len(set(taus)) == len(taus)
    # an explicit argument still overrides the preset's randomisation
    env = gym.make("evertgym/TortuousHard-v0", regulator_tau_s=(0.3, 0.3)).unwrapped
    env.reset(seed=0)
    assert env.sim.cfg.regulator_tau_s == pytest.approx(0.3)


def test_v1_channels_have_the_papers_bend_radii():
    """Every bend of a v1 channel has an inner-wall radius in the paper's 20-40 mm: the centreline's
    curvature radius is the inner radius plus half the lumen (45-60 mm), so 42.5-70 mm."""
    env = gym.make("evertgym/TortuousHard-v0").unwrapped
    for seed in range(4):
        env.reset(seed=seed)
        k = np.abs(env.scene.curvature)
        bent = k[k > 1e-6]
        assert 1.0 / bent.max() >= 0.0425 - 1e-4 and 1.0 / bent.max() <= 0.070 + 1e-4


def test_unknown_randomisation_key_is_refused_in_one_line(monkeypatch):
    preset = dict(env_pkg.load_preset("evertgym/TortuousHard-v0"))
    preset["randomisation"] = {"gravity": [0.0, 1.0]}
    monkeypatch.setattr(env_pkg, "load_preset", lambda env_id: preset)
    with pytest.raises(ValueError, match=r"randomisation\.gravity is not allowed: allowed \['regulator_tau_s'"):
        env_pkg.preset_kwargs("evertgym/TortuousHard-v0")


def test_the_former_id_of_the_harder_variant_names_the_new_one():
    from evertgym.cli_guard import check_env_id
    from evertgym.env import RENAMED_IDS, current_id

    assert RENAMED_IDS == {"evertgym/Tortuous-v1": "evertgym/TortuousHard-v0"}
    assert current_id("evertgym/Tortuous-v1") == "evertgym/TortuousHard-v0" and current_id("evertgym/UBend-v0") == "evertgym/UBend-v0"
    with pytest.raises(ValueError, match="renamed evertgym/TortuousHard-v0"):
        check_env_id("--env", "evertgym/Tortuous-v1")

