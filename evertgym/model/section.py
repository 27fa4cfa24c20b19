"""Cross-section properties along a banded tube: A(s), I(s), alpha(s), E(p, s).

A band of reduction ``rho`` narrows the radius to ``r (1 - rho)`` over its strip and
tapers linearly back to ``r`` over a transition on either side (the taper length is a
calibrated parameter, see :mod:`evertgym.model.params`).  Inside the band zone the
modulus is ``E(p, s) = alpha(s) E_eff(p)`` with ``alpha`` blending from 1 to
``alpha(rho)`` along the taper, the paper's equation (2).  The section is a thin-walled
circle: ``A = 2 pi r t``, ``I = pi r^3 t``.

Coordinates: ``s`` is measured along the body from the base (m), the design's frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from evertgym.design import TubeDesign
from evertgym.model.params import ModelParams, load_params
from evertgym.model.pressure import InflatedBeamLaw, collapse_moment, wrinkling_moment


def alpha_of_reduction(rho: float | np.ndarray, params: ModelParams | None = None) -> float | np.ndarray:
    """``alpha(rho)``: 1 at rho = 0, the calibrated table in between (linear), linear
    extrapolation past the last tabulated reduction, never below 0.05."""
    p = params or load_params()
    xs = np.array((0.0,) + p.alpha_reductions)
    ys = np.array((1.0,) + p.alpha_values)
    rho = np.asarray(rho, dtype=float)
    out = np.interp(rho, xs, ys)
    slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
    out = np.where(rho > xs[-1], ys[-1] + slope * (rho - xs[-1]), out)
    return np.maximum(out, 0.05)


def taper_length(rho: float, params: ModelParams | None = None) -> float:
    """Length (m) of the radius transition on each side of a band strip."""
    p = params or load_params()
    if rho <= 0:
        return 0.0
    return p.band_transition_m * (rho / 0.5) ** p.band_transition_exponent


@dataclass(frozen=True)
class BandZone:
    """One band's footprint: strip ``[centre - half_strip, centre + half_strip]`` plus tapers."""

    centre_m: float
    half_strip_m: float
    taper_m: float
    reduction: float
    alpha: float

    @property
    def start_m(self) -> float:
        return self.centre_m - self.half_strip_m - self.taper_m

    @property
    def end_m(self) -> float:
        return self.centre_m + self.half_strip_m + self.taper_m

    def shape(self, s: float | np.ndarray) -> np.ndarray:
        """1 on the strip, falling linearly to 0 across the taper, 0 outside."""
        d = np.abs(np.asarray(s, dtype=float) - self.centre_m) - self.half_strip_m
        if self.taper_m <= 0:
            return (d <= 0).astype(float)
        return np.clip(1.0 - d / self.taper_m, 0.0, 1.0)


