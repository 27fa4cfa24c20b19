"""Deterministic stand-in trial functions for the scoring framework tests.

Importable by worker processes (a module, not a test file).  Each result is a function of the
spec alone, so serial, pooled, Dask and resumed runs must give identical results.
"""

import os
import time

import numpy as np

from evertgym.scoring import TrialSpec

DESIGN = {"tube": {"diameter_mm": 40.0, "wall_thickness_mm": 0.05, "length_mm": 600.0}, "bands": []}


def make_specs(n: int, sleep_s: float = 0.0, designs: tuple[str, ...] = ("bare", "b30")) -> list[TrialSpec]:
    """``n`` trials cycling over ``designs`` on a U-bend; ``sleep_s`` (s) is each trial's duration."""
    return [
        TrialSpec(
            design=DESIGN,
            design_name=designs[i % len(designs)],
            scene={"family": "ubend", "params": {"radius_mm": 25.0}, "seed": None},
            policy={"name": "constant", "pressure_kpa": 3.0, "sleep_s": sleep_s},
            seed=1000 + i,
            index=i,
            group=f"r{25 + 5 * (i % 3)}",
        )
        for i in range(n)
    ]


def fake_trial(spec: TrialSpec) -> dict:
    """Sleep ``policy["sleep_s"]`` s, then draw a result from the seed (numpy types on purpose)."""
    time.sleep(spec.policy["sleep_s"])
    rng = np.random.default_rng(spec.seed)
    p_success = 0.8 if spec.design_name == "b30" else 0.4
    success = rng.random() < p_success
    return {
        "success": success,
        "time_s": rng.uniform(5.0, 30.0),
        "peak_pressure_kpa": spec.policy["pressure_kpa"] + rng.uniform(0.0, 1.0),
        "max_contact_force_n": rng.uniform(0.1, 2.0),
        "stall_position_mm": None if success else float(rng.uniform(100.0, 400.0)),
        "n_steps": np.int64(rng.integers(100, 1000)),
    }


def failing_trial(spec: TrialSpec) -> dict:
    """:func:`fake_trial`, except that trials 3 and 7 raise."""
    if spec.index in (3, 7):
        raise RuntimeError(f"simulated failure in trial {spec.index}")
    return fake_trial(spec)


def invalid_trial(spec: TrialSpec) -> dict:
    """:func:`fake_trial`, except that trial 3 returns a result without ``success``."""
    result = fake_trial(spec)
    if spec.index == 3:
        del result["success"]
    return result


def crashing_trial(spec: TrialSpec) -> dict:
    """:func:`fake_trial`, except that trial 5's worker process dies abruptly."""
    if spec.index == 5:
        os._exit(3)
    return fake_trial(spec)
