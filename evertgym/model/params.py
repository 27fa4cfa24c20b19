"""The versioned, calibrated parameter file of the model layer.

``evertgym/data/model_params.json`` is written by ``python -m evertgym.experiments.calibration`` (never by
hand) and records, beside every number, the data it was fitted on.  This module only
reads it.  All values in the file are SI.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent.parent / "data"
PARAMS_PATH = DATA_DIR / "model_params.json"
MEASUREMENTS_PATH = DATA_DIR / "measurements.json"


@dataclass(frozen=True)
class ModelParams:
    """Calibrated model parameters (SI).

    Attributes
    ----------
    e_eff_ref_pa, ref_pressure_pa, ref_radius_m, wall_thickness_m:
        The paper's identified ``E_eff`` (25.2 MPa) and the section and pressure it
        belongs to; the membrane modulus of the pressure law is anchored on them.
    pressure_stiffening:
        Multiplier of the Le van-Wielgosz pressure term.
    free_length_m:
        Free (cantilever) length of the paper's bending tests, fitted.
    band_transition_m, band_transition_exponent:
        Length over which the radius tapers from ``r`` to ``r (1 - rho)`` on each side of
        a band strip: ``band_transition_m * (rho / 0.5) ** band_transition_exponent``
        (exponent 0: a fixed taper; 1: a taper of fixed cone angle).
    alpha_reductions, alpha_values:
        ``alpha(rho)`` at the tabulated reductions; ``alpha(0) = 1``, linear in between.
    eversion_threshold:
        ``p0_pa``, ``a_pa``, ``c`` of the eversion threshold law (see
        :mod:`evertgym.model.eversion`) and where they came from.
    """

    e_eff_ref_pa: float
    ref_pressure_pa: float
    ref_radius_m: float
    wall_thickness_m: float
    pressure_stiffening: float
    poisson_ratio: float
    free_length_m: float
    band_transition_m: float
    band_transition_exponent: float
    alpha_reductions: tuple[float, ...]
    alpha_values: tuple[float, ...]
    eversion_threshold: dict
    version: str
    provenance: dict

    @property
    def membrane_modulus_pa(self) -> float:
        """``E_m`` such that ``E_eff(ref_pressure) = e_eff_ref`` on the reference section."""
        return self.e_eff_ref_pa - self.pressure_stiffening * self.ref_pressure_pa * self.ref_radius_m / (
            2.0 * self.wall_thickness_m
        )


def params_from_dict(d: dict) -> ModelParams:
    """Build :class:`ModelParams` from the JSON structure of the parameter file."""
    alpha = d["alpha_by_reduction"]
    keys = sorted(alpha, key=float)
    return ModelParams(
        e_eff_ref_pa=float(d["e_eff_ref_pa"]),
        ref_pressure_pa=float(d["ref_pressure_pa"]),
        ref_radius_m=float(d["ref_radius_m"]),
        wall_thickness_m=float(d["wall_thickness_m"]),
        pressure_stiffening=float(d["pressure_stiffening"]),
        poisson_ratio=float(d["poisson_ratio"]),
        free_length_m=float(d["free_length_m"]),
        band_transition_m=float(d["band_transition_m"]),
        band_transition_exponent=float(d.get("band_transition_exponent", 0.0)),
        alpha_reductions=tuple(float(k) for k in keys),
        alpha_values=tuple(float(alpha[k]) for k in keys),
        eversion_threshold=dict(d.get("eversion_threshold", {})),
        version=str(d.get("version", "unversioned")),
        provenance=dict(d.get("provenance", {})),
    )


@lru_cache(maxsize=1)
def load_params(path: str | None = None) -> ModelParams:
    """Read the calibrated parameter file (the packaged one unless ``path`` is given)."""
    p = Path(path) if path else PARAMS_PATH
    with open(p, encoding="utf-8") as f:
        return params_from_dict(json.load(f))


@lru_cache(maxsize=1)
def load_measurements() -> dict:
    """The paper's numbers (``evertgym/data/measurements.json``, shipped with the package)."""
    with open(MEASUREMENTS_PATH, encoding="utf-8") as f:
        return json.load(f)

