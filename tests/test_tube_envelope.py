"""The compiled collision-radius envelope (``sim.tube._envelope``) against the numpy form it replaced."""

import numpy as np

from evertgym.sim.tube import _envelope


def _numpy_envelope(s: np.ndarray, r: np.ndarray, a: float, b: float) -> float:
    i0 = int(np.searchsorted(s, a - 1e-12, side="left"))
    i1 = int(np.searchsorted(s, b + 1e-12, side="right"))
    return float(np.max(r[i0:i1])) if i1 > i0 else -1.0


def test_the_envelope_is_the_largest_radius_over_the_samples_in_the_span():
    rng = np.random.default_rng(7)
    for _ in range(500):
        s = np.sort(rng.uniform(0.0, 1.0, rng.integers(2, 60)))
        r = rng.uniform(0.005, 0.02, s.size)
        a = float(rng.choice([rng.uniform(-0.1, 1.1), s[rng.integers(s.size)]]))  # spans starting on a sample, too
        b = a + float(rng.choice([0.0, 1e-13, rng.uniform(0.0, 0.3)]))
        assert _envelope(s, r, a, b) == _numpy_envelope(s, r, a, b)
    s = np.array([0.0, 0.1, 0.2])
    assert _envelope(s, np.array([1.0, 3.0, 2.0]), 0.05, 0.25) == 3.0
    assert _envelope(s, np.array([1.0, 3.0, 2.0]), 0.12, 0.18) == -1.0  # no sample inside: the caller interpolates
