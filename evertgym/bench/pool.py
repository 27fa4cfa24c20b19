"""Throughput of the scoring backends: serial, process pool (1 and 2 workers) and Dask (2 workers).

Each backend runs the same N CPU-bound trials into a fresh result store with
:func:`evertgym.scoring.run_trials`.  By default a trial is a pure-Python busy loop
calibrated to about ``trial_s`` seconds (no I/O, no threads, so it measures the backends
and nothing else); with ``real`` each trial is the first trial of the paper's U-bend
protocol (:func:`evertgym.experiments.paper.ubend_specs`), repeated.

Per row: backend, workers, trials, wall time (s), trials per second, speed-up against the
process pool with 1 worker, and the mean compute time of one trial where it ran (s): when
that grows with the worker count, the CPUs are shared (other load, or fewer cores than
workers) and the speed-up is bounded by the machine, not the backend.

Wall times include starting the pool or cluster, except that the fork server (started once
per process) is warmed up before timing, and the row "dask (running cluster)" reuses a
LocalCluster started and warmed up beforehand (its start time is reported separately);
"dask (new LocalCluster)" includes starting one.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

from evertgym.scoring import ResultStore, TrialFn, TrialSpec, available_cpus, run_trials

BUSY_DESIGN = {"tube": {"diameter_mm": 40.0, "wall_thickness_mm": 0.05, "length_mm": 600.0}, "bands": []}


def busy_trial(spec: TrialSpec) -> dict:
    """Spin a pure-Python LCG for ``policy["iterations"]`` steps; a deterministic fake result."""
    x = spec.seed
    for _ in range(spec.policy["iterations"]):
        x = (x * 1103515245 + 12345) & 0x7FFFFFFF
    return {
        "success": x % 2 == 0,
        "time_s": float(x % 1000) / 100.0,
        "peak_pressure_kpa": 3.0,
        "max_contact_force_n": 0.0,
        "stall_position_mm": None,
    }


def busy_specs(n: int, iterations: int) -> list[TrialSpec]:
    """``n`` identical busy trials (same seed, so the same work), numbered 0..n-1."""
    return [
        TrialSpec(
            design=BUSY_DESIGN,
            design_name="busy",
            scene={"family": "straight", "params": {}, "seed": 0},
            policy={"name": "busy", "iterations": iterations},
            seed=12345,
            index=i,
            group="bench",
        )
        for i in range(n)
    ]


def calibrate_iterations(trial_s: float) -> int:
    """Busy-loop iterations that take about ``trial_s`` seconds on this machine (one core)."""
    probe = 200_000
    t0 = time.perf_counter()
    busy_trial(busy_specs(1, probe)[0])
    return max(1, int(probe * trial_s / (time.perf_counter() - t0)))


def real_specs(n: int) -> tuple[list[TrialSpec], TrialFn]:
    """``n`` copies of the paper's first U-bend trial, and the real trial function."""
    from evertgym.experiments.paper import ubend_specs
    from evertgym.experiments.trial import run_trial

    first = ubend_specs()[0]
    return [dataclasses.replace(first, index=i) for i in range(n)], run_trial


def _timed(specs: list[TrialSpec], trial_fn: TrialFn, workdir: Path, name: str, **kwargs) -> tuple[float, float]:
    """Wall time (s) of one ``run_trials`` call into a fresh store, and the mean trial compute time (s)."""
    with ResultStore(workdir / f"{name}.sqlite") as store:
        t0 = time.perf_counter()
        records = run_trials(specs, trial_fn, store, progress=False, **kwargs)
        wall = time.perf_counter() - t0
    if len(records) != len(specs):
        raise RuntimeError(f"{name}: {len(records)} records for {len(specs)} trials")
    return wall, sum(r.wall_s or 0.0 for r in records) / len(records)


def bench_pool(trials: int = 16, trial_s: float = 0.3, real: bool = False, dask: bool = True) -> dict:
    """Run every backend on the same trials; ``rows`` as described in the module docstring."""
    if trials < 1:
        raise ValueError(f"trials = {trials} is out of range: allowed >= 1")
    if not 0.01 <= trial_s <= 60:
        raise ValueError(f"trial_s = {trial_s} is out of range: allowed [0.01, 60] s")
    if real:
        specs, trial_fn = real_specs(trials)
        what = f"real trial: {specs[0].describe()}"
    else:
        iterations = calibrate_iterations(trial_s)
        specs, trial_fn = busy_specs(trials, iterations), busy_trial
        what = f"busy-loop trial of ~{trial_s:g} s ({iterations} iterations, pure Python)"
    timings: list[tuple[str, int, tuple[float, float]]] = []
    dask_start_s = None
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        _timed(specs[:1], trial_fn, workdir, "warmup", backend="process", workers=1)  # start the fork server
        timings.append(("serial", 1, _timed(specs, trial_fn, workdir, "serial", backend="serial")))
        for workers in (1, 2):
            timings.append(("process", workers, _timed(specs, trial_fn, workdir, f"p{workers}", backend="process", workers=workers)))
        if dask:
            from dask.distributed import LocalCluster

            timings.append(("dask (new LocalCluster)", 2, _timed(specs, trial_fn, workdir, "dask_new", backend="dask", workers=2)))
            t0 = time.perf_counter()
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
                # untimed trials (Dask spreads them over the idle workers) so the workers have imported everything
                _timed(specs[:2], trial_fn, workdir, "dask_warmup", backend="dask", address=cluster.scheduler_address)
                dask_start_s = time.perf_counter() - t0
                timings.append(("dask (running cluster)", 2, _timed(specs, trial_fn, workdir, "dask_running", backend="dask",
                                                                     address=cluster.scheduler_address)))
    base = next(wall for name, w, (wall, _) in timings if name == "process" and w == 1)
    rows = [
        {"backend": name, "workers": w, "trials": len(specs), "wall_s": wall, "trials_per_s": len(specs) / wall,
         "speedup_vs_1": base / wall, "mean_trial_s": mean}
        for name, w, (wall, mean) in timings
    ]
    return {"cpus": available_cpus(), "trial": what, "dask_start_s": dask_start_s, "rows": rows}


def format_pool(result: dict) -> list[str]:
    """The printed table of :func:`bench_pool`."""
    lines = [f"{result['cpus']} CPUs available; {result['rows'][0]['trials']} trials per row; {result['trial']}"]
    if result["dask_start_s"] is not None:
        lines.append(f"starting and warming the 2-worker LocalCluster took {result['dask_start_s']:.2f} s (not in its row)")
    lines.append(f"{'backend':<24} {'workers':>7} {'trials':>6} {'wall_s':>7} {'trials_per_s':>12} {'speedup_vs_1':>12} {'mean_trial_s':>12}")
    for r in result["rows"]:
        lines.append(f"{r['backend']:<24} {r['workers']:>7} {r['trials']:>6} {r['wall_s']:>7.2f} {r['trials_per_s']:>12.2f}"
                     f" {r['speedup_vs_1']:>12.2f} {r['mean_trial_s']:>12.3f}")
    return lines
