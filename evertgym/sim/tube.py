"""The engine interface: :class:`EversionSim`, the growing tube both engines implement.

:class:`EversionSim` is the abstract base of the two engines, :class:`~evertgym.sim.quasistatic.QuasiStaticSim`
(the default: the body in static equilibrium at every growth increment) and
:class:`~evertgym.sim.simulator.DynamicSim` (the pymunk chain).  ``EversionSim(design, scene, config)``
builds the engine ``config.engine`` names; either is an ``EversionSim``.  This class holds what does not
depend on how the body is put in equilibrium, written once: the construction (settings, scene, base pin),
the tabulated material along the body, the eversion threshold at the tip, the growth law and the pressure
regulator, the shared state, the events (stall, contact, band at tip, kink, :meth:`_event`) and the tail's
weight; and it declares, abstract, what each engine computes its own way.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numba as nb
import numpy as np

from evertgym.design import TubeDesign
from evertgym.limits import MAX_EVENTS
from evertgym.model.eversion import EversionThreshold, VariedThreshold, tail_weight_pressure
from evertgym.model.params import ModelParams, load_params
from evertgym.model.pressure import KINK_MOMENT_FRACTION, InflatedBeamLaw
from evertgym.sim.config import _STEP_OVERHEAD_PASSES, MAX_DYNAMIC_WORK_PER_S, SimConfig, check_buildable, dynamic_work_per_s
from evertgym.sim.events import SimEvent
from evertgym.sim.growth import GrowthLaw, PressureRegulator
from evertgym.sim.material import material_tables

# (check_buildable and the dynamic engine's work bound are the settings' checks, in evertgym.sim.config)
__all__ = ["ENGINE_CLASSES", "MAX_DYNAMIC_WORK_PER_S", "EversionSim", "check_buildable", "dynamic_work_per_s", "engine_class",
           "relax_step_budget"]

#: The class of each engine by its name (``SimConfig.engine``): an engine class enters when it is defined
#: (:meth:`EversionSim.__init_subclass__`); the package's ``__init__`` imports both engines' modules.
ENGINE_CLASSES: dict[str, type[EversionSim]] = {}


def engine_class(engine: str) -> type[EversionSim]:
    """The class of engine ``engine`` (``"quasistatic"``: :class:`~evertgym.sim.quasistatic.QuasiStaticSim`;
    ``"dynamic"``: :class:`~evertgym.sim.simulator.DynamicSim`)."""
    if engine not in ENGINE_CLASSES:
        raise ValueError(f"engine = {engine!r} is out of range: allowed {' or '.join(repr(e) for e in ENGINE_CLASSES)}")
    return ENGINE_CLASSES[engine]


class EversionSim:
    """A growing eversion robot in a scene: the interface both engines implement.

    Parameters
    ----------
    design: the tube and its bands.
    scene: anything with ``build(space, ...)`` (an :mod:`evertgym.scenes` scene) or None for open space.
        When given and ``base`` is None, the robot starts at ``scene.entry`` along ``scene.entry_direction``.
    config: settings (:class:`~evertgym.sim.config.SimConfig`); ``config.engine`` picks the engine.
    base, direction: the base pin (m) and the initial growth direction.
    vertical_tail: add the weight of the hauled tail (vertical eversion test).
    threshold: eversion threshold law (the paper-calibrated one, varied by ``config.threshold_z``, by default).
    params: the rod model's parameters (the calibrated ones by default).

    ``EversionSim(...)`` builds the engine ``config.engine`` names (:data:`ENGINE_CLASSES`); an engine's own
    class may be built directly, with a config of its engine (or None: its defaults).

    Out: ``length`` (m, everted), ``t`` (s), ``pressure`` (Pa), ``growth_speed`` (m/s), ``tip_force`` (N, the
    wall's reaction against growth), ``tip_contact`` (N, the wall's force on the tip), ``max_contact_force``,
    ``peak_pressure``, ``events`` and ``event_counts``, ``stall_count``, ``active_start`` (the first joint
    that moves), and the geometry methods below.
    """

    #: the engine's name, ``SimConfig.engine``
    engine: ClassVar[str]
    #: What each engine computes its own way (declared below, raising NotImplementedError): an engine class
    #: that does not define every one of them is refused when it is defined (:meth:`__init_subclass__`).
    INTERFACE: ClassVar[tuple[str, ...]] = (
        "_build_scene", "_build_body", "step", "required_pressure", "centreline", "radii", "tip_position", "tip_angle",
        "joint_angles", "joint_moments", "collapse_moments", "segments_in_contact", "wall_tension", "compression_capacity",
        "tip_capacity", "solve_stats", "at_rest")

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        missing = [name for name in cls.INTERFACE if getattr(cls, name) is getattr(EversionSim, name)]
        if missing or not isinstance(getattr(cls, "engine", None), str):
            raise TypeError(f"{cls.__name__} is not an engine: it must set engine and define {', '.join(missing) or 'them'}")
        ENGINE_CLASSES[cls.engine] = cls

    def __new__(cls, *args, **kwargs):
        if cls is EversionSim:  # dispatch on the config's engine
            config = kwargs["config"] if "config" in kwargs else (args[2] if len(args) > 2 else None)
            cls = engine_class((config or SimConfig()).engine)
        return super().__new__(cls)

    def __init__(
        self,
        design: TubeDesign,
        scene=None,
        config: SimConfig | None = None,
        base: tuple[float, float] | None = None,
        direction: tuple[float, float] | None = None,
        vertical_tail: bool = False,
        threshold: EversionThreshold | None = None,
        params: ModelParams | None = None,
    ):
        self.design = design
        self.cfg = cfg = config or SimConfig(engine=self.engine)
        if cfg.engine != self.engine:
            raise ValueError(f"engine = {cfg.engine!r} is out of range for {type(self).__name__}: allowed {self.engine!r} "
                             "(or build EversionSim(...), which picks the engine the config names)")
        check_buildable(design, cfg, scene)
        self.params = params or load_params()
        self.scene = scene
        self.scene_handles = self._build_scene(scene)
        self._place_base(scene, base, direction)
        self._init_tube(design, cfg, threshold, vertical_tail)
        self._init_state()
        self._build_body()

    def _build_scene(self, scene):
        """Make ``self.space`` and build ``scene`` (if any) into it; return the scene's handles (or None)."""
        raise NotImplementedError

    def _build_body(self) -> None:
        """The engine's own state and the initial body (``cfg.initial_length_m``), put at rest."""
        raise NotImplementedError

    def _init_state(self) -> None:
        """The state both engines keep, at the start."""
        self.t = 0.0
        self.steps = 0
        self.length = 0.0
        #: the first MAX_EVENTS events; later ones are only counted in ``event_counts``
        self.events: list[SimEvent] = []
        self.event_counts: dict[str, int] = {}
        self._kinked: set[int] = set()
        self._bands_reached: set[int] = set()
        self._in_contact = False
        self._stall_clock = 0.0
        self._stalled = False
        self.stall_count = 0
        self.growth_speed = 0.0
        self.tip_force = 0.0
        self.tip_contact = np.zeros(2)
        self._tip_force_norm = 0.0  # |tip_contact| (N)
        self.max_contact_force = 0.0
        self.peak_pressure = 0.0
        self._step_mean_pressure = 0.0
        self._step_max_contact = 0.0
        self._p_applied = -1.0  # the pressure (Pa) the joints were last set to (-1: none yet)
        self.active_start = 0  # the first joint (segment) that moves

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
        """Stall detection: no growth faster than ``stall_speed_m_per_s`` for ``stall_time_s`` (a ``stall`` event)."""
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

    def _contact_update(self, force_n: float, touching: bool) -> None:
        """The tip's wall force ``|tip_contact|`` (N) and whether it touches a wall now: the largest force so far,
        and a ``contact`` event when the tip comes to touch."""
        self._tip_force_norm = force_n
        self.max_contact_force = max(self.max_contact_force, force_n)
        if touching and not self._in_contact:
            self._event("contact", force_n=round(force_n, 6))
        self._in_contact = touching

    def _band_events(self) -> None:
        """A ``band_at_tip`` event for each band whose start the tip (``length``) has reached, once per band."""
        for i, start, reduction in self._band_starts:
            if self.length >= start and i not in self._bands_reached:
                self._bands_reached.add(i)
                self._event("band_at_tip", band=i, reduction=reduction)

    def _kink_events(self, kinked, moments: np.ndarray, collapse: np.ndarray, first: int = 0) -> None:
        """A ``kink`` event for each joint of ``kinked`` (indices) not kinked before; then a kinked joint that unloads
        below 0.8 of the kink fraction of its collapse moment is no longer kinked.  ``moments`` and ``collapse``
        (N m) are those of joints ``first..``; a joint before ``first`` (held, not updated) stays kinked."""
        for j in kinked:
            if j not in self._kinked:
                self._kinked.add(int(j))
                self._event("kink", joint_mm=round(float(self.nodes[j]) * 1e3, 3), at_band=bool(self._r3[j] < 0.999 * self.design.radius_m**3))
        if self._kinked:
            self._kinked = {j for j in self._kinked if j < first or abs(moments[j - first]) >= 0.8 * KINK_MOMENT_FRACTION * collapse[j - first]}

    def _tail_weight(self) -> float:
        """The hauled tail's weight as a pressure (Pa) with ``vertical_tail``, else 0."""
        if not self.vertical_tail:
            return 0.0
        return tail_weight_pressure(self.design.diameter_m, self.design.wall_thickness_m, self.length)

    @property
    def kinked_joints(self) -> list[int]:
        """Joints past the kink fraction of their collapse moment, base first."""
        return sorted(self._kinked)

    @property
    def tip_direction(self) -> np.ndarray:
        """Unit vector along the tip segment."""
        a = self.tip_angle
        return np.array([math.cos(a), math.sin(a)])

    # ---- what each engine computes its own way ---------------------------------------
    def step(self, n_steps: int = 1) -> None:
        """Advance the clock by ``n_steps`` steps of ``cfg.dt_s``; :attr:`step_mean_pressure` and
        :attr:`step_max_contact_force` summarise them."""
        raise NotImplementedError

    def required_pressure(self) -> float:
        """Pressure (Pa) the tip needs to grow now; below it the robot stalls."""
        raise NotImplementedError

    def centreline(self) -> np.ndarray:
        """Node positions from the base to the tip (m), (n+1) x 2."""
        raise NotImplementedError

    def radii(self) -> np.ndarray:
        """Collision radius of each segment (m)."""
        raise NotImplementedError

    @property
    def tip_position(self) -> np.ndarray:
        """The tip (m)."""
        raise NotImplementedError

    @property
    def tip_angle(self) -> float:
        """Heading of the tip segment (rad)."""
        raise NotImplementedError

    def joint_angles(self, start: int = 0) -> np.ndarray:
        """Relative rotation of joints ``start..`` (rad); joint 0 is measured against the clamp."""
        raise NotImplementedError

    def joint_moments(self, start: int = 0) -> np.ndarray:
        """Joint moments (N m) of joints ``start..`` from the joint law at the current angles."""
        raise NotImplementedError

    def collapse_moments(self, start: int = 0) -> np.ndarray:
        """Collapse (kink) moment ``M_c`` (N m) of joints ``start..`` at the applied pressure."""
        raise NotImplementedError

    def segments_in_contact(self) -> list[int]:
        """Segments that touch a wall now."""
        raise NotImplementedError

    @property
    def wall_tension(self) -> np.ndarray:
        """``T_wall`` (N) of the joints from ``active_start``."""
        raise NotImplementedError

    @property
    def compression_capacity(self) -> np.ndarray:
        """The compression (N) each joint from ``active_start`` carries before it folds axially."""
        raise NotImplementedError

    @property
    def tip_capacity(self) -> float:
        """The most the wall may push on the tip (N)."""
        raise NotImplementedError

    @property
    def solve_stats(self) -> dict:
        """The engine's counts of its equilibrium solves (reported in ``info`` and trial records)."""
        raise NotImplementedError

    @property
    def at_rest(self) -> bool:
        """Whether the body is in static equilibrium now."""
        raise NotImplementedError

    # ---- pressure, clock ---------------------------------------------------------------
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
