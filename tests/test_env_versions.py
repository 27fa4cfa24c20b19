"""TortuousHard-v0, the harder tortuous variant, beside Tortuous-v0, which stays as it was; the harder
variant's former id, evertgym/Tortuous-v1, is refused naming the new one.  Colon-v1, a new version of
Colon-v0 with 3-5 flexures, beside Colon-v0, whose channels are unchanged."""

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



def test_colon_v1_adds_flexures_and_leaves_colon_v0_as_it_was():
    v0, v1 = preset_kwargs("evertgym/Colon-v0"), preset_kwargs("evertgym/Colon-v1")
    assert v0["scene"]["params"] == {} and "regulator_tau_s" not in v0 and v0["max_episode_s"] == 30.0
    assert v1["scene"]["params"] == {"n_flexures": {"choice": [3, 4, 5]}}
    assert v1["regulator_tau_s"] == (0.1, 0.6) and v1["max_episode_s"] == 40.0
    assert gym.spec("evertgym/Colon-v1").max_episode_steps == 400
    assert v1["design"]["tube"]["length_mm"] == 1600.0 and v0["design"]["tube"]["length_mm"] == 800.0
    # the tube's diameter, the bands, their offset, the rewards, the observations and the clock are v0's
    assert v1["design"]["bands"] == v0["design"]["bands"]
    assert v1["design"]["tube"]["diameter_mm"] == v0["design"]["tube"]["diameter_mm"]
    for key in ("band_offset_mm", "control_hz", "history",
                "progress_weight", "pressure_weight", "contact_weight", "stall_weight", "success_weight"):
        assert v1[key] == v0[key], key
    assert v1["scene"]["family"] == v0["scene"]["family"] == "colon_random"
    env = gym.make("evertgym/Colon-v1").unwrapped
    drawn = set()
    for seed in range(12):
        env.reset(seed=seed)
        drawn.add(env.scene.params["n_flexures"])
        assert len(env.scene.bend_regions()) == env.scene.params["n_flexures"]
        assert env.scene.goal_arclength < 1.6 - 0.1  # the robot reaches past the goal
    assert drawn == {3, 4, 5}
    # Colon-v0's channels are the ones it drew before flexures existed (goal and length of its first episodes)
    v0_env = gym.make("evertgym/Colon-v0").unwrapped
    for seed, goal, length in [(0, 0.5360314053622854, 0.6109176108118509), (1, 0.49949264400366006, 0.5995503279976779),
                               (2, 0.5051518856556269, 0.5782582615105379)]:
        v0_env.reset(seed=seed)
        assert (v0_env.scene.goal_arclength, v0_env.scene.length) == pytest.approx((goal, length), rel=1e-12)
