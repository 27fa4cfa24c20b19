"""Where trials run: in this process, in a local process pool, or on a Dask cluster.

Each backend is a generator ``backend(trial_fn, specs, workers, address)`` that yields
``(spec, Outcome)`` pairs in the order trials finish; it never writes results (the runner
does, in the parent process).  A trial's exception is caught where the trial ran and comes
back as an :class:`Outcome` with the error text, so one failing trial never stops the others.
Closing the generator early (an exception or Ctrl-C in the runner) cancels the trials not
yet started and shuts the pool or cluster down.

Process backend: a :class:`concurrent.futures.ProcessPoolExecutor` started with the
``forkserver`` method where the platform has it (Linux), else ``spawn`` (macOS, Windows).
Plain ``fork`` copies the parent's threads' locks in whatever state they are in (tqdm's
monitor thread, a Dask client, BLAS pools), which can deadlock a child; the fork server is a
clean single-threaded process from which workers fork cheaply (it is Python 3.14's default
on Linux).  The fork server preloads this module and ``trial_fn``'s module, so workers start
with the package already imported.  ``trial_fn`` must be picklable by reference: a top-level
function of an importable module (or of a script guarded by ``if __name__ == "__main__":``).
If a worker process dies (segfault, ``os._exit``, the OOM killer) the pool breaks; the
backend restarts it and reruns each trial that was in flight alone, so only a trial that
kills its worker by itself comes back as an error.

Dask backend: :class:`dask.distributed.Client` connected to ``address`` (a running
scheduler, e.g. ``"tcp://host:8786"``, whose workers have evertgym installed), or to a fresh
``LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)`` closed at the end.
A worker that dies is replaced and its trial rescheduled by Dask; a trial that kills
workers repeatedly comes back as a ``KilledWorker`` error.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import pickle
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

from evertgym.scoring.spec import TrialSpec

#: A trial function: a picklable top-level function ``TrialSpec -> dict``.
TrialFn = Callable[[TrialSpec], dict]


@dataclass(frozen=True)
class Outcome:
    """What came back from one trial: its raw result, or an error (one line and full traceback).

    ``wall_s`` is the trial's compute time in s where it ran (None if it never returned).
    """

    result: Any
    error: str | None
    traceback: str | None
    wall_s: float | None


def call_trial(trial_fn: TrialFn, spec: TrialSpec) -> Outcome:
    """Run ``trial_fn(spec)`` where it is called (a worker), timing it and catching its exception."""
    t0 = time.perf_counter()
    try:
        result = trial_fn(spec)
    except Exception as exc:
        return Outcome(None, f"{type(exc).__name__}: {exc}", traceback.format_exc(), time.perf_counter() - t0)
    return Outcome(result, None, None, time.perf_counter() - t0)


#: A backend: ``(trial_fn, specs, workers) -> iterator of (spec, Outcome)`` as trials finish.
#: Where a backend needs more (the Dask scheduler's address), it is bound with
#: :func:`functools.partial`, as :func:`evertgym.scoring.runner.run_trials` does.
Backend = Callable[[TrialFn, Sequence[TrialSpec], "int | None"], Generator[tuple[TrialSpec, Outcome], None, None]]


def _failed(exc: BaseException) -> Outcome:
    """An outcome for an exception raised while fetching a trial's result (not in the trial)."""
    return Outcome(None, f"{type(exc).__name__}: {exc}", "".join(traceback.format_exception(exc)), None)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one, else ``os.cpu_count()``)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def serial_backend(
    trial_fn: TrialFn, specs: Sequence[TrialSpec], workers: int | None = None
) -> Generator[tuple[TrialSpec, Outcome], None, None]:
    """Run the trials one after another in this process (``workers`` unused)."""
    for spec in specs:
        yield spec, call_trial(trial_fn, spec)


def _mp_context(trial_fn: TrialFn) -> multiprocessing.context.BaseContext:
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    # effective only when the fork server starts, i.e. at the first pool of this process
    module = getattr(trial_fn, "__module__", None)
    ctx.set_forkserver_preload([__name__] + ([module] if isinstance(module, str) else []))
    return ctx


