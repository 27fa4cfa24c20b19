"""What both engines share: a growing tube's material, its growth law and regulator, its events.

:class:`GrowingTube` holds the parts of :class:`~evertgym.sim.simulator.EversionSim` (the dynamic
pymunk chain) and :class:`~evertgym.sim.quasistatic.QuasiStaticSim` that do not depend on how the
body is put in equilibrium: the tabulated material along the body, the eversion threshold at the
tip, the growth law and the pressure regulator, stall detection and the event log.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np

from evertgym.design import TubeDesign
from evertgym.limits import MAX_EVENTS
from evertgym.model.eversion import EversionThreshold, VariedThreshold
from evertgym.model.params import ModelParams
from evertgym.model.pressure import InflatedBeamLaw
from evertgym.sim.config import _STEP_OVERHEAD_PASSES, MAX_DYNAMIC_WORK_PER_S, SimConfig, check_buildable, dynamic_work_per_s
from evertgym.sim.events import SimEvent
from evertgym.sim.growth import GrowthLaw, PressureRegulator
from evertgym.sim.material import material_tables

# (check_buildable and the dynamic engine's work bound are the settings' checks, in evertgym.sim.config)
__all__ = ["MAX_DYNAMIC_WORK_PER_S", "GrowingTube", "check_buildable", "dynamic_work_per_s", "relax_step_budget"]


class GrowingTube:
    """The engine-independent state of a growing tube (set up by :meth:`_init_tube`)."""

    design: TubeDesign
    cfg: SimConfig
    params: ModelParams
    length: float
    t: float
    events: list[SimEvent]
    event_counts: dict[str, int]
    stall_count: int
    _stall_clock: float
    _stalled: bool
    _step_mean_pressure: float
    _step_max_contact: float
    _in_contact: bool
    #: advance the clock by ``n_steps`` steps of ``cfg.dt_s`` (each engine steps its own way)
    step: Callable[[int], None]

    def _place_base(self, scene, base: tuple[float, float] | None, direction: tuple[float, float] | None) -> None:
        """The base pin (m) and the initial growth direction: given, or the scene's entry."""
        if base is None:
            base = tuple(getattr(scene, "entry", (0.0, 0.0)))
        if direction is None:
            direction = tuple(getattr(scene, "entry_direction", (1.0, 0.0)))
        d = np.asarray(direction, dtype=float)
        self.base = np.asarray(base, dtype=float)
        self.base_angle = math.atan2(d[1], d[0])

    def _init_tube(self, design: TubeDesign, cfg: SimConfig, threshold: EversionThreshold | None, vertical_tail: bool) -> None:
        """Material tables over all nodes of the body (joint ``j`` at ``s_j = j ds``), the threshold
        law, the growth law and the regulator."""
        ds = cfg.segment_length_m
        self.ds = ds
        tables = material_tables(design, ds, self.params)
        self.nodes = tables.nodes
        self._node_list = tables.nodes.tolist()
        self._ref_section = tables.section
        self._e_ref = self._ref_section.e_eff_pa
        self._c_ref = tables.c_ref
        self._cs_ref = tables.cs_ref
        self._r_cell = tables.r_cell
        self._r3 = tables.r_cell**3
        self._law = InflatedBeamLaw.for_design(design)
        self._radius_fine = (tables.radius_s, tables.radius_r)
        # where the tip's material changes radius (m), and where each band starts (m)
        self._band_zones = [(z.start_m - 2 * ds, z.end_m + 2 * ds) for z in self._ref_section.zones]
        self._band_starts = [(i, b.position_m - b.width_m / 2, b.reduction) for i, b in enumerate(design.bands)]
        self.threshold = threshold or VariedThreshold.of_robot(cfg.threshold_z)
        self._bare_threshold = (float(self.threshold(0.0)), math.pi * design.radius_m * design.radius_m)
        self.growth = GrowthLaw(self.threshold, cfg.growth_gain_m_per_s_per_pa, cfg.bend_loss_per_rad, cfg.max_growth_speed_m_per_s)
        self.regulator = PressureRegulator(cfg.regulator_tau_s)
        self.vertical_tail = vertical_tail

    def _radius_between(self, a: float, b: float) -> float:
        """Collision radius of material [a, b]: its envelope (largest radius), so no part of
        the tube can sink into a wall; a segment wholly inside a band strip gets the band's."""
        s, r = self._radius_fine  # s increasing: the material in [a, b] is one run of it
        top = _envelope(s, r, a, b)
        return top if top >= 0.0 else float(np.interp(0.5 * (a + b), s, r))

    def _near_band(self, s: float) -> bool:
        return any(lo <= s <= hi for lo, hi in self._band_zones)

    def _tip_threshold(self) -> tuple[float, float]:
        """Eversion threshold (Pa) of the material at the tip, and the tip area (m^2)."""
        s_tip = self.length
        rho = 0.0
        for z in self._ref_section.zones:
            if z.start_m <= s_tip <= z.end_m:
                rho = max(rho, z.reduction * float(z.shape(s_tip)))
        if rho == 0.0:  # bare material: the same every step
            return self._bare_threshold
        r_tip = self.design.radius_m * (1 - rho)
        return float(self.threshold(rho)), math.pi * r_tip * r_tip

    def _stall_update(self, v: float, dt: float) -> None:
        if v < self.cfg.stall_speed_m_per_s and self.length < self.design.length_m:
            self._stall_clock += dt
            if self._stall_clock >= self.cfg.stall_time_s and not self._stalled:
                self._stalled = True
                self.stall_count += 1
                self._event("stall", pressure_kpa=round(self.pressure / 1e3, 4))
        else:
            self._stall_clock = 0.0
            self._stalled = False

    @property
    def stalled(self) -> bool:
        return self._stalled

    def _event(self, kind: str, **detail) -> None:
        self.event_counts[kind] = self.event_counts.get(kind, 0) + 1
        if len(self.events) < MAX_EVENTS:  # bounded: a long cycling run keeps its memory flat
            self.events.append(SimEvent(round(self.t, 6), kind, round(self.length * 1e3, 3), detail))

    def set_pressure_command(self, pressure_pa: float) -> float:
        """Command the regulator (Pa, clipped to [0, 8 kPa]); returns the clipped command."""
        return self.regulator.set_command(pressure_pa)

    @property
    def pressure(self) -> float:
        return self.regulator.pressure

    def run(self, duration_s: float) -> None:
        """Advance by ``duration_s`` seconds."""
        self.step(int(round(duration_s / self.cfg.dt_s)))

    # ---- geometry out -----------------------------------------------------------

    @property
    def step_mean_pressure(self) -> float:
        """Mean regulated pressure (Pa) over the steps of the last :meth:`step` call."""
        return self._step_mean_pressure

    @property
    def step_max_contact_force(self) -> float:
        """Largest tip contact force magnitude ``|tip_contact|`` (N) over the steps of the last
        :meth:`step` call (the last value held while the rest lock holds)."""
        return self._step_max_contact

    @property
    def in_contact(self) -> bool:
        """Whether the tip segment touched a wall in the last step."""
        return self._in_contact


