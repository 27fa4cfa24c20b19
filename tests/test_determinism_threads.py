"""The quasi-static engine's answers do not depend on the number of BLAS threads (cores)."""
from __future__ import annotations

import os
import subprocess
import sys

_EPISODE = """
import hashlib, numpy as np, gymnasium as gym
import evertgym  # noqa: F401
env = gym.make("evertgym/Colon-v0")
env.reset(seed=0)
rng = np.random.default_rng(0)
h = hashlib.sha256()
for _ in range(100):
    obs, r, te, tr, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
    h.update(np.asarray(obs, np.float64).tobytes()); h.update(np.float64(r).tobytes())
    if te or tr:
        env.reset()
print(h.hexdigest())
"""


def _digest(threads: int) -> str:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": str(threads)}
    out = subprocess.run([sys.executable, "-c", _EPISODE], capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_colon_steps_are_the_same_bits_with_one_or_two_blas_threads():
    """100 random-action Colon-v0 steps (compliant wall pieces: the Schur complement's matrix
    products and the wall's compliance go through BLAS) give the same observations and rewards,
    bit for bit, with one BLAS thread and with two.  Before :mod:`evertgym._blas` they did not
    (the rewards differed), and a PPO training diverged from its own config on another core count."""
    assert _digest(1) == _digest(2)
