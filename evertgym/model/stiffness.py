"""The paper's virtual tensile test and its stiffness rows (Exp 1-3).

Protocol (paper, Sec. IV-A): the fully everted 600 mm robot is clamped at its base,
inflated to 6.9 kPa, and its tip pulled laterally by 20 mm; the stiffness index is
``k = F / 0.02 m``.  The free length between clamp and tip is not stated; it is a
calibrated parameter (about 200 mm, from ``3 E I / L^3 = 11.94 N/m``).  The tip is
modelled as free to rotate and to slide axially: the tester's force is purely lateral.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from evertgym.design import TubeDesign
from evertgym.model.cosserat import CosseratRod, RodSolution
from evertgym.model.params import ModelParams, load_measurements, load_params
from evertgym.model.section import TubeSection

PAPER_PRESSURE_PA = 6900.0
PAPER_DISPLACEMENT_M = 0.020


@dataclass(frozen=True)
class StiffnessRow:
    """One row of the paper's stiffness table (k in N/m, distances in mm)."""

    experiment: int
    role: str  # "calibrate" or "predict"
    bands_from_tip_mm: tuple[float, ...]
    reduction: float
    measured_n_per_m: float
    sd_n_per_m: float


def paper_rows() -> list[StiffnessRow]:
    """All rows of Exp 1-3 in the order of ``measurements.json``."""
    st = load_measurements()["stiffness_tests"]
    rows: list[StiffnessRow] = []
    role = {"calibrate_on": "calibrate", "predict": "predict"}
    e1 = st["experiment_1_band_count"]
    for r in e1["rows"]:
        red = e1["diameter_reduction"] if r["bands_from_tip_mm"] else 0.0
        rows.append(StiffnessRow(1, role[e1["role"]], tuple(r["bands_from_tip_mm"]), red, r["k_N_per_m"], r["sd"]))
    e2 = st["experiment_2_band_position"]
    for r in e2["rows"]:
        rows.append(
            StiffnessRow(2, role[e2["role"]], tuple(r["bands_from_tip_mm"]), e2["diameter_reduction"], r["k_N_per_m"], r["sd"])
        )
    e3 = st["experiment_3_diameter_reduction"]
    for r in e3["rows"]:
        red = r["diameter_reduction"]
        bands = tuple(e3["bands_from_tip_mm"]) if red > 0 else ()
        rows.append(StiffnessRow(3, role[e3["role"]], bands, red, r["k_N_per_m"], r["sd"]))
    return rows


def paper_prototype(
    bands_from_tip_mm: tuple[float, ...] | list[float],
    reduction: float,
    length_mm: float = 600.0,
    diameter_mm: float = 40.0,
    wall_thickness_mm: float = 0.05,
) -> TubeDesign:
    """The paper's prototype (or any tube) with bands at the given distances from the tip."""
    base = TubeDesign(diameter_mm / 1e3, wall_thickness_mm / 1e3, length_mm / 1e3)
    if reduction <= 0 or not bands_from_tip_mm:
        return base
    return base.with_bands_from_tip([d / 1e3 for d in bands_from_tip_mm], reduction)


def tensile_rod(
    design: TubeDesign,
    pressure_pa: float = PAPER_PRESSURE_PA,
    free_length_m: float | None = None,
    params: ModelParams | None = None,
    **rod_kwargs,
) -> CosseratRod:
    """The clamped rod of the tensile test: the last ``free_length_m`` of the body."""
    params = params or load_params()
    L = params.free_length_m if free_length_m is None else free_length_m
    if not (0 < L <= design.length_m):
        raise ValueError(f"free_length_m = {L!r} is out of range: allowed (0, {design.length_m}] m")
    return CosseratRod(TubeSection(design, pressure_pa, params), design.length_m - L, design.length_m, **rod_kwargs)


def virtual_tensile_test(
    design: TubeDesign,
    displacement_m: float = PAPER_DISPLACEMENT_M,
    pressure_pa: float = PAPER_PRESSURE_PA,
    free_length_m: float | None = None,
    params: ModelParams | None = None,
) -> RodSolution:
    """Equilibrium of the tensile test at a lateral tip displacement (m)."""
    rod = tensile_rod(design, pressure_pa, free_length_m, params)
    return rod.solve_lateral_displacement(displacement_m)


def force_displacement_curve(
    design: TubeDesign,
    displacements_m: np.ndarray,
    pressure_pa: float = PAPER_PRESSURE_PA,
    params: ModelParams | None = None,
) -> np.ndarray:
    """Lateral tip force (N) at each displacement (m), by continuation."""
    rod = tensile_rod(design, pressure_pa, params=params)
    forces, guess = [], None
    for d in displacements_m:
        if d == 0:
            forces.append(0.0)
            continue
        sol = rod.solve_lateral_displacement(float(d), fy_guess=guess)
        forces.append(sol.force[1])
        guess = sol.force[1] * (1.0 + 1e-3)
    return np.array(forces)
