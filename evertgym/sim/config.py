"""Fidelity and physics settings of the simulator (SI), validated at construction."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from numbers import Integral

import numpy as np

from evertgym._validate import check_range as _check
from evertgym.design import TubeDesign
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


#: ``SimConfig`` field metadata: the engine a field belongs to (:data:`BOTH`, or one of :data:`ENGINES`).
BOTH = "both"


def _setting(default, engine: str = BOTH):
    """A SimConfig field whose metadata names the engine it belongs to."""
    return field(default=default, metadata={"engine": engine})


@dataclass(frozen=True)
class SimConfig:
    """Simulator settings, one flat set of fields; each field's metadata names the engine it belongs to
    (``"both"``, ``"dynamic"`` or ``"quasistatic"``, :func:`engine_fields`).  A field of the engine not
    chosen must stay at its default: set, it is refused in one line.  ``--sim`` JSON is parsed and checked
    by :func:`parse_sim`.

    Both engines
        ``engine``: ``"quasistatic"`` (the default, :mod:`evertgym.sim.quasistatic`: the body in static
        equilibrium after every growth increment and pressure change, no mass, inertia or damping; the
        clock ``dt_s`` advances the regulator and the growth law only) or ``"dynamic"`` (the pymunk chain
        of :mod:`evertgym.sim.simulator`).  ``segment_length_m``: segment length ds of the chain of
        segments both engines describe the body with.  ``dt_s``: the clock's step (the dynamic engine's
        pymunk step).  ``initial_length_m``: the body everted at the start.  ``active_length_m``: the
        length behind the tip that moves (the quasi-static solve's window; the dynamic engine's active set,
        below).  ``wall_friction``: Coulomb coefficient between the everted body and a wall: the everted
        body is laid down and does not slide along the walls, so it is high.  ``tip_friction``: the same
        for the everting tip segment, whose fold rolls over a wall as it everts and slides easily.
        ``regulator_tau_s``: pressure lag.  ``growth_gain_m_per_s_per_pa``, ``bend_loss_per_rad`` (the
        tail's capstan coefficient), ``max_growth_speed_m_per_s``: the growth law
        (:mod:`evertgym.sim.growth`).  ``stall_time_s``: a stall is no growth faster than
        ``stall_speed_m_per_s`` for this long.

    Dynamic engine: fidelity (the quasi-static regime of the pymunk chain)
        ``damping``: ``space.damping`` (velocity fraction kept after 1 s); spring stiffnesses are divided
        by ``damping ** dt`` so that the damping, which Chipmunk applies to the spring impulses too, does
        not bias the equilibrium.  ``inertia_factor``: segment rotational inertia ``I = f k dt^2`` for the
        stiffest adjacent joint ``k`` (f = 3 puts its local mode near 1.2 rad per step; 2 is the edge of
        stability of the explicit spring); ``mass_ratio``: translational mass as a fraction of a uniform
        bar's ``12 I / ds^2`` (small: the chain then relaxes in O(N) rather than O(N^2) steps).  Masses are
        scaled, not physical: only static answers are meaningful, and tests check they do not depend on
        these settings.  ``iterations``: constraint solver passes.  ``law_interval``: steps between updates
        of the non-linear joint law.
    Dynamic engine: active set
        Segments more than ``active_length_m`` behind the tip whose mean speed over each 50-step check
        stayed below ``freeze_speed_m_per_s`` for ``freeze_time_s`` become static (leave the active set).
        With ``dormant_walls`` (opt-in), compliant wall pieces farther than ``wall_wake_margin_m`` from
        every active segment's surface and at rest sleep (static, out of the solver) until one comes near
        (:mod:`evertgym.sim.dormant`).
    Dynamic engine: rest lock
        A stalled robot whose every dynamic body (segments and compliant wall pieces) moves slower than
        ``rest_speed_m_per_s`` is in static equilibrium: it is held there, without stepping the solver,
        until the regulated pressure moves by more than ``rest_pressure_tol_pa`` (Coulomb friction sticks;
        Chipmunk's iterative solver only approximates sticking and lets a loaded chain creep, then kick).
        0 disables it.
    Dynamic engine: axial-load model
        ``section_law``: False (default) is the rigid-column model; True the section law
        (:mod:`evertgym.model.section_law`, :mod:`evertgym.sim.simulator`), under which
        ``tail_drag_fraction`` (the share of the bare eversion threshold that is the tail's drag at the
        base), the force window and the relaxation below apply.  ``force_window_s``: the tip's wall force
        is its impulse over this window divided by the window (a quasi-static force, the same for any step;
        :meth:`DynamicSim._tip_reaction`).  After each growth increment the chain is stepped, without
        advancing time, until its active segments within ``relax_length_m`` of the tip move slower than
        ``relax_speed_m_per_s`` (at most ``max_relax_steps`` steps; 0 m/s disables it); with
        ``relax_force_n`` > 0 the criterion is instead the unbalanced force the motion implies (``m g
        |v|``, ``I g |w| / ds``).  Neither yet makes outcomes independent of the scaled masses
        (docs/sim.md) (:meth:`DynamicSim._relax`).

    Quasi-static engine: the solver
        ``growth_increment_m`` (the largest growth between two equilibria near a wall; up to a segment in
        free space), ``solver_tolerance`` (the largest unbalanced moment and force over ``p pi r^3`` and
        ``p pi r^2``, ``p`` at least 1 kPa), ``barrier_gap_m`` (IPC's d_hat: the contact barrier acts below
        this gap), ``friction_slip_fraction`` (IPC's eps_v h: a contact slides once its tangential travel
        in a solve exceeds this fraction of the solve's growth, of ``growth_increment_m`` for a solve without
        growth; below it static friction lets it creep, so the creep per metre of growth, not per increment,
        is fixed, and halving the increment does not add creep), ``friction_slip_m`` (optional: a fixed
        travel per solve instead, in m, which makes the creep grow as the increment shrinks),
        ``friction_lag_iterations`` (the most times a solve makes its lagged normal forces and tangents
        again from the contacts, at its Newton iterates, until they stop changing; a solve whose lag is
        cut short is counted in ``friction_lag_unconverged``: its friction comes from forces one iterate
        old, an error of the order of the increment, so the default iterates the lag to convergence and the
        outcomes do not move with ``growth_increment_m``, docs/quasistatic.md),
        ``max_newton_iterations`` and ``pressure_increment_fraction`` (the pressure change, as a fraction
        of the last solve's pressure and at least of 1 kPa, after which the body is re-solved while it
        touches a wall or is growing), ``linear_solver`` (how a Newton step's linear system is solved:
        ``"semiseparable"``, the default since 2026-12-05, in O(m + pieces), the joints' Hessian being
        diagonal plus semiseparable of rank 3 in joint coordinates and the compliant wall pieces eliminated
        into it; or ``"dense"``, the default before, a Cholesky factorisation of the joints' Hessian and a
        dense Schur complement for the pieces, O(m^3); the two agree to rounding, not bit for bit: a number
        made before the switch is regenerated exactly with ``"dense"``).
    Quasi-static engine: band-mechanism laws (:mod:`evertgym.sim.band_laws`)
        ``band_fold``: an everted band folds axially (goes slack) when the tip's push and the tail's
        tension exceed ``p pi r_b^2``; growth then stops.  ``fold_pinch_per_rad``: the tail's losses
        grow by ``exp(mu_p Phi)`` with the body's excess fold angle ``Phi``.
        ``band_eversion_threshold``: False removes the calibrated threshold of a band at the tip (a
        counterfactual of the study).  ``flattening``: the bare tube's largest cross-section flattening
        past wrinkling (a fraction of the radius; a band adds its reduction): the collision radius and
        the collapse moment shrink with it.  ``joint_softening``: a joint's moment falls past its peak by this fraction (Brazier's
        ovalisation; candidate (b) of docs/bands.md).  ``axial_load``: the wall's moment capacity at a section falls
        with the axial load it carries, the tip's push and the tail's tension against ``p pi r(s)^2``
        (first at bands).  ``band_hinge_relief`` and ``band_hinge_reach_m``: the phenomenological band
        law, the tip's friction coefficient lowered by this fraction while a wrinkled band lies within
        this reach behind the tip.  Their defaults are the adopted bend model's
        (``evertgym/data/bend_model.json``, :mod:`evertgym.experiments.bend_model`).
    Quasi-static engine: robot-to-robot variation (one fabricated robot; :mod:`evertgym.sim.variation`)
        ``stiffness_factor`` multiplies the joints' bending stiffness; ``threshold_z`` is the robot's
        standard-normal draw of its eversion threshold (Exp 4's coefficient of variation at the local
        reduction).  1 and 0 by default: the median robot.
    """

    # ---- both engines ----
    engine: str = _setting("quasistatic")
    segment_length_m: float = _setting(0.0075)
    dt_s: float = _setting(0.002)
    initial_length_m: float = _setting(0.015)
    active_length_m: float = _setting(0.2)
    wall_friction: float = _setting(1.0)
    tip_friction: float = _setting(0.2)
    regulator_tau_s: float = _setting(0.15)
    growth_gain_m_per_s_per_pa: float = _setting(GROWTH_GAIN_M_PER_S_PER_PA)
    bend_loss_per_rad: float = _setting(0.08)
    max_growth_speed_m_per_s: float = _setting(MAX_GROWTH_SPEED_M_PER_S)
    stall_time_s: float = _setting(1.0)
    stall_speed_m_per_s: float = _setting(1e-3)
    # ---- the dynamic engine (evertgym.sim.simulator) ----
    damping: float = _setting(1e-6, "dynamic")
    inertia_factor: float = _setting(3.0, "dynamic")
    mass_ratio: float = _setting(0.01, "dynamic")
    iterations: int = _setting(10, "dynamic")
    law_interval: int = _setting(5, "dynamic")
    freeze_speed_m_per_s: float = _setting(5e-3, "dynamic")
    freeze_time_s: float = _setting(0.3, "dynamic")
    dormant_walls: bool = _setting(False, "dynamic")
    wall_wake_margin_m: float = _setting(0.03, "dynamic")
    rest_speed_m_per_s: float = _setting(1e-5, "dynamic")
    rest_pressure_tol_pa: float = _setting(1.0, "dynamic")
    section_law: bool = _setting(False, "dynamic")
    tail_drag_fraction: float = _setting(1.0, "dynamic")
    force_window_s: float = _setting(0.02, "dynamic")
    relax_speed_m_per_s: float = _setting(0.02, "dynamic")
    relax_length_m: float = _setting(0.05, "dynamic")
    relax_force_n: float = _setting(0.0, "dynamic")
    max_relax_steps: int = _setting(50, "dynamic")
    # ---- the quasi-static engine (evertgym.sim.quasistatic) ----
    growth_increment_m: float = _setting(0.0005, "quasistatic")
    solver_tolerance: float = _setting(1e-3, "quasistatic")
    barrier_gap_m: float = _setting(0.001, "quasistatic")
    friction_slip_fraction: float = _setting(0.01, "quasistatic")
    friction_slip_m: float | None = _setting(None, "quasistatic")
    friction_lag_iterations: int = _setting(30, "quasistatic")
    max_newton_iterations: int = _setting(60, "quasistatic")
    pressure_increment_fraction: float = _setting(0.05, "quasistatic")
    linear_solver: str = _setting("semiseparable", "quasistatic")
    band_fold: bool = _setting(_MODEL.get("band_fold", False), "quasistatic")
    fold_pinch_per_rad: float = _setting(_MODEL.get("fold_pinch_per_rad", 0.0), "quasistatic")
    band_eversion_threshold: bool = _setting(True, "quasistatic")
    flattening: float = _setting(_MODEL.get("flattening", 0.0), "quasistatic")
    joint_softening: float = _setting(_MODEL.get("joint_softening", 0.0), "quasistatic")
    axial_load: bool = _setting(_MODEL.get("axial_load", False), "quasistatic")
    band_hinge_relief: float = _setting(_MODEL.get("band_hinge_relief", 0.0), "quasistatic")
    band_hinge_reach_m: float = _setting(_MODEL.get("band_hinge_reach_m", 0.15), "quasistatic")
    stiffness_factor: float = _setting(1.0, "quasistatic")
    threshold_z: float = _setting(0.0, "quasistatic")

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
        _check("friction_lag_iterations", self.friction_lag_iterations, 0, 100)
        _check("max_newton_iterations", self.max_newton_iterations, 1, 10000)
        _check("pressure_increment_fraction", self.pressure_increment_fraction, 1e-6, 0.5)
        if self.linear_solver not in LINEAR_SOLVERS:
            raise ValueError(f"linear_solver = {self.linear_solver!r} is out of range: allowed "
                             f"{' or '.join(repr(e) for e in LINEAR_SOLVERS)}")
        _check("fold_pinch_per_rad", self.fold_pinch_per_rad, 0.0, 10.0)
        _check("flattening", self.flattening, 0.0, 0.5, lo_open=False)
        _check("joint_softening", self.joint_softening, 0.0, 0.9, lo_open=False)
        _check("band_hinge_relief", self.band_hinge_relief, 0.0, 0.9, lo_open=False)
        _check("band_hinge_reach_m", self.band_hinge_reach_m, 0.005, 1.0, lo_open=False)
        _check("stiffness_factor", self.stiffness_factor, 0.5, 2.0, lo_open=False)
        _check("threshold_z", self.threshold_z, -5.0, 5.0, lo_open=False)
        for name in ("band_fold", "band_eversion_threshold", "axial_load"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} = {getattr(self, name)!r} is out of range: allowed true or false")
        for name in engine_fields(_OTHER[self.engine]):
            if getattr(self, name) != _DEFAULTS[name]:
                raise ValueError(f"{name} = {getattr(self, name)!r} means nothing to engine {self.engine!r}: it is a setting of "
                                 f"engine {_OTHER[self.engine]!r} only (allowed: leave it at {_DEFAULTS[name]!r}, or set "
                                 f"engine = {_OTHER[self.engine]!r})")
        if self.engine == "dynamic" and self.max_growth_speed_m_per_s * self.dt_s > 0.2 * self.segment_length_m:
            raise ValueError(
                f"max_growth_speed_m_per_s * dt_s = {self.max_growth_speed_m_per_s * self.dt_s:g} m per step is out of "
                f"range: allowed <= 0.2 x segment_length_m ({0.2 * self.segment_length_m:g} m); lower dt_s"
            )

    def to_dict(self) -> dict:
        return asdict(self)


#: The engines ``SimConfig.engine`` takes.
ENGINES = ("quasistatic", "dynamic")
_OTHER = {"quasistatic": "dynamic", "dynamic": "quasistatic"}
#: The quasi-static engine's solvers of a Newton step's linear system (``SimConfig.linear_solver``).
LINEAR_SOLVERS = ("dense", "semiseparable")
_DEFAULTS = {f.name: f.default for f in fields(SimConfig)}


def engine_fields(engine: str) -> tuple[str, ...]:
    """The SimConfig fields that belong to ``engine`` (``"dynamic"``, ``"quasistatic"``, or ``"both"`` for the
    shared ones), in declaration order."""
    if engine not in (*ENGINES, BOTH):
        raise ValueError(f"engine = {engine!r} is out of range: allowed {' or '.join(repr(e) for e in (*ENGINES, BOTH))}")
    return tuple(f.name for f in fields(SimConfig) if f.metadata["engine"] == engine)


#: Settings of the dynamic pymunk chain only (masses, damping, solver passes, active set, rest lock, section law).
DYNAMIC_ONLY = engine_fields("dynamic")
#: Settings of the quasi-static engine only (its solver, the band-mechanism laws, robot-to-robot variation).
QUASISTATIC_ONLY = engine_fields("quasistatic")
#: The ``--sim`` example every refusal quotes.
_EXAMPLE = '{"engine": "dynamic"}'


def parse_sim(text: str | None, extra: dict | None = None, *, engine: str | None = None) -> dict:
    """SimConfig fields from ``--sim`` JSON text, checked before any work starts: the one parser of every
    command and script.

    ``text``: a JSON object of SimConfig fields (flat keys, e.g. ``{"growth_increment_m": 0.0005}``); None
    or blank is ``{}``.  ``extra``: fields set on top (a command's own, e.g. ``{"engine": "dynamic"}``).
    ``engine``: the engine the caller runs, when it runs only one: ``text`` may not name another one, and
    its fields are checked against it.  Returns the parsed fields with ``extra`` (``engine`` not added).

    Every field is checked as :class:`SimConfig` checks it (names, types, ranges, the engine it belongs
    to), and the settings together as the simulator will build them on the paper's 0.9 m body
    (:func:`check_buildable`: the dynamic engine's work per simulated second).  Raises
    ``ValueError`` with one line naming the field, the value and what is allowed (without the flag's name:
    the caller prefixes it, ``--sim: ...``)."""
    import difflib
    import json

    if text is None or not str(text).strip():
        sim: object = {}
    else:
        try:
            sim = json.loads(text)
        except (json.JSONDecodeError, TypeError) as e:
            reason = e.msg if isinstance(e, json.JSONDecodeError) else str(e)
            raise ValueError(f"{text!r:.80} is not JSON ({reason}): allowed a JSON object of SimConfig fields, e.g. {_EXAMPLE}") from None
        except RecursionError:
            raise ValueError(f"{text!r:.80} is nested too deeply: allowed a JSON object of SimConfig fields, e.g. {_EXAMPLE}") from None
    if not isinstance(sim, dict):
        raise ValueError(f"{text!r:.80} is a JSON {_json_kind(sim)}: allowed a JSON object of SimConfig fields, e.g. {_EXAMPLE}")
    for name, value in sim.items():
        if name not in _DEFAULTS:
            near = difflib.get_close_matches(name, list(_DEFAULTS), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            shown = name if name.isprintable() else repr(name)  # (a newline in a key would break the one line)
            raise ValueError(f"{shown:.60} = {value!r:.40} is not a SimConfig field{hint}: allowed the fields of SimConfig "
                             "(evertgym.sim.config, docs/sim.md)")
    if engine is not None:
        if engine not in ENGINES:
            raise ValueError(f"engine = {engine!r} is out of range: allowed {' or '.join(repr(e) for e in ENGINES)}")
        if sim.get("engine", engine) != engine:
            raise ValueError(f"engine = {sim['engine']!r:.40} is out of range here: allowed {engine!r} (this command runs "
                             f"engine {engine!r} only)")
    out = {**sim, **(extra or {})}
    fields_in = {"engine": engine, **out} if engine is not None else out
    try:
        cfg = SimConfig(**fields_in)
    except TypeError as e:  # (a field's value of a type no check reaches)
        raise ValueError(str(e).splitlines()[0]) from None
    check_buildable(TubeDesign(length_m=0.9), cfg)
    return out


def _json_kind(value: object) -> str:
    """The JSON name of a parsed value's type."""
    if isinstance(value, list):
        return "array"
    if isinstance(value, str):
        return "string"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, (int, float)):
        return "number"
    return "null" if value is None else type(value).__name__


#: The most work (segment passes, :func:`dynamic_work_per_s`) per simulated second the dynamic engine accepts:
#: about 185 times its default on a 0.9 m body (5.4e6).  Measured on 2 shared cores (docs/robustness.md): 27
#: passes per 1e-5 s step on 1 mm segments, never frozen (9.6e9), took 4 s per 0.1 s env step on average and 45 s
#: for the worst one (the body in the bend's contacts); at this bound the worst step stays well under 10 s.
MAX_DYNAMIC_WORK_PER_S = 1e9
#: A pymunk step's own cost per body (collision detection, the Python loop), in constraint passes.
_STEP_OVERHEAD_PASSES = 80


def dynamic_work_per_s(design: TubeDesign, cfg: SimConfig) -> float:
    """An upper bound of the dynamic engine's stepping work per simulated second, in segment passes: every
    segment of the body active, ``iterations`` constraint passes plus the step's own cost
    (:data:`_STEP_OVERHEAD_PASSES`) per step of ``dt_s``.  Relaxation (section law) is bounded at run time
    (:func:`evertgym.sim.tube.relax_step_budget`)."""
    segments = design.length_m / cfg.segment_length_m
    return (cfg.iterations + _STEP_OVERHEAD_PASSES) * segments / cfg.dt_s


def check_buildable(design: TubeDesign, cfg: SimConfig, scene=None) -> None:
    """Raise ``ValueError`` naming the field unless the simulator can build ``design`` with
    ``cfg`` in ``scene``: the body must hold the initial chain, the dynamic engine's work per simulated
    second is bounded (:data:`MAX_DYNAMIC_WORK_PER_S`), and the robot's diameter may not exceed the
    scene's narrowest lumen."""
    need = cfg.initial_length_m
    if design.length_m < need - 1e-12:
        raise ValueError(f"length_m = {design.length_m:g} is out of range: allowed >= {need:g} m "
                         "(the simulator's initial_length_m)")
    if cfg.engine == "dynamic":
        work = dynamic_work_per_s(design, cfg)
        if work > MAX_DYNAMIC_WORK_PER_S:
            raise ValueError(
                f"dt_s = {cfg.dt_s:g}, iterations = {cfg.iterations}, segment_length_m = {cfg.segment_length_m:g}"
                f" on a {design.length_m:g} m body ask the dynamic engine for {work:.3g} segment passes per simulated second: "
                f"out of range, allowed at most {MAX_DYNAMIC_WORK_PER_S:.0e} (the defaults ask "
                f"{dynamic_work_per_s(design, type(cfg)(engine='dynamic')):.2g}; beyond it one 0.1 s env step runs for seconds): "
                "raise dt_s or segment_length_m, or lower iterations")
    lumen = getattr(scene, "lumen_width", None)
    if lumen is not None and len(lumen) and design.diameter_m > float(np.min(lumen)) + 1e-9:
        raise ValueError(f"diameter_m = {design.diameter_m:g} is out of range: allowed up to the scene's narrowest "
                         f"lumen, {float(np.min(lumen)):g} m (the robot must fit the channel)")
