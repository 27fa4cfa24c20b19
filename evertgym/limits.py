"""Resource limits at the edges: counts the CLI and the Python entry points accept.

A bad count is rejected before any work starts, with the field, the value and the limit.
``docs/robustness.md`` lists these numbers; ``tests/test_robustness.py`` checks them.
"""

from __future__ import annotations

import os

#: Episodes of one ``evaluate`` call / ``evertgym eval`` (the seed list is built up front).
MAX_EPISODES = 100_000
#: Scene seeds of one ``evertgym score`` run.
MAX_SCENES = 100_000
#: Trials per scene of one ``evertgym score`` run.
MAX_TRIALS_PER_SCENE = 10_000
#: Trial specs one ``evertgym score`` run may plan (scenes x trials x designs).
MAX_SPECS = 1_000_000
#: Bands on one design (a 1000-band design builds in seconds: docs/robustness.md).
MAX_BANDS = 1000
#: Events the simulator keeps in ``EversionSim.events``; later ones are only counted.
MAX_EVENTS = 10_000


def cpu_count() -> int:
    """CPUs this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def check_workers(workers: int | None, force: bool = False, field: str = "workers") -> int | None:
    """``workers`` if it is ``None`` or in [1, CPU count] (any positive count with ``force``)."""
    if workers is None:
        return None
    n = cpu_count()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"{field} = {workers!r} is out of range: allowed integers in [1, {n}] (the CPU count)")
    if workers > n and not force:
        raise ValueError(
            f"{field} = {workers} is out of range: allowed [1, {n}] (the CPU count); "
            "more processes than CPUs only compete for them (force with --force-workers)"
        )
    return workers
