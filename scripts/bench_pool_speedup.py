#!/usr/bin/env python
"""Throughput of the scoring backends: serial, process pool (1 and 2 workers) and Dask (2 workers).

    python scripts/bench_pool_speedup.py [--trials 16] [--trial-s 0.3] [--real] [--no-dask]

Each backend runs the same N CPU-bound trials into a fresh result store with
``evertgym.scoring.run_trials``.  By default a trial is a pure-Python busy loop calibrated
here to about ``--trial-s`` seconds (no I/O, no threads, so it measures the backends and
nothing else).  With ``--real`` each trial is the same physics trial instead: the first
U-bend spec (see :func:`real_specs`), repeated with indices 0..N-1 and run by
``evertgym.scoring.trial.run_trial``.

Printed: backend, workers, trials, wall time (s), trials per second, speedup against the
process pool with 1 worker, and the mean compute time of one trial where it ran (s): when
that grows with the worker count, the CPUs are shared (other load, or fewer cores than
workers) and the speedup is bounded by the machine, not the backend.

Wall times include starting the pool or cluster, except that the fork server (started once
per process) is warmed up before timing, and that the row "dask (running cluster)" reuses a
LocalCluster started and warmed up beforehand (its start time is printed separately);
"dask (new LocalCluster)" includes starting one.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
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
    """``n`` copies of the first real U-bend trial, and the real trial function.

    The specs come from ``evertgym.scoring.trial.ubend_trial_specs()`` or, failing that,
    ``evertgym.scoring.paper.ubend_specs()`` (the paper's U-bend protocol), called with no
    arguments.
    """
    try:
        from evertgym.scoring.trial import run_trial
    except ImportError as exc:
        sys.exit(f"--real needs evertgym.scoring.trial.run_trial: {exc}")
    try:
        from evertgym.scoring.trial import ubend_trial_specs as source
    except ImportError:
        try:
            from evertgym.scoring.paper import ubend_specs as source
        except ImportError as exc:
            sys.exit(f"--real needs evertgym.scoring.trial.ubend_trial_specs or "
                     f"evertgym.scoring.paper.ubend_specs: {exc}")
    first = next(iter(source()))
    return [dataclasses.replace(first, index=i) for i in range(n)], run_trial


def timed(specs: list[TrialSpec], trial_fn: TrialFn, workdir: Path, name: str, **kwargs) -> tuple[float, float]:
    """Wall time (s) of one ``run_trials`` call into a fresh store, and the mean trial compute time (s)."""
    with ResultStore(workdir / f"{name}.sqlite") as store:
        t0 = time.perf_counter()
        records = run_trials(specs, trial_fn, store, progress=False, **kwargs)
        wall = time.perf_counter() - t0
    assert len(records) == len(specs)
    return wall, sum(r.wall_s for r in records) / len(records)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=16, help="trials per backend (default 16)")
    ap.add_argument("--trial-s", type=float, default=0.3, help="busy-loop trial duration in s (default 0.3)")
    ap.add_argument("--real", action="store_true", help="run real U-bend trials from evertgym.scoring.trial")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask rows")
    args = ap.parse_args(argv)
    if args.trials < 1:
        ap.error(f"--trials = {args.trials} is out of range: allowed >= 1")
    if not 0.01 <= args.trial_s <= 60:
        ap.error(f"--trial-s = {args.trial_s} is out of range: allowed [0.01, 60] s")

    if args.real:
        specs, trial_fn = real_specs(args.trials)
        what = f"real trial: {specs[0].describe()}"
    else:
        iterations = calibrate_iterations(args.trial_s)
        specs, trial_fn = busy_specs(args.trials, iterations), busy_trial
        what = f"busy-loop trial of ~{args.trial_s:g} s ({iterations} iterations, pure Python)"
    print(f"{available_cpus()} CPUs available; {args.trials} trials per row; {what}")

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        timed(specs[:1], trial_fn, workdir, "warmup", backend="process", workers=1)  # start the fork server
        rows.append(("serial", 1, timed(specs, trial_fn, workdir, "serial", backend="serial")))
        for workers in (1, 2):
            rows.append(("process", workers, timed(specs, trial_fn, workdir, f"p{workers}", backend="process",
                                                   workers=workers)))
        if not args.no_dask:
            from dask.distributed import LocalCluster

            rows.append(("dask (new LocalCluster)", 2, timed(specs, trial_fn, workdir, "dask_new",
                                                             backend="dask", workers=2)))
            t0 = time.perf_counter()
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
                # untimed trials (Dask spreads them over the idle workers) so the workers have imported everything
                timed(specs[:2], trial_fn, workdir, "dask_warmup", backend="dask", address=cluster.scheduler_address)
                start_s = time.perf_counter() - t0
                rows.append(("dask (running cluster)", 2, timed(specs, trial_fn, workdir, "dask_running",
                                                                backend="dask", address=cluster.scheduler_address)))
            print(f"starting and warming the 2-worker LocalCluster took {start_s:.2f} s (not in its row)")

    base = next(wall for name, w, (wall, _) in rows if name == "process" and w == 1)
    print(f"{'backend':<24} {'workers':>7} {'trials':>6} {'wall_s':>7} {'trials_per_s':>12} {'speedup_vs_1':>12}"
          f" {'mean_trial_s':>12}")
    for name, workers, (wall, trial_s) in rows:
        print(f"{name:<24} {workers:>7} {len(specs):>6} {wall:>7.2f} {len(specs) / wall:>12.2f} {base / wall:>12.2f}"
              f" {trial_s:>12.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
