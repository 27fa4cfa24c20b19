"""Accuracy and cost of the simulator's fidelity settings.

Each setting is a :class:`~evertgym.sim.SimConfig` differing from the default in some of
its fidelity fields (:data:`FIDELITY_FIELDS`).  For each the sweep measures (SI inside,
mm where the name says so):

``tip_force_error``
    Largest relative error ``|F_sim / F_rod - 1|`` of the pymunk tensile test
    (:func:`evertgym.sim.tensile.sim_tensile_test`) against the Cosserat rod
    (:func:`evertgym.model.stiffness.virtual_tensile_test`) over :data:`PAPER_DESIGNS` at
    the tip displacements :data:`DISPLACEMENTS_M` (20 mm, the paper's, and 60 mm, deep in
    the wrinkled range), at the paper's 6.9 kPa.
``tip_pose_error_mm``
    Largest ``|x_tip,sim - x_tip,rod|`` (mm) over the same designs at 60 mm displacement:
    the axial shortening of the bent tube, a shape error the force does not show.
``ubend_disagreement``
    Fraction of the U-bend trials (:data:`UBEND_RADII_MM` x :data:`UBEND_BANDS` x
    :data:`UBEND_PRESSURES_PA`; success when the tip's arc length reaches the scene's goal
    within 15 s) whose outcome differs from the reference setting's (the finest:
    :data:`REFERENCE`).  A trial that raises ``NumericalInstabilityError`` counts as an
    outcome of its own.
``ubend_disagreement_quasistatic``
    The same fraction against the quasi-static engine's outcomes on the same trials
    (``SimConfig(engine="quasistatic")``, whose answers do not move with its numerical settings:
    docs/quasistatic.md): a reference that is not one of the settings measured.
``wall_s_per_sim_s``
    Wall-clock seconds per simulated second of a U-bend growth run (the bare 0.9 m robot in
    the 40 mm U-bend at 3 kPa for 10 s, through and past the bend), best of three.  Machine
    dependent: compare rows of one run only.

Assumptions: the rod is the reference for statics (the chain converges to it as ``ds ->
0``); U-bend outcomes have no analytic reference, so the finest setting stands in for one.
The sweep is not the full product of the fields: one field at a time around the default,
plus combinations of the two that set the cost (``segment_length_m``, ``dt_s``).

:func:`skip_costs` measures what the simulator saves by skipping what a scene does not
need: the active set on a long robot, rigid against compliant walls, rendering off.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from evertgym.design import Band, TubeDesign
from evertgym.model.stiffness import paper_prototype, virtual_tensile_test
from evertgym.scenes import PAPER_UBEND_RADII_MM, make_scene, render_rgb
from evertgym.sim import EversionSim, NumericalInstabilityError, SimConfig
from evertgym.sim.tensile import sim_tensile_test

#: The SimConfig fields the sweep varies (and reports for every setting).
FIDELITY_FIELDS = ("segment_length_m", "dt_s", "iterations", "inertia_factor", "mass_ratio", "active_length_m")
#: Tensile-test designs: (name, band distances from the tip in mm, diameter reduction).
PAPER_DESIGNS: tuple[tuple[str, tuple[float, ...], float], ...] = (
    ("bare", (), 0.0),
    ("1 band 50% at 50 mm", (50.0,), 0.5),
    ("4 bands 50% at 50-200 mm", (50.0, 100.0, 150.0, 200.0), 0.5),
    ("1 band 10% at 100 mm", (100.0,), 0.1),
)
#: Lateral tip displacements (m) of the tensile test; the pose error uses the last.
DISPLACEMENTS_M = (0.020, 0.060)
#: The contact-safety run of :func:`wall_overlap_mm`: U-bend inner radius (mm), pressure (Pa),
#: duration (s), and the contact tolerances (m) of the stress tests (tests/test_stress.py):
#: every node but the tip's, and the tip's.
SAFETY_RADIUS_MM = 20.0
SAFETY_PRESSURE_PA = 8000.0
SAFETY_TIME_S = 8.0
BODY_TOLERANCE_M = 1e-3
TIP_TOLERANCE_M = 2e-3
#: Band centres (m from the base) of the paper's colon robot.
COLON_BANDS_M = (0.25, 0.30, 0.35)

#: Largest ``tip_force_error`` a default setting may have.
FORCE_ERROR_BUDGET = 0.03
#: U-bend trials: inner radii (mm, the paper's 20-40 mm), band sets (position from the base
#: in m, reduction: none, or the paper's three 10% bands 50 mm apart just before the bend),
#: constant pressures (Pa; the paper's 3 kPa and one above it).
UBEND_RADII_MM = PAPER_UBEND_RADII_MM
UBEND_RADII_QUICK_MM = (25.0, 32.5, 40.0)
UBEND_BANDS: tuple[tuple[tuple[float, float], ...], ...] = ((), ((0.20, 0.1), (0.25, 0.1), (0.30, 0.1)))
UBEND_PRESSURES_PA = (3000.0, 4000.0)
UBEND_PRESSURES_QUICK_PA = (3000.0,)
#: Pressure (Pa) of the timed growth run and of the cost measurements.
TIMING_PRESSURE_PA = 3000.0
UBEND_TIME_LIMIT_S = 15.0
#: The paper's robot: 40 mm diameter; 0.9 m reaches well past the U-bend's goal.
ROBOT_LENGTH_M = 0.9
#: Control period (s) of every run here: the goal is checked this often.
CONTROL_PERIOD_S = 0.1
#: The timed growth run: U-bend inner radius (mm), simulated duration (s), repeats.
TIMING_RADIUS_MM = 40.0
TIMING_SIM_S = 10.0
TIMING_REPEATS = 3


@dataclass(frozen=True)
class SweepSetting:
    """A named set of :class:`SimConfig` overrides (SI field values)."""

    label: str
    overrides: Mapping[str, float] = field(default_factory=dict)

    def config(self) -> SimConfig:
        return replace(SimConfig(engine="dynamic"), **self.overrides)  # type: ignore[arg-type]  # int fields take ints

    def fidelity(self) -> dict[str, float]:
        """The values of :data:`FIDELITY_FIELDS` in this setting."""
        cfg = self.config()
        return {name: getattr(cfg, name) for name in FIDELITY_FIELDS}


#: The finest setting: 5 mm segments, 1 ms steps, 20 solver passes, and an active window
#: longer than the robot (nothing is frozen).
REFERENCE = SweepSetting("reference (finest)",
                         {"segment_length_m": 0.005, "dt_s": 0.001, "iterations": 20, "active_length_m": 1.0})


def default_settings(quick: bool = False) -> list[SweepSetting]:
    """The settings swept, the reference first.

    Full: the default; one field at a time (segment 5/10/15 mm, step 1/4 ms, 5/20 solver
    passes, inertia factor 2.5/6, mass ratio 0.003/0.05, active window 0.1/0.5 m); and
    combinations of segment length and step.  Quick: the reference, the default and five
    of those.
    """
    mm, ms = 1e-3, 1e-3
    one_at_a_time = [
        SweepSetting("segment 5 mm", {"segment_length_m": 5 * mm}),
        SweepSetting("segment 10 mm", {"segment_length_m": 10 * mm}),
        SweepSetting("segment 15 mm", {"segment_length_m": 15 * mm}),
        SweepSetting("step 1 ms", {"dt_s": 1 * ms}),
        SweepSetting("step 4 ms", {"dt_s": 4 * ms}),
        SweepSetting("5 iterations", {"iterations": 5}),
        SweepSetting("20 iterations", {"iterations": 20}),
        SweepSetting("inertia factor 2.5", {"inertia_factor": 2.5}),
        SweepSetting("inertia factor 6", {"inertia_factor": 6.0}),
        SweepSetting("mass ratio 0.003", {"mass_ratio": 0.003}),
        SweepSetting("mass ratio 0.05", {"mass_ratio": 0.05}),
        SweepSetting("active window 0.1 m", {"active_length_m": 0.1}),
        SweepSetting("active window 0.5 m", {"active_length_m": 0.5}),
    ]
    combinations = [
        SweepSetting("segment 5 mm, step 1 ms", {"segment_length_m": 5 * mm, "dt_s": 1 * ms}),
        SweepSetting("segment 10 mm, step 4 ms", {"segment_length_m": 10 * mm, "dt_s": 4 * ms}),
        SweepSetting("segment 15 mm, step 4 ms", {"segment_length_m": 15 * mm, "dt_s": 4 * ms}),
        SweepSetting("segment 10 mm, step 4 ms, 5 iterations", {"segment_length_m": 10 * mm, "dt_s": 4 * ms, "iterations": 5}),
        SweepSetting("segment 10 mm, step 4 ms, active window 0.1 m",
                     {"segment_length_m": 10 * mm, "dt_s": 4 * ms, "active_length_m": 0.1}),
    ]
    default = SweepSetting("default")
    if quick:
        keep = {"segment 5 mm", "segment 15 mm", "step 4 ms", "5 iterations", "segment 10 mm, step 4 ms"}
        return [REFERENCE, default] + [s for s in one_at_a_time + combinations if s.label in keep]
    return [REFERENCE, default] + one_at_a_time + combinations


# ---- measurements ----------------------------------------------------------------------
def rod_references() -> dict[tuple[str, float], tuple[float, float]]:
    """``(design name, displacement m) -> (lateral force N, tip x m)`` of the Cosserat rod."""
    out = {}
    for name, bands, reduction in PAPER_DESIGNS:
        design = paper_prototype(bands, reduction)
        for d in DISPLACEMENTS_M:
            sol = virtual_tensile_test(design, d)
            out[(name, d)] = (float(sol.force[1]), sol.tip_x)
    return out


def tensile_errors(config: SimConfig, refs: Mapping[tuple[str, float], tuple[float, float]]) -> dict:
    """``tip_force_error`` (relative), ``tip_pose_error_mm`` and whether every pymunk tensile
    test converged, for ``config`` against the rod references ``refs``."""
    force_err, pose_err, converged = 0.0, 0.0, True
    for name, bands, reduction in PAPER_DESIGNS:
        design = paper_prototype(bands, reduction)
        for d in DISPLACEMENTS_M:
            res = sim_tensile_test(design, d, config=config)
            f_rod, x_rod = refs[(name, d)]
            force_err = max(force_err, abs(res.force_n / f_rod - 1.0))
            if d == DISPLACEMENTS_M[-1]:
                pose_err = max(pose_err, abs(res.tip_x_m - x_rod) * 1e3)
            converged = converged and res.converged
    return {"tip_force_error": force_err, "tip_pose_error_mm": pose_err, "tensile_converged": converged}


def ubend_outcome(config: SimConfig, radius_mm: float, bands: Sequence[tuple[float, float]], pressure_pa: float) -> str:
    """``"pass"``, ``"fail"`` or ``"unstable"``: whether the 0.9 m, 40 mm robot with ``bands``
    (position from the base m, reduction) reaches the goal of the U-bend of inner radius
    ``radius_mm`` within 15 s at a constant ``pressure_pa`` (Pa)."""
    scene = make_scene({"family": "ubend", "params": {"radius_mm": radius_mm}})
    design = TubeDesign(length_m=ROBOT_LENGTH_M, bands=tuple(Band(p, r) for p, r in bands))
    try:
        sim = EversionSim(design, scene=scene, config=config)
        sim.set_pressure_command(pressure_pa)
        while sim.t < UBEND_TIME_LIMIT_S - 1e-9:
            sim.run(CONTROL_PERIOD_S)
            if scene.project(sim.tip_position)[0] >= scene.goal_arclength:
                return "pass"
    except NumericalInstabilityError:
        return "unstable"
    return "fail"


def wall_overlap_mm(config: SimConfig) -> float:
    """Largest depth (mm) by which the tube's surface passed into a wall, beyond the stress
    tests' contact tolerances (1 mm, 2 mm at the tip), while the 0.9 m, 40 mm robot grows 8 s into the tightest (20 mm) U-bend
    at 8 kPa: the hardest contact of the paper's experiments (checked every 5 steps).  A
    setting with a positive value lets the tip tunnel; ``inf`` if it became unstable."""
    scene = make_scene({"family": "ubend", "params": {"radius_mm": SAFETY_RADIUS_MM}})
    worst = -math.inf
    try:
        sim = EversionSim(TubeDesign(length_m=ROBOT_LENGTH_M), scene=scene, config=config)
        sim.set_pressure_command(SAFETY_PRESSURE_PA)
        while sim.t < SAFETY_TIME_S - 1e-9:
            sim.step(5)
            line = sim.centreline()[1:]
            tol = np.full(len(line), BODY_TOLERANCE_M)
            tol[-1] = TIP_TOLERANCE_M
            worst = max(worst, float(np.max(sim.radii() - scene.wall_distance(line) - tol)))
    except NumericalInstabilityError:
        return math.inf
    return max(worst, 0.0) * 1e3


def colon_peak_force_n(config: SimConfig) -> float:
    """Largest tip contact force (N) while the paper's banded colon robot (20 mm, 0.8 m,
    3 x 10% bands at 250/300/350 mm) is pushed into the default colon phantom's bend at
    8 kPa for 8 s: how hard a compliant wall is hit, which the static tensile error cannot
    see (``inf`` if the run became unstable)."""
    scene = make_scene({"family": "colon", "params": {}})
    design = TubeDesign(diameter_m=0.02, length_m=0.8, bands=tuple(Band(p, 0.1) for p in COLON_BANDS_M))
    try:
        sim = EversionSim(design, scene=scene, config=config)
        sim.set_pressure_command(SAFETY_PRESSURE_PA)
        sim.run(SAFETY_TIME_S)
    except NumericalInstabilityError:
        return math.inf
    return float(sim.max_contact_force)


def ubend_trials(quick: bool = False) -> list[tuple[float, tuple[tuple[float, float], ...], float]]:
    """The U-bend trials ``(radius mm, bands, pressure Pa)``, in order: every pressure, band
    set and radius (fewer radii and pressures with ``quick``)."""
    radii = UBEND_RADII_QUICK_MM if quick else UBEND_RADII_MM
    pressures = UBEND_PRESSURES_QUICK_PA if quick else UBEND_PRESSURES_PA
    return [(r, bands, p) for p in pressures for bands in UBEND_BANDS for r in radii]


def growth_cost(config: SimConfig, spec: Mapping, design: TubeDesign, pressure_pa: float, sim_s: float,
                render: bool = False, repeats: int = 1) -> float:
    """Wall seconds per simulated second of growing ``design`` in the scene ``spec`` at a
    constant ``pressure_pa`` for ``sim_s`` seconds (best of ``repeats``); with ``render``, an
    RGB frame of the scene and robot (``render_rgb``) every control period, as a viewer would."""
    best = math.inf
    for _ in range(repeats):
        scene = make_scene(spec)
        sim = EversionSim(design, scene=scene, config=config)
        sim.set_pressure_command(pressure_pa)
        t0 = time.perf_counter()
        for _ in range(int(round(sim_s / CONTROL_PERIOD_S))):
            sim.run(CONTROL_PERIOD_S)
            if render:
                render_rgb(scene, sim.centreline(), robot_radius=design.radius_m, handles=sim.scene_handles)
        best = min(best, (time.perf_counter() - t0) / sim.t)
    return best


def ubend_growth_cost(config: SimConfig) -> float:
    """``wall_s_per_sim_s`` of the timed U-bend growth run (module docstring)."""
    spec = {"family": "ubend", "params": {"radius_mm": TIMING_RADIUS_MM}}
    return growth_cost(config, spec, TubeDesign(length_m=ROBOT_LENGTH_M), TIMING_PRESSURE_PA, TIMING_SIM_S,
                       repeats=TIMING_REPEATS)


# ---- the sweep --------------------------------------------------------------------------
#: Relative difference below which two measurements count as equal (timing noise, and
#: tensile forces that differ in the last digits between settings with the same statics).
PARETO_RTOL = 1e-3


def pareto_flags(rows: Sequence[Mapping], keys: Sequence[str], rtol: float = PARETO_RTOL) -> list[bool]:
    """Whether each row is Pareto-optimal: no other row is at least as good (lower) in every
    one of ``keys`` and better in one, values within ``rtol`` of each other counting as equal."""

    def better(x: float, y: float) -> bool:
        return x < y - rtol * max(abs(x), abs(y))

    flags = []
    for a in rows:
        dominated = any(
            not any(better(a[k], b[k]) for k in keys) and any(better(b[k], a[k]) for k in keys)
            for b in rows if b is not a
        )
        flags.append(not dominated)
    return flags


def measure_setting(setting: SweepSetting, refs: Mapping, trials: Sequence, reference_outcomes: Sequence[str] | None,
                    quasistatic_outcomes: Sequence[str] | None = None) -> dict:
    """One row of the sweep (see the module docstring); ``reference_outcomes`` None means
    this setting is the reference itself; ``quasistatic_outcomes`` (the quasi-static engine's
    outcomes of ``trials``) adds ``ubend_disagreement_quasistatic``."""
    config = setting.config()
    row: dict = {"label": setting.label, "setting": setting.fidelity()}
    row.update(tensile_errors(config, refs))
    outcomes = [ubend_outcome(config, r, bands, p) for r, bands, p in trials]
    ref = outcomes if reference_outcomes is None else reference_outcomes
    row["ubend_disagreement"] = sum(a != b for a, b in zip(outcomes, ref)) / len(outcomes)
    row["ubend_outcomes"] = outcomes
    if quasistatic_outcomes is not None:
        row["ubend_disagreement_quasistatic"] = sum(a != b for a, b in zip(outcomes, quasistatic_outcomes)) / len(outcomes)
    row["wall_s_per_sim_s"] = ubend_growth_cost(config)
    row["wall_overlap_mm"] = wall_overlap_mm(config)
    row["colon_peak_force_n"] = colon_peak_force_n(config)
    return row


def run_sweep(settings: Sequence[SweepSetting] | None = None, quick: bool = False,
              done: Mapping[str, dict] | None = None, on_row: Callable[[dict], None] | None = None) -> dict:
    """Measure every setting and choose the default.

    ``settings`` defaults to :func:`default_settings`; the first is the reference for the
    U-bend outcomes.  ``done`` maps labels to rows already measured (a resumed sweep reuses
    them); ``on_row`` is called with each new row as soon as it is measured.

    Returns ``{"rows": [...], "default": {...}, "reference": label, "quasistatic_outcomes":
    [...], "ubend_trials": [...], "quick": bool}``.  Each row holds ``label``, ``setting`` (the fidelity fields, SI),
    ``tip_force_error``, ``tip_pose_error_mm``, ``ubend_disagreement``, ``wall_s_per_sim_s``,
    ``tensile_converged``, ``ubend_outcomes`` and ``pareto`` (Pareto-optimal in wall time,
    force error and U-bend disagreement), ``wall_overlap_mm`` (see :func:`wall_overlap_mm`) and
    ``colon_peak_force_n`` (see :func:`colon_peak_force_n`; reported, not used to choose).
    ``default`` is the fastest row whose tensile tests converged with ``tip_force_error <=
    0.03`` and whose tube never passed into a wall (``wall_overlap_mm == 0``), with
    ``equals_simconfig_default`` telling whether it is the current :class:`SimConfig` default.
    """
    settings = list(settings if settings is not None else default_settings(quick))
    done = dict(done or {})
    trials = ubend_trials(quick)
    refs = rod_references()
    qs_outcomes: list[str] | None = None  # measured once, when a setting is (a resumed sweep may need none)
    rows: list[dict] = []
    for i, setting in enumerate(settings):
        if setting.label in done:
            row = done[setting.label]
        else:
            if qs_outcomes is None:
                qs_config = SimConfig(engine="quasistatic")
                qs_outcomes = [ubend_outcome(qs_config, r, bands, p) for r, bands, p in trials]
            row = measure_setting(setting, refs, trials, None if i == 0 else rows[0]["ubend_outcomes"], qs_outcomes)
            if on_row is not None:
                on_row(row)
        rows.append(row)
    for row, flag in zip(rows, pareto_flags(rows, ("wall_s_per_sim_s", "tip_force_error", "ubend_disagreement"))):
        row["pareto"] = flag
    eligible = [r for r in rows if r["tensile_converged"] and r["tip_force_error"] <= FORCE_ERROR_BUDGET
                and r.get("wall_overlap_mm", 0.0) <= 0.0]
    current = {name: getattr(SimConfig(engine="dynamic"), name) for name in FIDELITY_FIELDS}
    default: dict = {"simconfig_default": current, "budget": FORCE_ERROR_BUDGET}
    if eligible:
        best = min(eligible, key=lambda r: r["wall_s_per_sim_s"])
        default.update({k: best[k] for k in ("label", "setting", "tip_force_error", "tip_pose_error_mm",
                                             "ubend_disagreement", "wall_s_per_sim_s")})
        default["equals_simconfig_default"] = best["setting"] == current
    return {
        "rows": rows,
        "default": default,
        "reference": settings[0].label,
        "quasistatic_outcomes": qs_outcomes,
        "ubend_trials": [{"radius_mm": r, "bands": [list(b) for b in bands], "pressure_kpa": p / 1e3}
                         for r, bands, p in trials],
        "quick": quick,
    }


# ---- skip what a scene does not need ------------------------------------------------------
def skip_costs(quick: bool = False) -> list[dict]:
    """Cost of what a scene may skip, each as ``{"topic", "variant", "wall_s_per_sim_s",
    "ratio"}`` (``ratio``: against the first variant of the topic, the simulator's default):

    * active set: a long robot (2 m; 1 m with ``quick``) grown at 3 kPa to full length
      through a 90-degree bend in a long pipe, with the default active window against one
      longer than the robot (every segment stays dynamic);
    * walls: the 20 mm robot at 4 kPa in the colon phantom with compliant walls (the
      default) against the same channel with ``compliant: false``;
    * rendering: the U-bend growth run with no rendering against an RGB frame
      (``render_rgb``, 480 x 480) every 0.1 s.
    """
    length = 1.0 if quick else 2.0
    long_scene = {"family": "bend", "params": {"angle_deg": 90.0, "radius_mm": 60.0, "lead_in_mm": 100.0,
                                                "lead_out_mm": length * 1e3 + 100.0, "goal_after_bend_mm": 50.0}}
    grow_s = length / 0.1 + 4.0  # full length at the largest growth speed, and a little more
    colon_s = 4.0 if quick else 10.0
    render_s = 1.0 if quick else 3.0
    default = SimConfig(engine="dynamic")  # the engine whose active set, walls and rendering these rows time
    cases = [
        ("active set", f"active_length_m = {default.active_length_m:g} (default), {length:g} m robot",
         lambda: growth_cost(default, long_scene, TubeDesign(length_m=length), 3000.0, grow_s)),
        ("active set", f"active_length_m = 100 (no freezing), {length:g} m robot",
         lambda: growth_cost(replace(default, active_length_m=100.0), long_scene, TubeDesign(length_m=length), 3000.0, grow_s)),
        ("walls", "colon, compliant walls (default)",
         lambda: growth_cost(default, {"family": "colon", "params": {}},
                             TubeDesign(diameter_m=0.02, length_m=0.6), 4000.0, colon_s)),
        ("walls", "colon, compliant: false (static walls)",
         lambda: growth_cost(default, {"family": "colon", "params": {"compliant": False}},
                             TubeDesign(diameter_m=0.02, length_m=0.6), 4000.0, colon_s)),
        ("rendering", "U-bend, no rendering (default)",
         lambda: growth_cost(default, {"family": "ubend", "params": {"radius_mm": TIMING_RADIUS_MM}},
                             TubeDesign(length_m=ROBOT_LENGTH_M), TIMING_PRESSURE_PA, render_s)),
        ("rendering", "U-bend, render_rgb every 0.1 s",
         lambda: growth_cost(default, {"family": "ubend", "params": {"radius_mm": TIMING_RADIUS_MM}},
                             TubeDesign(length_m=ROBOT_LENGTH_M), TIMING_PRESSURE_PA, render_s, render=True)),
    ]
    out: list[dict] = []
    first: dict[str, float] = {}
    for topic, variant, measure in cases:
        cost = measure()
        first.setdefault(topic, cost)
        out.append({"topic": topic, "variant": variant, "wall_s_per_sim_s": cost, "ratio": cost / first[topic]})
    return out