def _exit_with_parent() -> None:
    """Pool worker initializer: end this worker when the runner process dies.

    ProcessPoolExecutor workers otherwise outlive a killed runner (SIGKILL, the OOM killer),
    idle and holding memory.  ``parent_process().sentinel`` becomes ready when the runner's
    end of the worker's pipe closes, i.e. when the runner is gone.
    """
    parent = multiprocessing.parent_process()
    if parent is None:  # not a child process: nothing to watch
        return
    sentinel = parent.sentinel

    def watch() -> None:
        multiprocessing.connection.wait([sentinel])
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def process_backend(
    trial_fn: TrialFn, specs: Sequence[TrialSpec], workers: int | None = None
) -> Generator[tuple[TrialSpec, Outcome], None, None]:
    """Run the trials in a local pool of ``workers`` processes (default: the CPUs available).

    At most ``workers`` trials are submitted at a time, so when a worker dies the suspects
    are exactly the trials in flight.  The pool is then restarted and each suspect rerun
    alone: one that kills its worker again is reported as failed, the others run normally.
    A trial that always crashes therefore cannot block a resumed sweep.
    """
    try:
        pickle.dumps(trial_fn)
    except Exception as exc:
        raise ValueError(
            f"trial_fn = {trial_fn!r} cannot be sent to worker processes ({exc}): "
            "allowed a top-level function of an importable module"
        ) from None
    ctx = _mp_context(trial_fn)
    workers = workers or available_cpus()
    queue: deque[TrialSpec] = deque(specs)
    suspects: deque[TrialSpec] = deque()
    running: dict[Future, tuple[TrialSpec, bool]] = {}  # future -> (spec, ran alone)
    pool = None
    try:
        while queue or suspects or running:
            if pool is None:
                pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_exit_with_parent)
            broken = False
            try:
                if suspects and not running:
                    fut = pool.submit(call_trial, trial_fn, suspects[0])  # popped once submitted
                    running[fut] = (suspects.popleft(), True)
                while not suspects and queue and len(running) < workers:
                    fut = pool.submit(call_trial, trial_fn, queue[0])
                    running[fut] = (queue.popleft(), False)
            except (BrokenProcessPool, OSError):
                # a worker died between the last wait and this submit: the spec stays queued,
                # the trials in flight are collected below and the pool restarts
                broken = True
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            while done:
                for fut in done:
                    spec, alone = running.pop(fut)
                    try:
                        outcome = fut.result()
                    except BrokenProcessPool:
                        broken = True
                        if not alone:
                            suspects.append(spec)
                            continue
                        outcome = Outcome(None, "its worker process died while it ran alone (a crash, "
                                                "os._exit or the out-of-memory killer)", None, None)
                    except Exception as exc:
                        outcome = _failed(exc)
                    yield spec, outcome
                # a broken pool fails every trial in flight: collect them all before restarting
                done = wait(running)[0] if broken else set()
            if broken:
                pool.shutdown(wait=True)
                pool = None
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


def dask_backend(
    trial_fn: TrialFn, specs: Sequence[TrialSpec], workers: int | None = None, address: str | None = None
) -> Generator[tuple[TrialSpec, Outcome], None, None]:
    """Run the trials on the Dask scheduler at ``address``, else on a local cluster of ``workers``."""
    from dask.distributed import Client, LocalCluster
    from dask.distributed import as_completed as dask_as_completed

    with ExitStack() as stack:
        if address is not None:
            try:  # an unreachable scheduler fails in 10 s, not 30; anything else there is not a scheduler
                client = stack.enter_context(Client(address, timeout="10s"))
            except Exception as e:  # noqa: BLE001 - distributed raises OSError, TimeoutError, even MemoryError
                raise ConnectionError(f"address = {address!r}: no Dask scheduler answered there ({type(e).__name__})") from None
        else:
            cluster = stack.enter_context(
                LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
            )
            client = stack.enter_context(Client(cluster))
        pending = {}
        for spec in specs:
            fut = client.submit(call_trial, trial_fn, spec, pure=False)
            pending[fut.key] = (fut, spec)
        for fut in dask_as_completed([f for f, _ in pending.values()]):
            _, spec = pending.pop(fut.key)
            try:
                outcome = fut.result()
            except Exception as exc:
                outcome = _failed(exc)
            fut.release()
            yield spec, outcome


#: Backends by name.
BACKENDS: dict[str, Backend] = {"serial": serial_backend, "process": process_backend, "dask": dask_backend}
