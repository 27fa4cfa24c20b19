"""Fidelity and physics settings of the simulator (SI), validated at construction."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from numbers import Integral

from evertgym._validate import check_range as _check
from evertgym.model.eversion import GROWTH_GAIN_M_PER_S_PER_PA, MAX_GROWTH_SPEED_M_PER_S
from evertgym.sim.variation import bend_model

#: the adopted bend model's switches (evertgym/data/bend_model.json): the defaults of the band-mechanism laws
_MODEL = bend_model()["switches"]

#: the finest pymunk step accepted (s): 200x finer than the default 2 ms; below it one
#: simulated second costs over 100,000 substeps (tens of seconds of wall time), and an
#: accidental 1e-9 would never finish
MIN_DT_S = 1e-5
#: the smallest ``solver_tolerance`` accepted: the quasi-static solver's residuals stall near 1e-6 of
#: ``p pi r^2`` (double precision; docs/robustness.md), so below 1e-5 solves end unconverged, not finer
MIN_SOLVER_TOLERANCE = 1e-5


@dataclass(frozen=True)
class SimConfig:
    """Simulator settings.

    Fidelity (the quasi-static regime)
        ``segment_length_m``: rigid segment length ds.  ``dt_s``: pymunk step.
        ``damping``: ``space.damping`` (velocity fraction kept after 1 s); spring
        stiffnesses are divided by ``damping ** dt`` so that the damping, which
        Chipmunk applies to the spring impulses too, does not bias the equilibrium.
        ``inertia_factor``: segment rotational inertia ``I = f k dt^2`` for the stiffest
        adjacent joint ``k`` (f = 3 puts its local mode near 1.2 rad per step; 2 is the
        edge of stability of the explicit spring);
        ``mass_ratio``: translational mass as a fraction of a uniform bar's ``12 I /
        ds^2`` (small: the chain then relaxes in O(N) rather than O(N^2) steps).  Masses
        are scaled, not physical: only static answers are meaningful, and tests check
        they do not depend on these settings.  ``iterations``: constraint solver passes.
        ``law_interval``: steps between updates of the non-linear joint law.
    Active set
        Segments more than ``active_length_m`` behind the tip whose mean speed over each
        50-step check stayed below ``freeze_speed_m_per_s`` for ``freeze_time_s`` become
        static (leave the active set).  With ``dormant_walls`` (opt-in), compliant wall
        pieces farther than ``wall_wake_margin_m`` from every active segment's surface and at
        rest sleep (static, out of the solver) until one comes near (:mod:`evertgym.sim.dormant`).
    Physics
        ``wall_friction``: Coulomb coefficient between the everted body and a wall: the
        everted body is laid down and does not slide along the walls, so it is high.
        ``tip_friction``: the same for the everting tip segment, whose fold rolls over a
        wall as it everts and slides easily.  ``regulator_tau_s``: pressure
        lag.  ``growth_gain_m_per_s_per_pa``, ``bend_loss_per_rad`` (the tail's capstan
        coefficient), ``tail_drag_fraction`` (the share of the bare eversion threshold that is
        the tail's drag at the base), ``max_growth_speed_m_per_s``: the growth law
        (:mod:`evertgym.sim.growth`) and the tail tension of the section law.
    Rest lock
        A stalled robot whose every dynamic body (segments and compliant wall pieces)
        moves slower than ``rest_speed_m_per_s`` is in static equilibrium: it is held there,
        without stepping the solver, until the regulated pressure moves by more than
        ``rest_pressure_tol_pa`` (Coulomb friction sticks; Chipmunk's iterative solver only
        approximates sticking and lets a loaded chain creep, then kick).  0 disables it.
    Axial-load model
        ``section_law``: False (default) is the rigid-column model; True the section law
        (:mod:`evertgym.model.section_law`, :mod:`evertgym.sim.simulator`), under which
        ``tail_drag_fraction``, the force window and the quasi-static relaxation below apply.
    Quasi-static growth (section law)
        After each growth increment the chain is stepped, without advancing time, until its
        active segments move slower than ``relax_speed_m_per_s`` (at most ``max_relax_steps``
        steps; 0 m/s disables it); with ``relax_force_n`` > 0 the criterion is instead the
        unbalanced force the motion implies (``m g |v|``, ``I g |w| / ds``).  Neither yet makes
        outcomes independent of the scaled masses (docs/sim.md) (:meth:`EversionSim._relax`).
    Contact forces (section law)
        ``force_window_s``: the tip's wall force is its impulse over this window divided by
        the window (a quasi-static force, the same for any step; :meth:`EversionSim._tip_reaction`).
    Events
        ``stall_time_s``: a stall is no growth faster than ``stall_speed_m_per_s`` for this long.
    Engine
        ``engine``: ``"quasistatic"`` (:mod:`evertgym.sim.quasistatic`: the body in static
        equilibrium after every growth increment and pressure change, no mass, inertia or
        damping; the clock ``dt_s`` advances the regulator and the growth law only) or
        ``"dynamic"`` (the pymunk chain of :mod:`evertgym.sim.simulator`, bit for bit as before).
        The quasi-static engine's numerical settings: ``growth_increment_m`` (the largest growth
        between two equilibria near a wall; up to a segment in free space), ``solver_tolerance``
        (the largest unbalanced moment and force over ``p pi r^3`` and ``p pi r^2``, ``p`` at
        least 1 kPa), ``barrier_gap_m`` (IPC's d_hat: the contact barrier acts below this gap),
        ``friction_slip_fraction`` (IPC's eps_v h: a contact slides once its tangential travel in a solve
        exceeds this fraction of the solve's growth, of ``growth_increment_m`` for a solve without growth;
        below it static friction lets it creep, so the creep per metre of growth, not per increment, is
        fixed, and halving the increment does not add creep), ``friction_slip_m`` (optional: a fixed travel
        per solve instead, in m, which makes the creep grow as the increment shrinks), ``friction_lag_iterations`` (re-solves with the normal forces updated),
        ``max_newton_iterations`` and ``pressure_increment_fraction`` (the pressure change, as a
        fraction of the last solve's pressure and at least of 1 kPa, after which the body is
        re-solved while it touches a wall or is growing), ``linear_solver`` (how a Newton step's linear
        system is solved: ``"semiseparable"``, the default since 2026-12-05, in O(m + pieces), the
        joints' Hessian being diagonal plus semiseparable of rank 3 in joint coordinates and the
        compliant wall pieces eliminated into it; or ``"dense"``, the default before, a Cholesky
        factorisation of the joints' Hessian and a dense Schur complement for the pieces, O(m^3); the
        two agree to rounding, not bit for bit: a number made before the switch is regenerated
        exactly with ``"dense"``).  A field that means nothing to the chosen engine is rejected.
    Band-mechanism laws (quasi-static engine; :mod:`evertgym.sim.band_laws`)
        ``band_fold``: an everted band folds axially (goes slack) when the tip's push and the tail's
        tension exceed ``p pi r_b^2``; growth then stops.  ``fold_pinch_per_rad``: the tail's losses
        grow by ``exp(mu_p Phi)`` with the body's excess fold angle ``Phi``.
        ``band_eversion_threshold``: False removes the calibrated threshold of a band at the tip (a
        counterfactual of the study).  ``flattening``: the bare tube's largest cross-section flattening
        past wrinkling (a fraction of the radius; a band adds its reduction): the collision radius and
        the collapse moment shrink with it.  ``axial_load``: the wall's moment capacity at a section falls
        with the axial load it carries, the tip's push and the tail's tension against ``p pi r(s)^2``
        (first at bands).  ``band_hinge_relief`` and ``band_hinge_reach_m``: the phenomenological band
        law, the tip's friction coefficient lowered by this fraction while a wrinkled band lies within
        this reach behind the tip.  Their defaults are the adopted bend model's
        (``evertgym/data/bend_model.json``, :mod:`evertgym.experiments.bend_model`).
    Robot-to-robot variation (one fabricated robot; :mod:`evertgym.sim.variation`)
        ``stiffness_factor`` multiplies the joints' bending stiffness; ``threshold_z`` is the robot's
        standard-normal draw of its eversion threshold (Exp 4's coefficient of variation at the local
        reduction).  1 and 0 by default: the median robot.
    """

    segment_length_m: float = 0.0075
    dt_s: float = 0.002
    damping: float = 1e-6
    inertia_factor: float = 3.0
    mass_ratio: float = 0.01
    iterations: int = 10
    law_interval: int = 5
    active_length_m: float = 0.2
    freeze_speed_m_per_s: float = 5e-3
    freeze_time_s: float = 0.3
    wall_friction: float = 1.0
    tip_friction: float = 0.2
    regulator_tau_s: float = 0.15
    growth_gain_m_per_s_per_pa: float = GROWTH_GAIN_M_PER_S_PER_PA
    bend_loss_per_rad: float = 0.08
    tail_drag_fraction: float = 1.0
    max_growth_speed_m_per_s: float = MAX_GROWTH_SPEED_M_PER_S
    stall_time_s: float = 1.0
    stall_speed_m_per_s: float = 1e-3
    rest_speed_m_per_s: float = 1e-5
    rest_pressure_tol_pa: float = 1.0
    initial_length_m: float = 0.015
    section_law: bool = False
    force_window_s: float = 0.02
    relax_speed_m_per_s: float = 0.02
    relax_length_m: float = 0.05
    relax_force_n: float = 0.0
    max_relax_steps: int = 50
    dormant_walls: bool = False
    wall_wake_margin_m: float = 0.03
    engine: str = "quasistatic"
    growth_increment_m: float = 0.0005
    solver_tolerance: float = 1e-3
    barrier_gap_m: float = 0.001
    friction_slip_fraction: float = 0.01
    friction_slip_m: float | None = None
    friction_lag_iterations: int = 1
    max_newton_iterations: int = 60
    pressure_increment_fraction: float = 0.05
    linear_solver: str = "semiseparable"
    band_fold: bool = _MODEL.get("band_fold", False)
    fold_pinch_per_rad: float = _MODEL.get("fold_pinch_per_rad", 0.0)
    band_eversion_threshold: bool = True
    flattening: float = _MODEL.get("flattening", 0.0)
    axial_load: bool = _MODEL.get("axial_load", False)
    band_hinge_relief: float = _MODEL.get("band_hinge_relief", 0.0)
    band_hinge_reach_m: float = _MODEL.get("band_hinge_reach_m", 0.15)
    stiffness_factor: float = 1.0
    threshold_z: float = 0.0

    def __post_init__(self) -> None:
        for name in ("iterations", "law_interval", "max_relax_steps", "friction_lag_iterations", "max_newton_iterations"):
            count = getattr(self, name)  # counts: 1.5 and true are not counts (their ranges are checked below)
            if isinstance(count, bool) or not isinstance(count, Integral):
                raise ValueError(f"{name} = {count!r:.80} is out of range: allowed integers (a count)")
        _check("segment_length_m", self.segment_length_m, 0.0005, 0.05, lo_open=False)
        _check("dt_s", self.dt_s, MIN_DT_S, 0.01)
        _check("damping", self.damping, 0.0, 1.0, lo_open=True)
        _check("inertia_factor", self.inertia_factor, 1.0, 1e6)
        _check("mass_ratio", self.mass_ratio, 0.0, 1.0, lo_open=True)
        _check("iterations", self.iterations, 1, 1000)
        _check("law_interval", self.law_interval, 1, 1000)
        _check("active_length_m", self.active_length_m, 0.0, 100.0, lo_open=True)
        _check("freeze_speed_m_per_s", self.freeze_speed_m_per_s, 0.0, 10.0)
        _check("freeze_time_s", self.freeze_time_s, 0.0, 1e6)
        _check("wall_friction", self.wall_friction, 0.0, 5.0)
        _check("tip_friction", self.tip_friction, 0.0, 5.0)
        _check("regulator_tau_s", self.regulator_tau_s, 0.0, 100.0)
        _check("growth_gain_m_per_s_per_pa", self.growth_gain_m_per_s_per_pa, 0.0, 1.0)
        _check("bend_loss_per_rad", self.bend_loss_per_rad, 0.0, 10.0)
        _check("tail_drag_fraction", self.tail_drag_fraction, 0.0, 1.0)
        _check("max_growth_speed_m_per_s", self.max_growth_speed_m_per_s, 0.0, 10.0, lo_open=True)
        _check("stall_time_s", self.stall_time_s, 0.0, 1e6, lo_open=True)
        _check("stall_speed_m_per_s", self.stall_speed_m_per_s, 0.0, 10.0)
        _check("rest_speed_m_per_s", self.rest_speed_m_per_s, 0.0, 1e-2)
        _check("rest_pressure_tol_pa", self.rest_pressure_tol_pa, 0.0, 1000.0)
        _check("initial_length_m", self.initial_length_m, self.segment_length_m, 100.0)
        _check("force_window_s", self.force_window_s, self.dt_s, 1.0)
        _check("relax_speed_m_per_s", self.relax_speed_m_per_s, 0.0, 10.0)
        _check("max_relax_steps", self.max_relax_steps, 0, 100000)
        _check("relax_length_m", self.relax_length_m, 0.0, 100.0)
        _check("relax_force_n", self.relax_force_n, 0.0, 100.0)
        _check("wall_wake_margin_m", self.wall_wake_margin_m, 0.0, 100.0)
        if not isinstance(self.dormant_walls, bool):
            raise ValueError(f"dormant_walls = {self.dormant_walls!r} is out of range: allowed true or false")
        if self.engine not in ENGINES:
            raise ValueError(f"engine = {self.engine!r} is out of range: allowed {' or '.join(repr(e) for e in ENGINES)}")
        _check("growth_increment_m", self.growth_increment_m, 1e-6, self.segment_length_m)
        if not MIN_SOLVER_TOLERANCE <= _check("solver_tolerance", self.solver_tolerance, 0.0, 0.1, lo_open=True):
            raise ValueError(f"solver_tolerance = {self.solver_tolerance!r} is out of range: allowed [{MIN_SOLVER_TOLERANCE:g}, 0.1]; "
                             f"{MIN_SOLVER_TOLERANCE:g} is the floor: the solver's residuals stall near 1e-6 p pi r^2 in double "
                             "precision, so a smaller tolerance is never reached")
        _check("barrier_gap_m", self.barrier_gap_m, 1e-6, 0.01)
        _check("friction_slip_fraction", self.friction_slip_fraction, 1e-6, 0.5)
        if self.friction_slip_m is not None:
            _check("friction_slip_m", self.friction_slip_m, 1e-9, 1e-3)
        _check("friction_lag_iterations", self.friction_lag_iterations, 0, 20)
        _check("max_newton_iterations", self.max_newton_iterations, 1, 10000)
        _check("pressure_increment_fraction", self.pressure_increment_fraction, 1e-6, 0.5)
        if self.linear_solver not in LINEAR_SOLVERS:
            raise ValueError(f"linear_solver = {self.linear_solver!r} is out of range: allowed "
                             f"{' or '.join(repr(e) for e in LINEAR_SOLVERS)}")
        _check("fold_pinch_per_rad", self.fold_pinch_per_rad, 0.0, 10.0)
        _check("flattening", self.flattening, 0.0, 0.5, lo_open=False)
        _check("band_hinge_relief", self.band_hinge_relief, 0.0, 0.9, lo_open=False)
        _check("band_hinge_reach_m", self.band_hinge_reach_m, 0.005, 1.0, lo_open=False)
        _check("stiffness_factor", self.stiffness_factor, 0.5, 2.0, lo_open=False)
        _check("threshold_z", self.threshold_z, -5.0, 5.0, lo_open=False)
        for name in ("band_fold", "band_eversion_threshold", "axial_load"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} = {getattr(self, name)!r} is out of range: allowed true or false")
        other = "dynamic" if self.engine == "quasistatic" else "quasistatic"
        foreign = DYNAMIC_ONLY if self.engine == "quasistatic" else QUASISTATIC_ONLY
        for name in foreign:
            if getattr(self, name) != _DEFAULTS[name]:
                raise ValueError(f"{name} = {getattr(self, name)!r} means nothing to engine {self.engine!r}: it is a setting of "
                                 f"engine {other!r} only (allowed: leave it at {_DEFAULTS[name]!r}, or set engine = {other!r})")
        if self.engine == "quasistatic" and self.section_law:
            raise ValueError("section_law = True is out of range for engine 'quasistatic': allowed false "
                             "(the section law runs on engine 'dynamic')")
        if self.engine == "dynamic" and self.max_growth_speed_m_per_s * self.dt_s > 0.2 * self.segment_length_m:
            raise ValueError(
                f"max_growth_speed_m_per_s * dt_s = {self.max_growth_speed_m_per_s * self.dt_s:g} m per step is out of "
                f"range: allowed <= 0.2 x segment_length_m ({0.2 * self.segment_length_m:g} m); lower dt_s"
            )

    def to_dict(self) -> dict:
        return asdict(self)


#: The engines ``SimConfig.engine`` takes.
ENGINES = ("quasistatic", "dynamic")
#: The quasi-static engine's solvers of a Newton step's linear system (``SimConfig.linear_solver``).
LINEAR_SOLVERS = ("dense", "semiseparable")
#: Settings of the dynamic pymunk chain (masses, damping, solver passes, relaxation, active set).
DYNAMIC_ONLY = ("damping", "inertia_factor", "mass_ratio", "iterations", "law_interval", "freeze_speed_m_per_s", "freeze_time_s",
                "rest_speed_m_per_s", "rest_pressure_tol_pa", "force_window_s", "relax_speed_m_per_s", "relax_length_m",
                "relax_force_n", "max_relax_steps", "dormant_walls", "wall_wake_margin_m", "tail_drag_fraction")
#: Settings of the quasi-static engine.
QUASISTATIC_ONLY = ("growth_increment_m", "solver_tolerance", "barrier_gap_m", "friction_slip_fraction", "friction_slip_m",
                    "friction_lag_iterations",
                    "max_newton_iterations", "pressure_increment_fraction", "linear_solver", "band_fold", "fold_pinch_per_rad",
                    "band_eversion_threshold", "flattening", "axial_load", "band_hinge_relief", "band_hinge_reach_m",
                    "stiffness_factor", "threshold_z")
_DEFAULTS = {f.name: f.default for f in fields(SimConfig)}


def quasistatic_overrides(text: str) -> dict:
    """SimConfig fields for the quasi-static engine from JSON text (a script's ``--sim``), checked before any
    work: a JSON object of known fields, ``engine`` left out, valid together.  Raises ValueError naming what
    is wrong."""
    import json

    sim = json.loads(text)
    if not isinstance(sim, dict) or "engine" in sim:
        raise ValueError("expected a JSON object of quasi-static SimConfig fields, engine left out")
    unknown = sorted(set(sim) - set(_DEFAULTS))
    if unknown:
        raise ValueError(f"unknown SimConfig fields {unknown}")
    SimConfig(engine="quasistatic", **sim)
    return sim
