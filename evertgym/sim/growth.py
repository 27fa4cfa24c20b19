"""Pressure regulation and the growth (eversion) law.  SI throughout.

Growth law
----------
Apical extension follows the yield-pressure model of Blumenschein, Okamura & Hawkes
("Modeling of bioinspired apical extension in a soft robot", Living Machines 2017) and
Hawkes et al. (Science Robotics 2017): the tip everts at a rate proportional to the
pressure in excess of what eversion needs,

    v = min(v_max, K_g max(0, p - p_req)).

The pressure on the tip cap must fold new material out, haul the tail and push whatever
blocks the tip:

    p_req A_tip = F_fold + T_tail(tip) + F_tip + w_tail,

* ``F_fold + T_base = p_y(rho_tip) A_tip``: with no bend and nothing ahead the tip needs its
  material's eversion (yield) threshold ``p_y``, about 0.45 kPa for the bare tube; while a
  band passes the tip it rises to the threshold of the local reduction
  (:class:`evertgym.model.eversion.EversionThreshold`, calibrated on the paper's
  eversion-pressure table, Exp 4);
* ``T_tail(tip) = T_base exp(mu_b Theta)``: the tail is hauled from the base through every
  bend the everted body has turned (total turning ``Theta``), and capstan friction on the
  inside of those bends amplifies the base's drag ``T_base`` (Euler-Eytelwein; the loss
  Haggerty, Naclerio & Hawkes, IROS 2019, observed growing with the turning angle;
  Blumenschein et al. 2017).  ``T_base = f_tail p_y(0) pi r^2``, a fraction ``f_tail`` of
  the bare threshold.  The loss acts on the tail only: it does not multiply the wall's
  reaction on the tip (``shared/notes/bend-physics.md``, section 3);
* ``F_tip``: the wall's reaction on the tip along the growth direction (N), never more than
  the weakest section can carry (:mod:`evertgym.model.section_law`);
* ``w_tail``: the weight of the not-yet-everted tail hauled against gravity (only in the
  vertical eversion test; the 2-D scenes lie in a horizontal plane).

So ``p_req = p_y + (T_base (exp(mu_b Theta) - 1) + F_tip) / A_tip + w_tail / A_tip``.
``mu_b`` (the capstan coefficient), ``f_tail``, ``K_g`` (the growth gain, m/s per Pa) and
``v_max`` (the speed the supply's air flow allows) are not constrained by the stiffness or
eversion data: ``mu_b`` and ``f_tail`` are fitted on the paper's no-band U-bend rows
(``scripts/calibrate_navigation.py``).

The pressure follows the command through a first-order regulator lag (time constant
``tau``, the SMC ITV2050's response is of order 0.1-0.2 s); commands are clipped to
[0, 8] kPa, the seal's rupture limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from evertgym.model.eversion import (
    GROWTH_GAIN_M_PER_S_PER_PA,
    MAX_GROWTH_SPEED_M_PER_S,
    EversionThreshold,
)

#: The seal ruptures above this (paper: 8 kPa).
MAX_PRESSURE_PA = 8000.0


class PressureRegulator:
    """First-order lag from the (clipped) command to the pressure in the tube."""

    def __init__(self, tau_s: float = 0.15, initial_pa: float = 0.0):
        if not (math.isfinite(tau_s) and tau_s >= 0):
            raise ValueError(f"tau_s = {tau_s!r} is out of range: allowed [0, inf) s")
        self.tau = tau_s
        self.pressure = float(initial_pa)
        self.command = float(initial_pa)

    def set_command(self, pressure_pa: float) -> float:
        """Set the command (Pa); returns the clipped value. NaN/inf raise ValueError."""
        if not math.isfinite(pressure_pa):
            raise ValueError(f"pressure command = {pressure_pa!r} is not finite: allowed [0, 8000] Pa")
        self.command = min(max(float(pressure_pa), 0.0), MAX_PRESSURE_PA)
        return self.command

    def advance(self, dt: float) -> float:
        if self.tau <= 0:
            self.pressure = self.command
        else:
            self.pressure += (self.command - self.pressure) * (1.0 - math.exp(-dt / self.tau))
        return self.pressure


@dataclass(frozen=True)
class GrowthLaw:
    """``v = min(v_max, K_g max(0, p - p_req))`` (see the module docstring).

    Attributes: ``gain_m_per_s_per_pa`` (K_g), ``bend_loss`` (mu_b, per rad),
    ``max_speed_m_per_s`` (v_max).
    """

    threshold: EversionThreshold
    gain_m_per_s_per_pa: float = GROWTH_GAIN_M_PER_S_PER_PA
    bend_loss: float = 0.08
    max_speed_m_per_s: float = MAX_GROWTH_SPEED_M_PER_S

    def required_pressure(
        self,
        tip_threshold_pa: float,
        tip_force_n: float,
        tip_area_m2: float,
        turning_rad: float,
        tail_pa: float = 0.0,
        base_tail_n: float | None = None,
    ) -> float:
        """``p_req`` (Pa).  With the tail's drag at the base ``base_tail_n`` (the section law):
        the tip's threshold, the tail's capstan loss ``T_base (exp(mu_b Theta) - 1)``, the wall's
        reaction and the tail's weight, per tip area.  Without it (the rigid-column model):
        ``(p_y + F_tip / A + w_tail / A) exp(mu_b Theta)``, the loss multiplying everything."""
        if base_tail_n is None:
            return (tip_threshold_pa + max(tip_force_n, 0.0) / tip_area_m2 + tail_pa) * math.exp(self.bend_loss * turning_rad)
        capstan = base_tail_n * math.expm1(self.bend_loss * turning_rad)
        return tip_threshold_pa + (capstan + max(tip_force_n, 0.0)) / tip_area_m2 + tail_pa

    def speed(self, pressure_pa: float, required_pa: float) -> float:
        return min(self.max_speed_m_per_s, self.gain_m_per_s_per_pa * max(0.0, pressure_pa - required_pa))
