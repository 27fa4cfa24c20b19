"""Run a list of trials with resume: skip stored keys, run the rest, store each as it finishes.

Results are written by this (the parent) process, one committed row per trial the moment it
comes back, so killing a run loses at most the trials in flight; running the same specs
again against the same store runs only what is missing.  A trial that raises (or returns an
invalid result) stores nothing; the others carry on, and :class:`TrialsFailed` is raised at
the end (or, with ``on_error="warn"``, a warning) listing every failure.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Iterable
from contextlib import closing
from dataclasses import dataclass

from tqdm import tqdm

from evertgym._extras import require
from evertgym.scoring.backends import BACKENDS, TrialFn, available_cpus, dask_backend
from evertgym.scoring.provenance import code_fingerprint, run_metadata
from evertgym.scoring.spec import TrialResultError, TrialSpec
from evertgym.scoring.store import ResultStore, TrialRecord

#: Failures listed one per line in a :class:`TrialsFailed` message (the rest are counted).
MAX_LISTED = 10


@dataclass(frozen=True)
class TrialFailure:
    """A trial that stored nothing: its spec, the one-line error and the full traceback text."""

    spec: TrialSpec
    error: str
    traceback: str | None


class TrialsFailed(RuntimeError):
    """Some trials failed; every other trial finished and is stored.  ``failures`` lists them."""

    def __init__(self, failures: list[TrialFailure], n_specs: int, store_path: str) -> None:
        self.failures = failures
        lines = [
            f"{len(failures)} of {n_specs} trials failed and stored nothing; every other trial is stored "
            f"in {store_path}, and running the same specs again retries only the failed ones:"
        ]
        lines += [f"  {f.spec.describe()}: {f.error}" for f in failures[:MAX_LISTED]]
        if len(failures) > MAX_LISTED:
            lines.append(f"  ... and {len(failures) - MAX_LISTED} more (see .failures)")
        if failures[0].traceback:
            lines += [f"first failure's traceback ({failures[0].spec.describe()}):", failures[0].traceback.rstrip()]
        super().__init__("\n".join(lines))


def _check_specs(specs: Iterable[TrialSpec]) -> list[TrialSpec]:
    specs = list(specs)
    seen: dict[str, int] = {}
    for i, spec in enumerate(specs):
        if not isinstance(spec, TrialSpec):
            raise ValueError(f"specs[{i}] = {spec!r} is not allowed: allowed a TrialSpec")
        if spec.key in seen:
            raise ValueError(
                f"specs[{i}] is the same trial as specs[{seen[spec.key]}] ({spec.describe()}): "
                "allowed distinct trials (give each its own index or seed)"
            )
        seen[spec.key] = i
    return specs


class StaleResultsWarning(UserWarning):
    """Stored trials that a resumed run reuses were computed by another build of evertgym."""


def _warn_if_stale(store: ResultStore, reused: list[str]) -> None:
    now = code_fingerprint()
    stale = [k for k, fp in store.fingerprints(reused).items() if fp != now]
    if stale:
        warnings.warn(StaleResultsWarning(
            f"{len(stale)} of the {len(reused)} stored trials reused from {store.path} were computed by another build "
            f"of evertgym (code fingerprint now {now}); their results are reused as they are: use a new store "
            "(--db) to recompute them"), stacklevel=3)


def run_trials(
    specs: Iterable[TrialSpec],
    trial_fn: TrialFn,
    store: ResultStore,
    backend: str = "process",
    workers: int | None = None,
    progress: bool = True,
    *,
    address: str | None = None,
    on_error: str = "raise",
) -> list[TrialRecord]:
    """Run every spec not yet in ``store`` and return the stored records of all specs, in spec order.

    - ``trial_fn``: a picklable top-level function ``TrialSpec -> dict`` (the dict as
      :func:`~evertgym.scoring.spec.check_result` requires); it must be deterministic in the
      spec for a resumed run to equal a clean one.
    - ``backend``: ``"process"`` (local process pool), ``"serial"`` (this process) or
      ``"dask"`` (see :mod:`evertgym.scoring.backends`).
    - ``workers``: pool size or local Dask cluster size, default the CPUs available; not
      allowed with ``address`` (the cluster has its own workers) and ignored by ``"serial"``.
    - ``address``: a Dask scheduler address, e.g. ``"tcp://host:8786"`` (``"dask"`` only).
    - ``progress``: show a tqdm progress bar (on stderr) counting finished trials.
    - ``on_error``: ``"raise"`` raises :class:`TrialsFailed` after all other trials finished;
      ``"warn"`` warns and returns the records of the trials that succeeded.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r} is not allowed: allowed one of {', '.join(BACKENDS)}")
    if on_error not in ("raise", "warn"):
        raise ValueError(f"on_error = {on_error!r} is not allowed: allowed 'raise' or 'warn'")
    if address is not None and backend != "dask":
        raise ValueError(f"address = {address!r} is not allowed with backend {backend!r}: allowed only with 'dask'")
    if backend == "dask":  # before the progress bar
        require("the dask backend", "dask", "distributed")
    if address is not None and workers is not None:
        raise ValueError(f"workers = {workers!r} is not allowed with an address: the cluster sets its workers")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers = {workers!r} is out of range: allowed an integer >= 1")
    if not callable(trial_fn):
        raise ValueError(f"trial_fn = {trial_fn!r} is not allowed: allowed a function TrialSpec -> dict")
    specs = _check_specs(specs)

    done = store.done_keys()
    todo = [s for s in specs if s.key not in done]
    _warn_if_stale(store, [s.key for s in specs if s.key in done])
    failures: list[TrialFailure] = []
    if todo:
        n_workers = (
            None if address is not None
            else 1 if backend == "serial"
            else min(workers or available_cpus(), len(todo))
        )
        meta = run_metadata(backend=backend, workers=n_workers, address=address, n_specs=len(specs), n_todo=len(todo))
        bar = tqdm(
            total=len(specs), initial=len(specs) - len(todo), unit="trial", desc=f"scoring ({backend})",
            disable=not progress, dynamic_ncols=True,
        )
        run = functools.partial(dask_backend, address=address) if backend == "dask" else BACKENDS[backend]
        with bar, closing(run(trial_fn, todo, n_workers)) as outcomes:
            for spec, out in outcomes:
                if out.error is None:
                    try:
                        store.add(spec, out.result, wall_s=out.wall_s, meta=meta)
                    except TrialResultError as exc:
                        failures.append(TrialFailure(spec, f"invalid result: {exc}", None))
                else:
                    failures.append(TrialFailure(spec, out.error, out.traceback))
                bar.update(1)
                if failures:
                    bar.set_postfix(failed=len(failures), refresh=False)

    by_key = {r.key: r for r in store.results(keys=[s.key for s in specs])}
    if failures:
        err = TrialsFailed(failures, len(specs), str(store.path))
        if on_error == "raise":
            raise err
        warnings.warn(str(err), RuntimeWarning, stacklevel=2)
    return [by_key[s.key] for s in specs if s.key in by_key]