#: Relaxation work (segment passes) one dynamic step call may spend beyond :data:`MAX_DYNAMIC_WORK_PER_S` over its
#: simulated time: a single 2 ms step of a 0.9 m body may relax for about 900 steps.
_RELAX_WORK_MIN = 1e7


def relax_step_budget(design: TubeDesign, cfg: SimConfig, n_steps: int) -> float:
    """Relaxation steps a dynamic ``step(n_steps)`` call may take: :data:`MAX_DYNAMIC_WORK_PER_S` over the
    call's simulated time plus :data:`_RELAX_WORK_MIN`, in steps of this body (far above what the defaults
    take: 50 per growth step at most)."""
    per_step = (cfg.iterations + _STEP_OVERHEAD_PASSES) * design.length_m / cfg.segment_length_m
    return (MAX_DYNAMIC_WORK_PER_S * n_steps * cfg.dt_s + _RELAX_WORK_MIN) / per_step


@nb.njit(cache=True, nogil=True)
def _envelope(s: np.ndarray, r: np.ndarray, a: float, b: float) -> float:
    """Largest radius ``r`` (m) over the fine samples ``s`` (m, increasing) in ``[a, b]`` (1e-12 m of slack at each
    end), or -1 when none lies there (compiled: it runs at every growth increment)."""
    i0 = np.searchsorted(s, a - 1e-12, side="left")
    i1 = np.searchsorted(s, b + 1e-12, side="right")
    if i1 <= i0:
        return -1.0
    return r[i0:i1].max()
