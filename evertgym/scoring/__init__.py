"""Scoring: run designs x scenes x policies as seeded trials, in parallel, resumably, and summarise.

- :class:`TrialSpec` names one trial; its :attr:`~TrialSpec.key` (SHA-256 of its canonical
  JSON) identifies it everywhere.  A trial function ``TrialSpec -> dict`` returns a result
  with the keys of :data:`REQUIRED_RESULT_KEYS` (mm, kPa, N, s in the names) and any others.
- :class:`ResultStore` is an append-only SQLite file, one committed row per finished trial
  with the spec, result, run metadata (command, versions, platform, git revision) and times.
- :func:`run_trials` skips stored trials, runs the rest serially, in a process pool or on
  Dask, and stores each result the moment it comes back, so a killed run resumes.
- :func:`summarize` gives per-design success rates with Wilson intervals
  (:func:`wilson_interval`) and result medians; :func:`compare_rates` the difference of two
  designs' rates with its Newcombe interval (:func:`newcombe_interval`) and a verdict.

The physics trial and the paper's experiments live in :mod:`evertgym.experiments`; this package runs any trial
function and does not import it.
"""

from evertgym.scoring.backends import BACKENDS, Outcome, TrialFn, available_cpus
from evertgym.scoring.provenance import run_metadata
from evertgym.scoring.runner import (
    StaleResultsWarning,
    TrialFailure,
    TrialsFailed,
    run_trials,
)
from evertgym.scoring.spec import (
    REQUIRED_RESULT_KEYS,
    TrialResult,
    TrialResultError,
    TrialSpec,
    TrialSpecError,
    canonical_json,
    check_result,
)
from evertgym.scoring.stats import compare_rates, newcombe_interval, summarize, wilson_interval
from evertgym.scoring.store import ResultStore, TrialRecord

__all__ = [
    "BACKENDS",
    "REQUIRED_RESULT_KEYS",
    "Outcome",
    "ResultStore",
    "StaleResultsWarning",
    "TrialFailure",
    "TrialFn",
    "TrialRecord",
    "TrialResult",
    "TrialResultError",
    "TrialSpec",
    "TrialSpecError",
    "TrialsFailed",
    "available_cpus",
    "canonical_json",
    "check_result",
    "compare_rates",
    "newcombe_interval",
    "run_metadata",
    "run_trials",
    "summarize",
    "wilson_interval",
]
