"""Pressure dependence of an inflated thin-walled tube: stiffening, wrinkling, collapse.

Everything here is SI: pressure in Pa, lengths in m, moments in N m.

Sources
-------
* Effective modulus.  Le van, A. & Wielgosz, C. (2005) "Bending and buckling of
  inflatable beams: some new theoretical results", Thin-Walled Structures 43:1166-1187,
  show that an inflated tube of membrane modulus ``E_m`` bends like a beam of
  modulus ``E_m + P/S`` where ``P = p pi r^2`` is the pressure end-force and
  ``S = 2 pi r t`` the wall area, i.e. ``E_eff(p) = E_m + kappa_p * p r / (2 t)``.
  ``kappa_p`` (1 in their theory) is exposed so that a user can switch the
  pressure stiffening off (0) or scale it.  We anchor ``E_m`` on the paper's
  identified ``E_eff = 25.2 MPa`` at 6.9 kPa for the 40 mm tube.
* Wrinkling and collapse.  Comer, R. L. & Levy, S. (1963) "Deflections of an
  inflated circular-cylindrical cantilever beam", AIAA J. 1(7):1652-1655, and
  Stein, M. & Hedgepeth, J. M. (1961) NASA TN D-813: a membrane that cannot carry
  compression wrinkles when the bending stress cancels the axial pre-stress
  ``p r / (2 t)``, at ``M_w = p pi r^3 / 2``; the wrinkled (tension-field) section
  still carries moment until it collapses at ``M_c = p pi r^3``.  Between the two
  the moment-curvature law follows from a taut arc ``|phi| < phi0`` carrying a
  linear strain and a slack arc carrying none:

      M(phi0) / (p pi r^3) = (phi0 - sin phi0 cos phi0) / (2 (sin phi0 - phi0 cos phi0))
      kappa(phi0) / kappa_w = pi / (sin phi0 - phi0 cos phi0),  kappa_w = M_w / (E I)

  ``phi0 = pi`` is wrinkling onset, ``phi0 -> 0`` collapse (a kink: curvature
  grows without bound at ``M_c``).  This is the law every joint of the simulator and
  every section of the rod model uses, so a band (smaller r) kinks first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from evertgym._validate import check_range
from evertgym.design import TubeDesign
from evertgym.model.params import ModelParams, load_params

#: Normalised moment M/M_c past which a section counts as kinked: its curvature is then
#: about 27 kappa_w (a radius of curvature of the order of the tube radius) and it turns
#: into a hinge whose moment barely rises.
KINK_MOMENT_FRACTION = 0.95
#: The tabulated tension-field law ends here (kappa ~ 840 kappa_w); past it the moment
#: continues with the slope it has there, so the law stays invertible for any moment.
LAW_END_FRACTION = 0.995


def _tension_field_table(n: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """Universal curve of the wrinkled section: (M/M_c, kappa/kappa_w), both increasing."""
    phi0 = np.linspace(math.pi, 1e-3, n)
    s, c = np.sin(phi0), np.cos(phi0)
    denom = s - phi0 * c
    m_hat = (phi0 - s * c) / (2.0 * denom)  # M / (p pi r^3) = M / M_c
    kappa_hat = math.pi / denom  # kappa / kappa_w
    return m_hat, kappa_hat


_M_HAT, _KAPPA_HAT = _tension_field_table()
#: kappa/kappa_w where the section kinks, and the slope d(kappa/kappa_w)/d(M/M_c) there.
KINK_CURVATURE_RATIO = float(np.interp(KINK_MOMENT_FRACTION, _M_HAT, _KAPPA_HAT))
_END_CURVATURE_RATIO = float(np.interp(LAW_END_FRACTION, _M_HAT, _KAPPA_HAT))
_END_SLOPE = float((_END_CURVATURE_RATIO - np.interp(LAW_END_FRACTION - 1e-5, _M_HAT, _KAPPA_HAT)) / 1e-5)


def _uniform_cubic_table(n: int = 8000) -> tuple[float, float, np.ndarray]:
    """Cubic-spline coefficients of kappa/kappa_w on a uniform grid of M/M_c in [0.5, LAW_END].

    The scalar evaluator below is C2-smooth, which an adaptive ODE integrator needs
    (a piecewise-linear table makes it crawl over every table kink).
    """
    from scipy.interpolate import CubicSpline

    phi0 = np.linspace(math.pi, 1e-4, 200_000)
    s, c = np.sin(phi0), np.cos(phi0)
    m_fine = (phi0 - s * c) / (2.0 * (s - phi0 * c))
    k_fine = math.pi / (s - phi0 * c)
    grid = np.linspace(0.5, LAW_END_FRACTION, n)
    spline = CubicSpline(grid, np.interp(grid, m_fine, k_fine))
    return 0.5, grid[1] - grid[0], np.asarray(spline.c).T.copy()


_TABLE: tuple[float, float, np.ndarray] | None = None  # built on first use (scipy.interpolate is not loaded with an env)


def wrinkled_curvature_ratio_scalar(moment_fraction: float) -> float:
    """Fast C2 scalar version of :func:`wrinkled_curvature_ratio` for ODE right-hand sides."""
    global _TABLE
    if moment_fraction > LAW_END_FRACTION:
        return _END_CURVATURE_RATIO + _END_SLOPE * (moment_fraction - LAW_END_FRACTION)
    if _TABLE is None:
        _TABLE = _uniform_cubic_table()
    grid0, h, coefs = _TABLE
    mf = max(moment_fraction, 0.5)
    i = min(int((mf - grid0) / h), len(coefs) - 1)
    dx = mf - (grid0 + i * h)
    a, b, c, d = coefs[i]
    return ((a * dx + b) * dx + c) * dx + d


def wrinkled_curvature_ratio(moment_fraction: float | np.ndarray) -> float | np.ndarray:
    """kappa/kappa_w on the tension-field branch for ``moment_fraction = M/M_c`` >= 0.5.

    Past :data:`KINK_MOMENT_FRACTION` the section is kinked (a hinge: ten times more
    curvature costs a few percent more moment).  Past :data:`LAW_END_FRACTION` the
    curvature continues linearly with the slope it has there, so the law stays invertible.
    """
    mf = np.maximum(np.asarray(moment_fraction, dtype=float), 0.5)
    below = np.interp(np.minimum(mf, LAW_END_FRACTION), _M_HAT, _KAPPA_HAT)
    return np.where(mf > LAW_END_FRACTION, _END_CURVATURE_RATIO + _END_SLOPE * (mf - LAW_END_FRACTION), below)


def wrinkled_moment_fraction(curvature_ratio: float | np.ndarray) -> float | np.ndarray:
    """Inverse of :func:`wrinkled_curvature_ratio`: M/M_c for ``kappa/kappa_w >= 1``."""
    k = np.asarray(curvature_ratio, dtype=float)
    below = np.interp(np.minimum(k, _END_CURVATURE_RATIO), _KAPPA_HAT, _M_HAT)
    return np.where(k > _END_CURVATURE_RATIO, LAW_END_FRACTION + (k - _END_CURVATURE_RATIO) / _END_SLOPE, below)


@dataclass(frozen=True)
class InflatedBeamLaw:
    """Pressure law of an inflated thin-walled tube (see module docstring for sources).

    Attributes
    ----------
    membrane_modulus_pa:
        Modulus of the unpressurised membrane ``E_m`` (Pa).
    pressure_stiffening:
        ``kappa_p``, the multiplier of the Le van-Wielgosz pressure term ``p r / (2 t)``.
    reference_radius_m, wall_thickness_m:
        The section the pressure term is evaluated on (the nominal, unbanded tube):
        the paper's ``E_eff(p)`` is a property of the tube, and bands enter only
        through ``alpha(s)`` and the reduced ``A(s)``, ``I(s)``.
    poisson_ratio:
        Used for ``G = E / (2 (1 + nu))`` in the shear stiffness.
    """

    membrane_modulus_pa: float
    pressure_stiffening: float = 1.0
    reference_radius_m: float = 0.020
    wall_thickness_m: float = 0.05e-3
    poisson_ratio: float = 0.5

    @classmethod
    def for_design(cls, design: TubeDesign, params: ModelParams | None = None) -> InflatedBeamLaw:
        """The law of ``design``'s tube: its own modulus and stiffening where it sets them, the
        calibrated values of ``params`` (default: the parameter file) where it does not."""
        p = params or load_params()
        kappa = p.pressure_stiffening if design.pressure_stiffening is None else design.pressure_stiffening
        e_m = p.membrane_modulus_pa if design.membrane_modulus_pa is None else design.membrane_modulus_pa
        return cls(e_m, kappa, design.radius_m, design.wall_thickness_m, p.poisson_ratio)

    def __post_init__(self) -> None:
        _check_positive("membrane_modulus_pa", self.membrane_modulus_pa)
        if not (0.0 <= self.pressure_stiffening <= 10.0):
            raise ValueError(
                f"pressure_stiffening = {self.pressure_stiffening!r} is out of range: allowed [0, 10]"
            )
        _check_positive("reference_radius_m", self.reference_radius_m)
        _check_positive("wall_thickness_m", self.wall_thickness_m)
        if not (0.0 <= self.poisson_ratio <= 0.5):
            raise ValueError(f"poisson_ratio = {self.poisson_ratio!r} is out of range: allowed [0, 0.5]")

    @classmethod
    def anchored(
        cls,
        e_eff_pa: float,
        at_pressure_pa: float,
        radius_m: float,
        wall_thickness_m: float,
        pressure_stiffening: float = 1.0,
        poisson_ratio: float = 0.5,
    ) -> InflatedBeamLaw:
        """The law whose ``E_eff(at_pressure_pa)`` equals ``e_eff_pa`` for this section."""
        e_m = e_eff_pa - pressure_stiffening * at_pressure_pa * radius_m / (2.0 * wall_thickness_m)
        return cls(e_m, pressure_stiffening, radius_m, wall_thickness_m, poisson_ratio)

    def effective_modulus(self, pressure_pa: float) -> float:
        """``E_eff(p)`` in Pa."""
        p = max(float(pressure_pa), 0.0)
        return self.membrane_modulus_pa + self.pressure_stiffening * p * self.reference_radius_m / (
            2.0 * self.wall_thickness_m
        )

    def shear_modulus(self, pressure_pa: float) -> float:
        """``G = E_eff / (2 (1 + nu))`` in Pa."""
        return self.effective_modulus(pressure_pa) / (2.0 * (1.0 + self.poisson_ratio))


def wrinkling_moment(pressure_pa: float, radius_m: float | np.ndarray) -> np.ndarray:
    """Onset of wrinkling ``M_w = p pi r^3 / 2`` (N m) (Comer & Levy 1963)."""
    return 0.5 * max(float(pressure_pa), 0.0) * math.pi * np.asarray(radius_m) ** 3


def collapse_moment(pressure_pa: float, radius_m: float | np.ndarray) -> np.ndarray:
    """Collapse (kink) moment ``M_c = p pi r^3`` (N m) (Stein & Hedgepeth 1961)."""
    return max(float(pressure_pa), 0.0) * math.pi * np.asarray(radius_m) ** 3


def _check_positive(name: str, value: float) -> None:
    check_range(name, value, 0.0, math.inf, lo_open=True, hi_open=True)
