"""Domain randomisation of what the paper does not give: regulator lag, wall friction, sensor noise."""

import gymnasium as gym
import numpy as np
import pytest

import evertgym  # noqa: F401  (registers the envs)
from evertgym.env import EversionEnv


def _episode(env, seed, steps=5, action=0.2):
    obs, info = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, _, _, _, info = env.step(np.array([action], np.float32))
        out.append(obs)
    return np.array(out), info


def test_without_randomisation_an_episode_is_what_it_was():
    """The draws come after the scene, band and entry draws: off, nothing changes."""
    a, info_a = _episode(gym.make("evertgym/UBend-v0"), seed=4)
    b, info_b = _episode(gym.make("evertgym/UBend-v0", regulator_tau_s=None, wall_friction=None,
                                  pressure_noise_kpa=0.0, insertion_noise_mm=0.0), seed=4)
    assert np.array_equal(a, b)
    assert info_a["regulator_tau_s"] == info_b["regulator_tau_s"] == 0.15
    # the bend model's friction factor (evertgym.sim.variation) multiplies the robot's coefficient of 1.0
    assert info_a["wall_friction"] == info_b["wall_friction"] == info_a["variation"]["friction_factor"]


def test_regulator_lag_and_wall_friction_are_drawn_per_episode_within_their_ranges():
    env = gym.make("evertgym/UBend-v0", regulator_tau_s=(0.1, 0.6), wall_friction=(0.5, 1.5))
    taus, frictions = [], []
    for seed in range(8):
        _, info = env.reset(seed=seed)
        sim = env.unwrapped.sim
        assert sim.regulator.tau == info["regulator_tau_s"] and sim.cfg.wall_friction == info["wall_friction"]
        taus.append(info["regulator_tau_s"])
        frictions.append(info["wall_friction"] / info["variation"]["friction_factor"])  # the range's draw, before the robot's factor
    assert all(0.1 <= t <= 0.6 for t in taus) and np.std(taus) > 0.05
    assert all(0.5 <= f <= 1.5 for f in frictions) and np.std(frictions) > 0.1
    # the same seed, the same draw; and the scene does not depend on it
    _, again = env.reset(seed=3)
    assert again["regulator_tau_s"] == taus[3]


def test_a_slower_regulator_lags_more():
    fast = gym.make("evertgym/UBend-v0", regulator_tau_s=(0.1, 0.1))
    slow = gym.make("evertgym/UBend-v0", regulator_tau_s=(0.6, 0.6))
    _, fast_info = _episode(fast, seed=1, steps=2, action=1.0)
    _, slow_info = _episode(slow, seed=1, steps=2, action=1.0)
    # after 0.2 s of an 8 kPa command: 8 (1 - exp(-0.2 / tau)) kPa
    assert fast_info["pressure_kpa"] == pytest.approx(8 * (1 - np.exp(-0.2 / 0.1)), rel=0.02)
    assert slow_info["pressure_kpa"] == pytest.approx(8 * (1 - np.exp(-0.2 / 0.6)), rel=0.02)


def test_sensor_noise_reaches_the_observation_not_the_info():
    clean = gym.make("evertgym/UBend-v0")
    noisy = gym.make("evertgym/UBend-v0", pressure_noise_kpa=0.5, insertion_noise_mm=2.0)
    names = clean.unwrapped.observation_names()
    p, ins = names.index("pressure[t]"), names.index("insertion[t]")
    a, info_a = _episode(clean, seed=2, steps=10, action=0.0)
    b, info_b = _episode(noisy, seed=2, steps=10, action=0.0)
    assert info_a["pressure_kpa"] == info_b["pressure_kpa"]  # the physics is the same
    assert a[-1][p] * 8.0 == pytest.approx(info_a["pressure_kpa"], abs=1e-5)
    err_p = (b[:, p] - a[:, p]) * 8.0  # kPa, where the observation was not clipped at 0 or 1
    err_i = (b[:, ins] - a[:, ins]) * 900.0  # mm (the 900 mm UBend-v0 robot)
    assert np.std(err_p[(b[:, p] > 0) & (b[:, p] < 1)]) == pytest.approx(0.5, rel=0.6)
    assert 0.5 < np.std(err_i) < 4.0


@pytest.mark.parametrize("kw, message", [
    ({"regulator_tau_s": (0.6, 0.1)}, "regulator_tau_s = .* has lo > hi"),
    ({"regulator_tau_s": 0.3}, "regulator_tau_s = 0.3 is not a \\[lo, hi\\] pair"),
    ({"wall_friction": (0.5, 9.0)}, "wall_friction = 9.0 is out of range"),
    ({"pressure_noise_kpa": -1.0}, "pressure_noise_kpa = -1.0 is out of range"),
    ({"insertion_noise_mm": float("nan")}, "insertion_noise_mm = nan"),
])
def test_bad_randomisation_is_one_line(kw, message):
    with pytest.raises(ValueError, match=message):
        EversionEnv(**kw)
