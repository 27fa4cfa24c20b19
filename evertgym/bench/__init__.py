"""Benchmarks of the simulator: accuracy against the rod model and cost (:mod:`evertgym.bench.accuracy`)."""

from evertgym.bench.accuracy import (
    FIDELITY_FIELDS,
    SweepSetting,
    default_settings,
    run_sweep,
    skip_costs,
)

__all__ = ["FIDELITY_FIELDS", "SweepSetting", "default_settings", "run_sweep", "skip_costs"]
