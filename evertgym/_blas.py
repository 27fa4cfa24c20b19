"""One BLAS thread where the quasi-static engine's answers are computed, whatever the machine.

The compiled kernel (:mod:`evertgym.sim.kernel`) eliminates the colon's wall pieces with a
Schur complement whose matrix products numba hands to scipy's OpenBLAS.  OpenBLAS splits a
product over as many threads as the process may use, and a split sums in another order: measured
on a 2-core machine, 100 random-action Colon-v0 steps gave other observation bits with 2 BLAS
threads than with 1 (the same with ``OPENBLAS_NUM_THREADS=1`` as pinned to one CPU), and a PPO
training from the same config diverged from its first checkpoint.  The compliant wall's
compliance (``K^-1``, :mod:`evertgym.scenes.compliant`), from which each piece's spring comes,
depends on the threads too.  An answer must not move with the number of cores, so both run with
one BLAS thread (for these sizes a second thread buys little).  The limit is scoped with
threadpoolctl: the caller's own numpy keeps its threads outside the engine's calls (about 25 us per
call).
"""
from __future__ import annotations

from contextlib import AbstractContextManager
from functools import lru_cache

import scipy.linalg.cython_blas  # noqa: F401  (numba's BLAS: loaded before the controller looks for libraries)
from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread() -> AbstractContextManager:
    """A context in which every loaded BLAS (numpy's, scipy's) uses one thread."""
    return _controller().limit(limits=1, user_api="blas")