class TubeSection:
    """Section properties of a design at one pressure, as functions of ``s`` (m from base).

    Parameters
    ----------
    design: the tube and its bands.
    pressure_pa: internal pressure (Pa).
    params: calibrated parameters (the packaged file by default).
    """

    def __init__(self, design: TubeDesign, pressure_pa: float, params: ModelParams | None = None):
        if not (math.isfinite(pressure_pa) and pressure_pa >= 0):
            raise ValueError(f"pressure_pa = {pressure_pa!r} is out of range: allowed [0, inf)")
        self.design = design
        self.params = params or load_params()
        self.pressure_pa = float(pressure_pa)
        law = InflatedBeamLaw.for_design(design)
        self.e_eff_pa = law.effective_modulus(pressure_pa)
        self.g_eff_pa = law.shear_modulus(pressure_pa)
        self.r0 = design.radius_m
        self.t = design.wall_thickness_m
        self.zones = tuple(
            BandZone(
                b.position_m,
                b.width_m / 2,
                taper_length(b.reduction, self.params),
                b.reduction,
                float(alpha_of_reduction(b.reduction, self.params)),
            )
            for b in design.bands
            if b.reduction > 0
        )

    @property
    def bare_bending_stiffness(self) -> float:
        """``E_eff I`` of the unbanded tube (N m^2)."""
        return self.e_eff_pa * math.pi * self.r0**3 * self.t

    def breakpoints(self) -> list[float]:
        """Every ``s`` where a property has a kink (band zone and strip edges)."""
        pts: list[float] = []
        for z in self.zones:
            pts += [z.start_m, z.centre_m - z.half_strip_m, z.centre_m + z.half_strip_m, z.end_m]
        return sorted(pts)

    def _zone_table(self) -> tuple[Any, ...]:
        """Zones sorted by start as arrays, and the most zones any point can lie in (``depth``)."""
        if not hasattr(self, "_table"):
            zs = sorted(self.zones, key=lambda z: z.start_m)
            start = np.array([z.start_m for z in zs])
            end = np.array([z.end_m for z in zs])
            # zones k-depth+1..k are the only ones that can cover a point in zone k's footprint
            depth = int(np.max(np.arange(len(zs)) - np.searchsorted(np.maximum.accumulate(end), start, "right") + 1)) if zs else 0
            cols = [np.array([getattr(z, f) for z in zs]) for f in ("centre_m", "half_strip_m", "taper_m", "reduction", "alpha")]
            self._table = (start, *cols, depth)
        return self._table

    def _reduction_and_alpha(self, s: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = np.asarray(s, dtype=float)
        rho = np.zeros_like(s)
        alpha = np.ones_like(s)
        if not self.zones:
            return rho, alpha
        start, centre, half, taper, red, alf, depth = self._zone_table()
        last = np.searchsorted(start, s, side="right") - 1  # the last zone starting at or before s
        for k in range(depth):  # vectorised over s: cost O(len(s) x depth), not O(len(s) x bands)
            i = last - k
            ok = i >= 0
            j = np.where(ok, i, 0)
            d = np.abs(s - centre[j]) - half[j]
            safe = np.where(taper[j] > 0, taper[j], 1.0)
            w = np.where(taper[j] > 0, np.clip(1.0 - d / safe, 0.0, 1.0), (d <= 0).astype(float)) * ok
            rho = np.maximum(rho, red[j] * w)
            alpha = np.minimum(alpha, 1.0 - (1.0 - alf[j]) * w)
        return rho, alpha

    def radius(self, s: float | np.ndarray) -> np.ndarray:
        """Local radius (m)."""
        rho, _ = self._reduction_and_alpha(s)
        return self.r0 * (1.0 - rho)

    def bending_stiffness(self, s: float | np.ndarray) -> np.ndarray:
        """``E(p, s) I(s) = alpha(s) E_eff(p) pi r(s)^3 t`` (N m^2)."""
        rho, alpha = self._reduction_and_alpha(s)
        r = self.r0 * (1.0 - rho)
        return alpha * self.e_eff_pa * math.pi * r**3 * self.t

    def axial_stiffness(self, s: float | np.ndarray) -> np.ndarray:
        """``E(p, s) A(s)`` (N)."""
        rho, alpha = self._reduction_and_alpha(s)
        return alpha * self.e_eff_pa * 2 * math.pi * self.r0 * (1.0 - rho) * self.t

    def shear_stiffness(self, s: float | np.ndarray) -> np.ndarray:
        """``G(p, s) A(s)`` (N)."""
        return self.axial_stiffness(s) * (self.g_eff_pa / self.e_eff_pa)

    def wrinkling_moment(self, s: float | np.ndarray) -> np.ndarray:
        """``M_w = p pi r(s)^3 / 2`` (N m)."""
        return wrinkling_moment(self.pressure_pa, self.radius(s))

    def collapse_moment(self, s: float | np.ndarray) -> np.ndarray:
        """``M_c = p pi r(s)^3`` (N m)."""
        return collapse_moment(self.pressure_pa, self.radius(s))
