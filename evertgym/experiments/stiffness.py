"""Exp 1-3 reproduced: the paper's stiffness index per row, from the calibrated rod model
and (optionally) from the pymunk chain (``evertgym reproduce stiffness``)."""

from __future__ import annotations

import math
from typing import Any

from evertgym.model.params import ModelParams, load_params
from evertgym.model.stiffness import (
    PAPER_DISPLACEMENT_M,
    paper_prototype,
    paper_rows,
    virtual_tensile_test,
)
from evertgym.sim.config import SimConfig
from evertgym.sim.tensile import TensileResult, sim_tensile_test


def rms(values: list[float]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else float("nan")


def reproduce_stiffness(params: ModelParams | None = None) -> dict:
    """Model stiffness index for every paper row; RMS relative errors by role.

    Returns the ``--json`` structure of ``evertgym reproduce stiffness``.
    """
    params = params or load_params()
    out_rows: list[dict[str, Any]] = []
    cache: dict[tuple, float] = {}
    for row in paper_rows():
        key = (row.bands_from_tip_mm, row.reduction)
        if key not in cache:
            sol = virtual_tensile_test(paper_prototype(row.bands_from_tip_mm, row.reduction), params=params)
            cache[key] = sol.force[1] / PAPER_DISPLACEMENT_M
        k = cache[key]
        out_rows.append(
            {
                "experiment": row.experiment,
                "role": row.role,
                "bands_from_tip_mm": list(row.bands_from_tip_mm),
                "reduction": row.reduction,
                "measured_n_per_m": row.measured_n_per_m,
                "sd_n_per_m": row.sd_n_per_m,
                "cosserat_n_per_m": k,
                "cosserat_rel_error": k / row.measured_n_per_m - 1.0,
            }
        )
    calib_keys = {(tuple(r["bands_from_tip_mm"]), r["reduction"]) for r in out_rows if r["role"] == "calibrate"}
    unseen = [
        r["cosserat_rel_error"]
        for r in out_rows
        if r["role"] == "predict" and (tuple(r["bands_from_tip_mm"]), r["reduction"]) not in calib_keys
    ]
    return {
        "rows": out_rows,
        "rms": {
            "calibrate": rms([r["cosserat_rel_error"] for r in out_rows if r["role"] == "calibrate"]),
            "predict": rms([r["cosserat_rel_error"] for r in out_rows if r["role"] == "predict"]),
            "predict_unseen_configurations": rms(unseen),
        },
        "params_version": params.version,
    }


def add_sim_columns(result: dict, displacement_m: float = 0.02, config: SimConfig | None = None) -> dict:
    """Add ``sim_force_n``, ``sim_n_per_m`` and ``sim_rel_error_vs_cosserat`` to each row
    of :func:`evertgym.model.stiffness.reproduce_stiffness`'s result (in place)."""
    cache: dict[tuple, TensileResult] = {}
    for row in result["rows"]:
        key = (tuple(row["bands_from_tip_mm"]), row["reduction"])
        if key not in cache:
            cache[key] = sim_tensile_test(paper_prototype(*key), displacement_m, config=config)
        res = cache[key]
        row["sim_force_n"] = res.force_n
        row["sim_n_per_m"] = res.n_per_m
        row["sim_rel_error_vs_cosserat"] = res.n_per_m / row["cosserat_n_per_m"] - 1.0
    return result
