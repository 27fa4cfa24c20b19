"""The Gymnasium environments: API conformance, determinism, bad actions, vector envs."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from evertgym.env import EversionEnv, register_envs

IDS = ["evertgym/UBend-v0", "evertgym/Tortuous-v0", "evertgym/Colon-v0", "evertgym/TortuousHard-v0", "evertgym/Colon-v1"]


def test_presets_are_registered_on_import():
    assert set(IDS) <= set(register_envs())
    for env_id in IDS:
        assert env_id in gym.registry


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id).unwrapped
    gym_check_env(env, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id):
    sb3_check_env(gym.make(env_id).unwrapped, warn=True)


def test_module_prefixed_id_imports_the_package():
    env = gym.make("evertgym:evertgym/UBend-v0")
    assert isinstance(env.unwrapped, EversionEnv)


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_actions_same_episode(env_id):
    def rollout():
        env = gym.make(env_id)
        obs, _ = env.reset(seed=123)
        rng = np.random.default_rng(7)
        out = [obs]
        rewards = []
        for _ in range(15):
            obs, r, term, trunc, _ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
            out.append(obs)
            rewards.append(r)
            if term or trunc:
                break
        return np.array(out), np.array(rewards)

    o1, r1 = rollout()
    o2, r2 = rollout()
    assert np.array_equal(o1, o2) and np.array_equal(r1, r2)


def test_different_seeds_draw_different_scenes():
    env = gym.make("evertgym/UBend-v0").unwrapped
    env.reset(seed=1)
    r1 = env.scene.params["radius_mm"]
    env.reset(seed=2)
    assert env.scene.params["radius_mm"] != r1
    assert 25.0 <= r1 <= 40.0


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises_before_the_simulation(bad):
    env = gym.make("evertgym/UBend-v0").unwrapped
    env.reset(seed=0)
    t, length, p = env.sim.t, env.sim.length, env.sim.regulator.command
    with pytest.raises(ValueError, match="NaN and inf are rejected"):
        env.step(np.array([bad], dtype=np.float32))
    assert (env.sim.t, env.sim.length, env.sim.regulator.command) == (t, length, p)


def test_action_maps_to_pressure_and_is_clipped_at_8kpa():
    env = gym.make("evertgym/UBend-v0").unwrapped
    env.reset(seed=0)
    env.step(np.array([0.0], dtype=np.float32))
    assert env.sim.regulator.command == pytest.approx(4000.0)
    with pytest.warns(UserWarning, match="outside the action space"):
        env.step(np.array([5.0], dtype=np.float32))  # out of the box: clipped, with a warning
    assert env.sim.regulator.command == pytest.approx(8000.0)
    for _ in range(20):
        env.step(np.array([1.0], dtype=np.float32))
    assert env.sim.pressure <= 8000.0 + 1e-9


def test_increment_mode_accumulates():
    env = EversionEnv(action_mode="increment", max_increment_kpa=0.5)
    env.reset(seed=0)
    for _ in range(4):
        env.step(np.array([1.0], dtype=np.float32))
    assert env.sim.regulator.command == pytest.approx(2000.0)
    env.step(np.array([-1.0], dtype=np.float32))
    assert env.sim.regulator.command == pytest.approx(1500.0)


def test_observation_flags_extend_the_observation():
    base = EversionEnv()
    full = EversionEnv(tip_sensing=True, scene_ahead=True)
    assert full.observation_space.shape[0] == base.observation_space.shape[0] + 2 + 10
    obs, _ = full.reset(seed=0)
    assert full.observation_space.contains(obs)


def test_reward_terms_respond_to_their_weights():
    env = EversionEnv(progress_weight=0.0, pressure_weight=1.0, contact_weight=0.0, stall_weight=0.0)
    env.reset(seed=0)
    _, r_hi, *_ = env.step(np.array([1.0], dtype=np.float32))
    env.reset(seed=0)
    _, r_lo, *_ = env.step(np.array([-0.5], dtype=np.float32))
    assert r_hi < r_lo <= 0.0


def test_peak_contact_reward_charges_the_episode_peak_once():
    """``contact_reward="peak"`` charges each rise of the episode's peak tip force: the terms sum to
    ``- contact_weight x`` the peak the evaluation reports, while the default charges every step's force
    (more, over a wall contact of several steps). Everything else in the episode is the same."""
    kw = dict(scene={"family": "ubend", "params": {"radius_mm": 30.0}}, contact_weight=2.0)
    sums = {}
    for mode in ("step", "peak"):
        env = EversionEnv(contact_reward=mode, **kw)
        env.reset(seed=0)
        total, lengths = 0.0, []
        for _ in range(60):  # 3 kPa: into the bend, where the tip meets the wall
            _, _, term, trunc, info = env.step(np.array([-0.25], dtype=np.float32))
            total += info["reward_contact"]
            lengths.append(info["insertion_length_mm"])
            assert info["reward_contact"] <= 0.0
            if term or trunc:
                break
        sums[mode] = (total, info["max_contact_force_n"], lengths)
    (step_sum, f_step, len_step), (peak_sum, f_peak, len_peak) = sums["step"], sums["peak"]
    assert len_step == len_peak and f_step == f_peak > 0.1  # the reward does not change the physics
    assert peak_sum == pytest.approx(-2.0 * f_peak, rel=1e-12)
    assert step_sum < 2.0 * peak_sum  # the wall was pushed over many steps


def test_success_terminates_with_info():
    env = gym.make("evertgym/UBend-v0", scene={"family": "ubend", "params": {"radius_mm": 40.0}})
    env.reset(seed=0)
    for _ in range(200):
        _, _, term, trunc, info = env.step(np.array([-0.25], dtype=np.float32))  # 3 kPa
        if term or trunc:
            break
    assert term and info["success"]
    assert info["peak_pressure_kpa"] == pytest.approx(3.0, abs=0.01)
    assert set(info) >= {"success", "peak_pressure_kpa", "max_contact_force_n", "stall_count", "insertion_length_mm"}
    # the tip went through the bend at the held 3 kPa: its bend peak is that pressure, reached
    # after the start-up (the regulator's approach to 3 kPa still creeps up in the bend)
    assert info["bend_entry_time_s"] is not None and 0.0 < info["bend_entry_time_s"] < info["time_s"]
    assert info["peak_pressure_bend_kpa"] == pytest.approx(3.0, abs=0.01)
    assert 0.0 < info["peak_pressure_time_s"] <= info["time_s"]


def test_bend_keys_at_reset_and_before_the_bend():
    env = gym.make("evertgym/UBend-v0")
    _, info = env.reset(seed=0)
    assert info["bend_entry_time_s"] is None and info["peak_pressure_bend_kpa"] == 0.0
    _, _, _, _, info = env.step(np.array([1.0], dtype=np.float32))
    assert info["bend_entry_time_s"] is None and info["peak_pressure_bend_kpa"] == 0.0  # 300 mm of pipe first


def test_time_limit_truncates():
    env = EversionEnv(max_episode_s=1.0)
    env.reset(seed=0)
    for k in range(20):  # noqa: B007 - k is read after the loop
        _, _, term, trunc, _ = env.step(np.array([-1.0], dtype=np.float32))  # 0 kPa: never grows
        if term or trunc:
            break
    assert trunc and not term and k == 9


def test_rgb_render():
    env = gym.make("evertgym/Colon-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.array([0.0], dtype=np.float32))
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(control_hz=0), "control_hz"),
        (dict(action_mode="force"), "action_mode"),
        (dict(band_offset_mm=(5, -5)), "band_offset_mm"),
        (dict(pressure_weight=-1), "pressure_weight"),
        (dict(scene={"family": "ubend", "params": {"radius_mm": 10.0}}), "radius_mm = 10 is out of range"),
        (dict(design={"tube": {"diameter_mm": -40}}), "diameter_m"),
        (dict(render_mode="video"), "render_mode"),
        (dict(contact_reward="max"), "contact_reward = 'max': allowed 'step' or 'peak'"),
    ],
)
def test_bad_constructor_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        env = EversionEnv(**kwargs)
        env.reset(seed=0)


def test_gymnasium_vector_env():
    envs = gym.make_vec("evertgym/UBend-v0", num_envs=2, vectorization_mode="sync")
    obs, _ = envs.reset(seed=[0, 1])
    assert obs.shape == (2, 15)
    obs, r, term, trunc, info = envs.step(np.zeros((2, 1), dtype=np.float32))
    assert r.shape == (2,)
    envs.close()


def _make_ubend():

    return gym.make("evertgym/UBend-v0")


@pytest.mark.parametrize("vec_cls", [DummyVecEnv, SubprocVecEnv])
def test_sb3_vec_envs(vec_cls):
    venv = vec_cls([_make_ubend, _make_ubend])
    venv.seed(3)
    obs = venv.reset()
    assert obs.shape == (2, 15)
    obs, rewards, dones, infos = venv.step(np.zeros((2, 1), dtype=np.float32))
    assert rewards.shape == (2,) and len(infos) == 2
    venv.close()
