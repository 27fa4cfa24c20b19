"""Pressure regulation and the growth (eversion) law.  SI throughout.

Growth law
----------
Apical extension follows the yield-pressure model of Blumenschein, Okamura & Hawkes
("Modeling of bioinspired apical extension in a soft robot", Living Machines 2017) and
Hawkes et al. (Science Robotics 2017): the tip everts at a rate proportional to the
pressure in excess of what eversion needs,

    v = min(v_max, K_g max(0, p - p_req)),

and the pressure needed grows with the forces resisting the tip and, through capstan
friction of the inner tail sliding over every bend the everted body has already turned
(the loss Haggerty et al., IROS 2019, observed growing with the turning angle), with the
total turning angle ``Theta`` of the body:

    p_req = (p_y(s_tip) + F_tip / A_tip + w_tail / A_tip) exp(mu_b Theta).

* ``p_y(s)``: the eversion (yield) threshold of the material at the tip, about 0.45 kPa
  for the bare tube; while a band passes the tip it rises to the threshold of the local
  reduction, :class:`evertgym.model.eversion.EversionThreshold`, calibrated on the
  paper's eversion-pressure table (Exp 4).
* ``F_tip``: the wall's reaction on the tip along the growth direction (N).
* ``w_tail``: the weight of the not-yet-everted tail hauled against gravity (only in the
  vertical eversion test; the 2-D scenes lie in a horizontal plane).
* ``mu_b``: the bend-loss (capstan) coefficient; ``K_g``: the growth gain (m/s per Pa);
  ``v_max``: the speed the supply's air flow allows.  None of them is constrained by the
  paper's calibration data; all are exposed.

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
        self, tip_reduction_threshold_pa: float, tip_force_n: float, tip_area_m2: float, turning_rad: float, tail_pa: float = 0.0
    ) -> float:
        return (tip_reduction_threshold_pa + max(tip_force_n, 0.0) / tip_area_m2 + tail_pa) * math.exp(
            self.bend_loss * turning_rad
        )

    def speed(self, pressure_pa: float, required_pa: float) -> float:
        return min(self.max_speed_m_per_s, self.gain_m_per_s_per_pa * max(0.0, pressure_pa - required_pa))
