"""One BLAS thread where the engine's answers go through BLAS, whatever the machine.

OpenBLAS splits a product over as many threads as the process may use, and a split sums in another
order: measured on a 2-core machine, 100 random-action Colon-v0 steps gave other observation bits
with 2 BLAS threads than with 1, and a PPO training from the same config diverged from its first
checkpoint.  So these run with one BLAS thread: the compliant wall's compliance (``K^-1``,
:mod:`evertgym.scenes.compliant`), from which each wall piece's spring comes, and the dense linear
solver's LAPACK factor (``linear_solver="dense"``).  The default semiseparable solver calls no BLAS
(:mod:`evertgym.sim.kernel.linear`), and its steps are not scoped.  The limit is scoped with
threadpoolctl: the caller's own numpy keeps its threads outside (about 25 us per call).
"""
from __future__ import annotations

from contextlib import AbstractContextManager
from functools import lru_cache

from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread() -> AbstractContextManager:
    """A context in which every loaded BLAS uses one thread."""
    return _controller().limit(limits=1, user_api="blas")
