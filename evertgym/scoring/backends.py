"""Where trials run: in this process, in a local process pool, or on a Dask cluster.

Each backend is a generator ``backend(trial_fn, specs, workers, address)`` that yields
``(spec, Outcome)`` pairs in the order trials finish; it never writes results (the runner
does, in the parent process).  A trial's exception is caught where the trial ran and comes
back as an :class:`Outcome` with the error text, so one failing trial never stops the others.
Closing the generator early (an exception or Ctrl-C in the runner) cancels the trials not
yet started and shuts the pool or cluster down.

Process backend: ``workers`` worker processes, each running one trial at a time over its
own pipe, started with the ``forkserver`` method where the platform has it (Linux), else
``spawn`` (macOS, Windows).  Plain ``fork`` copies the parent's threads' locks in whatever
state they are in (tqdm's monitor thread, a Dask client, BLAS pools), which can deadlock a
child; the fork server is a clean single-threaded process from which workers fork cheaply
(it is Python 3.14's default on Linux).  The fork server preloads this module and
``trial_fn``'s module, so workers start with the package already imported.  ``trial_fn``
must be picklable by reference: a top-level function of an importable module (or of a script
guarded by ``if __name__ == "__main__":``).  If a worker process dies (segfault,
``os._exit``, the OOM killer) only its trial is affected: it is rerun alone, so only a trial
that kills its worker by itself comes back as an error.

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
import signal
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Generator, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

from evertgym._extras import require
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
    """In a worker: end this process when the runner process dies.

    Workers otherwise outlive a killed runner (SIGKILL, the OOM killer) until their trial
    ends.  ``parent_process().sentinel`` becomes ready when the runner's end of the
    worker's pipe closes, i.e. when the runner is gone.
    """
    parent = multiprocessing.parent_process()
    if parent is None:  # not a child process: nothing to watch
        return
    sentinel = parent.sentinel

    def watch() -> None:
        multiprocessing.connection.wait([sentinel])
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _worker_main(conn: multiprocessing.connection.Connection, trial_fn: TrialFn) -> None:
    """A pool worker: run each spec received on ``conn`` and send its :class:`Outcome` back.

    Ends when the runner sends ``None`` or closes its end.  SIGINT is ignored: Ctrl-C in a
    terminal reaches the whole process group, and the runner, which gets it too, ends the
    workers itself.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _exit_with_parent()
    while True:
        try:
            spec = conn.recv()
        except (EOFError, OSError):
            return
        if spec is None:
            return
        outcome = call_trial(trial_fn, spec)
        try:
            conn.send(outcome)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:  # an unpicklable result
            conn.send(Outcome(None, f"the trial's result cannot be sent back ({type(exc).__name__}: {exc})",
                              None, outcome.wall_s))


class _Worker:
    """One worker process and the parent's end of its pipe; runs one trial at a time."""

    def __init__(self, ctx: Any, trial_fn: TrialFn) -> None:
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child, trial_fn), daemon=True, name="evertgym-trial")
        self.proc.start()
        child.close()
        self.spec: TrialSpec | None = None  # the trial it runs, None when idle
        self.alone = False  # whether that trial was the only one running

    def end(self, kill: bool) -> None:
        """Stop the worker: ask it to exit (idle) or kill it (``kill``, a trial running), then reap it."""
        if not kill:
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                kill = True
        self.conn.close()
        if kill and self.proc.is_alive():
            self.proc.kill()
        self.proc.join(5)
        if self.proc.is_alive():  # did not take the hint within 5 s
            self.proc.kill()
            self.proc.join()


_DIED = ("its worker process died while it ran alone (a crash, os._exit or the out-of-memory killer)")


def process_backend(
    trial_fn: TrialFn, specs: Sequence[TrialSpec], workers: int | None = None
) -> Generator[tuple[TrialSpec, Outcome], None, None]:
    """Run the trials in a local pool of ``workers`` processes (default: the CPUs available).

    Each worker runs one trial at a time over its own pipe, and the runner watches each
    worker's pipe and its process sentinel, so a worker that dies names the one trial it
    ran; the other trials go on.  A trial whose worker died while others ran is rerun
    alone (the out-of-memory killer may have picked the wrong process): one that kills its
    worker again is reported as failed.  A trial that always crashes therefore cannot block
    a resumed sweep.  The runner holds no threads or feeder queues (unlike
    :class:`concurrent.futures.ProcessPoolExecutor`, whose shutdown after a worker crash can
    deadlock on CPython 3.11, gh-125451), so ending the pool cannot hang.
    """
    try:
        pickle.dumps(trial_fn)
    except Exception as exc:
        raise ValueError(
            f"trial_fn = {trial_fn!r} cannot be sent to worker processes ({exc}): "
            "allowed a top-level function of an importable module"
        ) from None
    ctx = _mp_context(trial_fn)
    n_workers = workers or available_cpus()
    queue: deque[TrialSpec] = deque(specs)
    suspects: deque[TrialSpec] = deque()
    idle: list[_Worker] = []
    busy: list[_Worker] = []

    def start(spec: TrialSpec, alone: bool) -> None:
        while True:
            w = idle.pop() if idle else _Worker(ctx, trial_fn)
            try:
                w.conn.send(spec)
            except OSError:  # it died while idle: replace it
                w.end(kill=True)
                continue
            w.spec, w.alone = spec, alone
            busy.append(w)
            return

    try:
        while queue or suspects or busy:
            if suspects and not busy:
                start(suspects.popleft(), alone=True)
            while not suspects and queue and len(busy) < n_workers:
                start(queue.popleft(), alone=False)
            ready = set(multiprocessing.connection.wait([w.conn for w in busy] + [w.proc.sentinel for w in busy]))
            for w in [w for w in busy if w.conn in ready or w.proc.sentinel in ready]:
                spec = w.spec
                assert spec is not None
                busy.remove(w)
                outcome: Outcome | None = None
                if w.conn in ready:
                    try:
                        outcome = w.conn.recv()
                    except (EOFError, OSError):
                        outcome = None  # it died before it answered
                    except Exception as exc:  # an answer that cannot be read back
                        outcome = _failed(exc)
                if outcome is not None:
                    w.spec = None
                    idle.append(w)
                    yield spec, outcome
                    continue
                w.end(kill=True)
                if w.alone:
                    yield spec, Outcome(None, _DIED, None, None)
                else:
                    suspects.append(spec)
    finally:
        for w in busy:
            w.end(kill=True)
        for w in idle:
            w.end(kill=False)


def dask_backend(
    trial_fn: TrialFn, specs: Sequence[TrialSpec], workers: int | None = None, address: str | None = None
) -> Generator[tuple[TrialSpec, Outcome], None, None]:
    """Run the trials on the Dask scheduler at ``address``, else on a local cluster of ``workers``."""
    require("the dask backend", "dask", "distributed")
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
