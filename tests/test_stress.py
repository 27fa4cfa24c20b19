"""Numerical stress tests of the eversion simulator: random designs, scenes and pressures.

Every example draws a design (diameter 20 or 40 mm, length 0.3-1.0 m, 0-6 bands of
reduction 0-0.5 placed anywhere the design's own validation admits), a scene (straight,
U-bend of inner radius 20-40 mm, bend, S-bend, seeded tortuous channel, or a seeded
colon-like channel with compliant walls) whose bends start within the first 100 mm so that
a short run reaches them, and a pressure command sequence (steps anywhere in 0-8 kPa,
sinusoids, holds at 8 kPa) applied every 0.1 s with ``sim.set_pressure_command`` and
``sim.run(0.1)``.  After every 0.1 s it checks:

* finiteness: every centreline node, the pressure (and that it stays in 0-8 kPa), the tip
  force and the tip contact force;
* walls (rigid scenes): each node's distance to the wall surface is at least the local tube
  radius minus :data:`BODY_TOLERANCE_M` (1 mm, contact slop) or, for the tip node,
  :data:`TIP_TOLERANCE_M` (2 mm: the tip everts into contact geometrically and the contact
  resolves 20% of an overlap per step, about 1 mm at full growth speed); each node's centre
  is inside the lumen and projects onto the channel, ``0 <= s <= scene.length``;
* compliant walls (colon): the wall pieces stay finite and move no farther from rest than
  their tether allows (``wall_travel_mm``) plus :data:`BODY_TOLERANCE_M`;
* calm dynamics: no robot body moves faster than :data:`MAX_SPEED_M_PER_S` (the masses are
  scaled for a quasi-static answer; 10x the largest growth speed is an artefact);
* failure mode: the run either completes or raises ``NumericalInstabilityError`` whose
  message names a setting to change (``dt_s``, ``inertia_factor`` or ``iterations``);
  anything else fails the test.

A second property holds the pressure at 8 kPa on a short robot in a rigid scene until it
stops growing (full length or stall) and 4 s more: its kinetic energy must not grow over
those 4 s.  Compliant scenes are left out of it: there a stalled robot advances in jerks
whenever the tethered wall creeps back (see the tether test at the end), so its energy
comes in bursts; their speeds are still bounded by the first property.

The default run draws 10 examples per family and 3 per rigid family for the hold (about
10 s when nothing fails; shrinking a failure takes longer); ``-m slow`` draws 2200 (about
6 minutes) and runs a 10-simulated-minute memory test on a rigid and a compliant scene.
Examples are derandomized (the same ones every run, from a hash of the test) and no example
database is kept, so CI sees exactly what a developer sees.  Statistics per family:
``--hypothesis-show-statistics``.

Defects.  The regression tests at the end reproduce the simulator defects these properties
found (see their docstrings); all are fixed, and each test keeps its reproduction.
"""

from __future__ import annotations

import gc
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import psutil
import pymunk
import pytest
from hypothesis import HealthCheck, assume, event, given, reject, settings
from hypothesis import strategies as st

from evertgym.design import Band, DesignError, TubeDesign
from evertgym.model.eversion import MAX_GROWTH_SPEED_M_PER_S
from evertgym.scenes import Scene, SceneError, make_scene
from evertgym.sim import EversionSim, NumericalInstabilityError, SimConfig
from evertgym.sim.growth import MAX_PRESSURE_PA

#: The dynamic pymunk chain, whose bodies, kinetic energy and rest lock most of these tests check
#: (the quasi-static engine has no bodies to move: tests/test_quasistatic.py).
DYNAMIC = SimConfig(engine="dynamic")
#: Control period (s): the pressure command is updated and the state checked this often.
CONTROL_PERIOD_S = 0.1
#: Contact tolerance (m) for every centreline node but the tip's.
BODY_TOLERANCE_M = 1e-3
#: Contact tolerance (m) for the tip node (see the module docstring).
TIP_TOLERANCE_M = 2e-3
#: Largest admissible speed (m/s) of any robot body: 10x the largest growth speed (1 m/s).
MAX_SPEED_M_PER_S = 10.0 * MAX_GROWTH_SPEED_M_PER_S
#: Seconds the hold property keeps 8 kPa after growth stopped.
HOLD_AFTER_STOP_S = 4
#: Settings a ``NumericalInstabilityError`` must name.
INSTABILITY_SETTINGS = re.compile(r"\b(dt_s|inertia_factor|iterations)\b")

RIGID_FAMILIES = ("straight", "ubend", "bend", "sbend", "tortuous")
FAMILIES = RIGID_FAMILIES + ("colon",)

_COMMON = dict(deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])
FAST = settings(max_examples=10, **_COMMON)
FAST_HOLD = settings(max_examples=3, **_COMMON)
#: 6 x 300 + 5 x 80 = 2200 examples in the slow suite.
SLOW = settings(max_examples=300, **_COMMON)
SLOW_HOLD = settings(max_examples=80, **_COMMON)


# ---- strategies ---------------------------------------------------------------------
def quantities(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Scene parameters (mm or degrees) in [lo, hi] at a resolution of 0.001.

    Rounding keeps hypothesis from drawing subnormal lengths, which break the scene layer
    itself (see :func:`test_a_vanishing_straight_still_builds_finite_walls`); the properties
    here are about the simulator.
    """
    return st.floats(lo, hi).map(lambda v: round(v, 3))


@st.composite
def designs(draw, diameters_m: tuple[float, ...] = (0.02, 0.04), length_m: tuple[float, float] = (0.3, 1.0)) -> TubeDesign:
    """A tube of the given diameters (m) and length range (m) with 0-6 bands of reduction 0-0.5.

    Band centres are drawn anywhere along the body; a band the design's validation rejects
    (its strip overlapping another's) is dropped, so the bands kept are exactly the valid ones.
    """
    diameter = draw(st.sampled_from(diameters_m))
    length = draw(st.floats(*length_m))
    bands: list[Band] = []
    for _ in range(draw(st.integers(0, 6))):
        band = Band(draw(st.floats(0.0075, length - 0.0075)), draw(st.floats(0.0, 0.5)))
        try:
            TubeDesign(diameter_m=diameter, length_m=length, bands=(*bands, band))
        except DesignError:
            continue
        bands.append(band)
    return TubeDesign(diameter_m=diameter, length_m=length, bands=tuple(bands))


@st.composite
def scene_specs(draw, family: str, design: TubeDesign) -> dict:
    """A scene spec (mm, degrees) of ``family`` longer than ``design`` by at least 100 mm.

    The first bend starts within 100 mm of the entry so that a few seconds of growth reach
    it.  Colon scenes are the procedural variants (anatomy drawn from the seed) with the
    bend pinned 100-250 mm from the entry; their walls are compliant.
    """
    room_mm = design.length_m * 1e3 + 100.0
    lead_mm = draw(quantities(0.0, 100.0))
    seed = 0
    if family == "straight":
        params = {"length_mm": room_mm}
    elif family == "ubend":
        params = {"radius_mm": draw(quantities(20.0, 40.0)), "pipe_length_mm": lead_mm, "exit_length_mm": room_mm}
    elif family == "bend":
        params = {"angle_deg": draw(quantities(10.0, 180.0)), "radius_mm": draw(quantities(20.0, 100.0)),
                  "turn": draw(st.sampled_from(("left", "right"))), "lead_in_mm": lead_mm, "lead_out_mm": room_mm}
    elif family == "sbend":
        params = {"angle_deg": draw(quantities(10.0, 120.0)), "radius_mm": draw(quantities(20.0, 100.0)),
                  "middle_mm": draw(quantities(0.0, 100.0)), "turn": draw(st.sampled_from(("left", "right"))),
                  "lead_in_mm": lead_mm, "lead_out_mm": room_mm}
    elif family == "tortuous":
        params = {"robot_diameter_mm": design.diameter_m * 1e3, "lead_in_mm": lead_mm, "lead_out_mm": room_mm}
        seed = draw(st.integers(0, 2**31 - 1))
    elif family == "colon":
        bend_at = draw(quantities(100.0, 250.0))
        params = {"variant": True, "bend_at_mm": bend_at, "length_mm": max(room_mm, bend_at + 400.0)}
        seed = draw(st.integers(0, 2**31 - 1))
    else:
        raise ValueError(f"family = {family!r} is not one of {FAMILIES}")
    return {"family": family, "params": params, "seed": seed}


@st.composite
def pressure_sequences(draw, n_ticks: int) -> list[float]:
    """``n_ticks`` pressure commands (Pa), one per control period, from random pieces:
    steps to a level in [0, 8] kPa, sinusoids (mean 0-8 kPa, amplitude up to 4 kPa, clipped
    to [0, 8] kPa, period 0.2-2 s) and holds at 8 kPa."""
    out: list[float] = []
    while len(out) < n_ticks:
        kind = draw(st.sampled_from(("step", "sine", "hold")))
        ticks = draw(st.integers(1, 20))
        if kind == "step":
            out += [draw(st.floats(0.0, MAX_PRESSURE_PA))] * ticks
        elif kind == "sine":
            mean, amp = draw(st.floats(0.0, MAX_PRESSURE_PA)), draw(st.floats(0.0, 4000.0))
            period = draw(st.floats(0.2, 2.0))
            out += [min(max(mean + amp * math.sin(2 * math.pi * k * CONTROL_PERIOD_S / period), 0.0), MAX_PRESSURE_PA)
                    for k in range(ticks)]
        else:
            out += [MAX_PRESSURE_PA] * (ticks + 10)
    return out[:n_ticks]


@dataclass
class Scenario:
    """One stress example: a design, a scene spec and one pressure command (Pa) per 0.1 s."""

    design: TubeDesign
    spec: dict
    commands: list[float]


@st.composite
def scenarios(draw, family: str, duration_s: tuple[float, float]) -> Scenario:
    """A random :class:`Scenario` in ``family`` lasting ``duration_s`` (s, range)."""
    design = draw(designs(diameters_m=(0.02,) if family == "colon" else (0.02, 0.04)))
    spec = draw(scene_specs(family, design))
    n_ticks = draw(st.integers(int(round(duration_s[0] / CONTROL_PERIOD_S)), int(round(duration_s[1] / CONTROL_PERIOD_S))))
    return Scenario(design, spec, draw(pressure_sequences(n_ticks)))


# ---- checks -------------------------------------------------------------------------
def build(spec: dict) -> Scene:
    """The scene of ``spec``; specs whose random channel cannot be made are rejected."""
    try:
        return make_scene(spec)
    except SceneError:
        reject()


def robot_speed(sim: EversionSim) -> float:
    """Largest speed (m/s) of any point of an active robot segment (centre speed plus ``|omega| ds``)."""
    return max(math.hypot(*b.velocity) + abs(b.angular_velocity) * sim.ds for b in sim.bodies[sim.active_start:])


def kinetic_energy(sim: EversionSim) -> float:
    """Kinetic energy of the active robot segments (J, with the simulator's scaled masses)."""
    return sum(0.5 * b.mass * b.velocity.dot(b.velocity) + 0.5 * b.moment * b.angular_velocity**2
               for b in sim.bodies[sim.active_start:])


def check_state(sim: EversionSim, scene: Scene) -> None:
    """The invariants of the module docstring, at the current instant."""
    line = sim.centreline()
    assert np.all(np.isfinite(line)), "non-finite centreline"
    assert math.isfinite(sim.pressure) and -1e-9 <= sim.pressure <= MAX_PRESSURE_PA + 1e-9, f"pressure {sim.pressure!r} Pa"
    assert math.isfinite(sim.tip_force) and sim.tip_force >= 0.0, f"tip force {sim.tip_force!r} N"
    assert np.all(np.isfinite(sim.tip_contact)), "non-finite tip contact force"
    speed = robot_speed(sim)
    assert speed < MAX_SPEED_M_PER_S, f"a robot body moves at {speed:.3g} m/s at t = {sim.t:.2f} s"
    if scene.compliant:
        walls = sim.scene_handles.positions()
        assert np.all(np.isfinite(walls)), "non-finite compliant wall"
        moved = sim.scene_handles.wall_displacement()
        limit = scene.mechanics.max_travel_m + BODY_TOLERANCE_M
        assert moved <= limit, (f"a compliant wall piece moved {moved * 1e3:.2f} mm, past its tether "
                                f"({scene.mechanics.max_travel_m * 1e3:g} mm + 1 mm) at t = {sim.t:.2f} s")
        return
    nodes, radii = line[1:], sim.radii()
    tol = np.full(len(radii), BODY_TOLERANCE_M)
    tol[-1] = TIP_TOLERANCE_M
    gap = scene.wall_distance(nodes) - (radii - tol)
    worst = int(np.argmin(gap))
    assert gap[worst] >= 0.0, (
        f"node {worst + 1}/{len(nodes)} (r = {radii[worst] * 1e3:.1f} mm) overlaps the wall by "
        f"{(radii[worst] - scene.wall_distance(nodes)[worst]) * 1e3:.2f} mm at t = {sim.t:.3f} s, length {sim.length:.4f} m"
    )
    s, e = scene.project(nodes)
    assert np.all(s >= 0.0) and np.all(s <= scene.length), "a node projects outside the channel"
    assert np.all(np.abs(e) <= 0.5 * scene.lumen_at(s)), "a node's centre left the lumen (tunnelled)"


def run_checked(sim: EversionSim, scene: Scene, commands: list[float],
                on_tick: Callable[[EversionSim], None] | None = None) -> bool:
    """Apply one command per control period, checking the state after each; False if the
    simulator raised ``NumericalInstabilityError`` (naming a setting, as it must)."""
    for command in commands:
        sim.set_pressure_command(command)
        try:
            sim.run(CONTROL_PERIOD_S)
        except NumericalInstabilityError as err:
            assert INSTABILITY_SETTINGS.search(str(err)), f"instability message names no setting: {err}"
            event("NumericalInstabilityError")
            return False
        check_state(sim, scene)
        if on_tick is not None:
            on_tick(sim)
    return True


def check_scenario(sc: Scenario) -> None:
    """Build the scenario's scene and robot and run its pressure sequence, checking every 0.1 s."""
    scene = build(sc.spec)
    event(f"bands: {len(sc.design.bands)}")
    sim = EversionSim(sc.design, scene=scene, config=DYNAMIC)
    check_state(sim, scene)
    run_checked(sim, scene, sc.commands)


def check_hold(design: TubeDesign, spec: dict) -> None:
    """Hold 8 kPa until growth stops (full length or stall, at most 8 s), then 4 s more: the
    largest kinetic energy of the last of those seconds may not exceed that of the first, up
    to a floor (the tip segment moving at 1 mm/s)."""
    scene = build(spec)
    sim = EversionSim(design, scene=scene, config=DYNAMIC)
    energies: list[float] = []
    stopped_at: list[int] = []

    def on_tick(s: EversionSim) -> None:
        energies.append(kinetic_energy(s))
        if not stopped_at and (s.length >= design.length_m - 1e-9 or s.stalled):
            stopped_at.append(len(energies))

    ticks_per_s = int(round(1.0 / CONTROL_PERIOD_S))
    while not stopped_at and sim.t < 8.0:
        if not run_checked(sim, scene, [MAX_PRESSURE_PA] * ticks_per_s, on_tick):
            return
    full = sim.length >= design.length_m - 1e-9
    event("stopped: full length" if full else "stopped: stall" if stopped_at else "still growing at 8 s")
    assume(stopped_at)
    k = stopped_at[0]
    if not run_checked(sim, scene, [MAX_PRESSURE_PA] * (k + HOLD_AFTER_STOP_S * ticks_per_s - len(energies)), on_tick):
        return
    first, last = max(energies[k:k + ticks_per_s]), max(energies[-ticks_per_s:])
    floor = 0.5 * sim.bodies[-1].mass * 1e-3**2
    assert last <= first + floor, f"kinetic energy grew over the hold: {first:.3g} -> {last:.3g} J (scaled masses)"


# ---- the properties: fast (default) and slow ------------------------------------------
def hold_case(data: st.DataObject, family: str) -> tuple[TubeDesign, dict]:
    """A short robot (0.3-0.4 m, so that it stops growing within a few seconds) and a rigid scene."""
    design = data.draw(designs(length_m=(0.3, 0.4)))
    return design, data.draw(scene_specs(family, design))


@pytest.mark.parametrize("family", FAMILIES)
@FAST
@given(data=st.data())
def test_random_runs_stay_finite_inside_and_calm(family, data):
    check_scenario(data.draw(scenarios(family, (1.0, 2.0))))


@pytest.mark.parametrize("family", RIGID_FAMILIES)
@FAST_HOLD
@given(data=st.data())
def test_kinetic_energy_does_not_grow_over_a_hold_at_8kpa(family, data):
    check_hold(*hold_case(data, family))


@pytest.mark.slow
@pytest.mark.parametrize("family", FAMILIES)
@SLOW
@given(data=st.data())
def test_random_runs_stay_finite_inside_and_calm_slow(family, data):
    check_scenario(data.draw(scenarios(family, (1.0, 3.0))))


@pytest.mark.slow
@pytest.mark.parametrize("family", RIGID_FAMILIES)
@SLOW_HOLD
@given(data=st.data())
def test_kinetic_energy_does_not_grow_over_a_hold_at_8kpa_slow(family, data):
    check_hold(*hold_case(data, family))


# ---- memory ---------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize(
    "spec, design",
    [
        ({"family": "ubend", "params": {"radius_mm": 35.0}},
         TubeDesign(length_m=0.9, bands=(Band(0.2, 0.1), Band(0.25, 0.1), Band(0.3, 0.1)))),
        ({"family": "colon", "params": {}}, TubeDesign(diameter_m=0.02, length_m=0.6)),
    ],
    ids=["ubend", "colon"],
)
def test_ten_simulated_minutes_do_not_grow_memory(spec, design):
    """10 simulated minutes with the pressure cycling 1-8 kPa (period 6 s): after a 2-minute
    warm-up (the robot reaches full length) the resident set size, sampled after a garbage
    collection at each simulated minute, grows by less than 2 MiB in all."""
    scene = make_scene(spec)
    sim = EversionSim(design, scene=scene)
    proc = psutil.Process()
    rss: list[int] = []
    for minute in range(10):
        for _ in range(int(round(60.0 / CONTROL_PERIOD_S))):
            sim.set_pressure_command(4500.0 + 3500.0 * math.sin(2.0 * math.pi * sim.t / 6.0))
            sim.run(CONTROL_PERIOD_S)
        assert np.all(np.isfinite(sim.centreline()))
        gc.collect()
        if minute >= 1:
            rss.append(proc.memory_info().rss)
    growth = max(rss) - rss[0]
    assert growth < 2 * 2**20, f"RSS grew by {growth / 2**20:.2f} MiB over 8 simulated minutes: {[r // 2**10 for r in rss]} KiB"


# ---- the defects these properties found: reproductions and regression tests --------------


def joint_gaps(sim: EversionSim) -> np.ndarray:
    """Distance (m) from each segment's origin to where its joint holds it: the base for the
    first, the end of the previous segment's axis for the others."""
    ends = [np.asarray(b.local_to_world((sh.b.x, 0.0))) for b, sh in zip(sim.bodies[:-1], sim.shapes[:-1])]
    anchors = [np.asarray(sim.base)] + ends
    origins = [np.asarray(b.local_to_world((0.0, 0.0))) for b in sim.bodies]
    return np.array([np.hypot(*(o - a)) for o, a in zip(origins, anchors)])


def segment_offset_m(heading_deg: float) -> float:
    """Largest joint gap (m) of a robot growing towards ``heading_deg``, at construction and
    right after its first split."""
    a = math.radians(heading_deg)
    sim = EversionSim(TubeDesign(), direction=(math.cos(a), math.sin(a)), config=DYNAMIC)
    worst = float(np.max(joint_gaps(sim)))
    n = len(sim.bodies)
    sim.set_pressure_command(3000.0)
    while len(sim.bodies) == n:
        sim.step(1)
    return max(worst, float(joint_gaps(sim)[-1]))


def band_exit_overlap_m() -> float:
    """Largest wall overlap (m) beyond the contact tolerances, checked every step, of a 40 mm
    robot with a 50% band at 90 mm growing at 8 kPa into a 90-degree bend (1.5 s)."""
    scene = make_scene({"family": "bend", "params": {"angle_deg": 90.0, "radius_mm": 30.0, "lead_in_mm": 50.0}})
    sim = EversionSim(TubeDesign(length_m=0.4, bands=(Band(0.09, 0.5),)), scene=scene)
    sim.set_pressure_command(8000.0)
    worst = 0.0
    while sim.t < 1.5:
        sim.step(1)
        nodes = sim.centreline()[1:]
        tol = np.full(len(nodes), BODY_TOLERANCE_M)
        tol[-1] = TIP_TOLERANCE_M
        worst = max(worst, float(np.max(sim.radii() - scene.wall_distance(nodes) - tol)))
    return worst


def tether_overshoot_m() -> float:
    """Largest excursion (m) of a compliant colon wall piece beyond its tether (8 mm) while
    the 20 mm robot pushes into the bend at 8 kPa (3 s)."""
    scene = make_scene({"family": "colon", "params": {"variant": True, "bend_at_mm": 221.9, "length_mm": 1100.0},
                        "seed": 584160037})
    sim = EversionSim(TubeDesign(diameter_m=0.02, length_m=1.0), scene=scene)
    sim.set_pressure_command(8000.0)
    worst = 0.0
    while sim.t < 3.0:
        sim.run(CONTROL_PERIOD_S)
        worst = max(worst, sim.scene_handles.wall_displacement())
    return worst - scene.mechanics.max_travel_m


def stalled_robot(pressure_pa: float) -> EversionSim:
    """A 40 mm robot growing at ``pressure_pa`` into a tortuous channel's first bend, where it stalls."""
    scene = make_scene({"family": "tortuous", "params": {"robot_diameter_mm": 40.0, "lead_in_mm": 79.0,
                                                        "lead_out_mm": 475.0}, "seed": 0})
    sim = EversionSim(TubeDesign(length_m=0.375), scene=scene, config=DYNAMIC)
    sim.set_pressure_command(pressure_pa)
    return sim


def drift_after_rest() -> tuple[float, float]:
    """(time the rest lock engaged (s), inf if never; largest node displacement (m) after it)
    of a robot stalled at a constant 8 kPa, up to t = 10 s."""
    sim = stalled_robot(8000.0)
    rested_at, line, drift = math.inf, None, 0.0
    while sim.t < 10.0:
        sim.step(1)
        if sim.at_rest and line is None:
            rested_at, line = sim.t, sim.centreline()
        if line is not None:
            now = sim.centreline()
            drift = max(drift, float(np.max(np.hypot(*(now[: len(line)] - line).T))))
    return rested_at, drift


@pytest.mark.parametrize("heading_deg", [30.0, 90.0, 180.0])
def test_every_new_segment_starts_on_its_joint(heading_deg):
    """A segment is created where its joint holds it, in every growth direction.

    Fixed defect, kept as a regression test: ``DynamicSim._add_segment`` set ``body.angle`` after ``body.position`` on a
    body whose centre of gravity is offset (``ds / 2``); pymunk keeps the centre of gravity
    fixed when the angle changes, so the origin (the pivot) lands ``ds |sin(theta / 2)|``
    away (7.5 mm at theta = 180 deg), and the joint snaps it back over the next steps: every
    split of a tip not heading along +x kicks the tip, into the walls in a bend.
    """
    assert segment_offset_m(heading_deg) < 1e-6


def test_a_segment_along_x_starts_on_its_joint():
    """The control case of the defect above: growing along +x there is no offset."""
    assert segment_offset_m(0.0) < 1e-6


def test_tip_stays_out_of_the_wall_after_a_band_has_everted():
    """A 50% band everting in a 90-degree bend: the tip keeps out of the wall.

    Fixed defect, kept as a regression test: the tip segment's collision radius is set when the segment is created (from its
    first ``ds`` of material) and not updated while it lengthens to ``2 ds``.  Once a band's
    strip has everted, the tip keeps the band's radius while bare material grows, and sits
    up to ``rho r`` closer to the wall than a bare tube could; at the next split the new tip
    segment appears at the bare radius, overlapping the wall by up to ``rho r`` (9 mm beyond
    the tolerance here), with a tip-force spike while the contact pushes it out.  The tip's
    radius now follows its newest ``ds`` of material and widens by at most ``dl / 2`` per
    step (``DynamicSim._tip_radius``).
    """
    assert band_exit_overlap_m() <= 0.0


def test_a_pushed_colon_wall_stops_at_its_tether():
    """The 20 mm robot pushing into the colon's bend at 8 kPa: no wall piece moves farther
    than ``wall_travel_mm`` (8 mm) from rest, up to 1 mm.

    Fixed defect, kept as a regression test: ``WallNetwork.build`` made each tether a ``pymunk.SlideJoint`` with the default
    ``error_bias`` (10% of the error per 1/60 s, about 0.35% per 2 ms step), so a loaded
    piece overshoots its travel by up to 5 mm (13 mm here) and creeps back over seconds,
    letting the robot advance in jerks meanwhile.
    """
    assert tether_overshoot_m() <= BODY_TOLERANCE_M


def test_a_stalled_robot_at_rest_stays_at_rest():
    """A 40 mm robot stalled against a tortuous channel's first bend at a constant 8 kPa
    comes to rest and stays exactly there.

    Fixed defect, kept as a regression test: the stalled robot kept creeping at about 1 nm
    per step (Coulomb friction in Chipmunk's iterative solver never sticks exactly) until a
    contact that carried no load engaged; the contact forces then redistributed in one step,
    the robot kicked (kinetic energy 1e-16 -> 2e-5 J at t = 5.63 s) and settled with a
    different tip force (16.0 -> 12.8 N), which the growth law reads as the load on the tip.
    The rest lock (``SimConfig.rest_speed_m_per_s``) now holds a stalled robot whose bodies
    all move slower than 10 um/s.
    """
    rested_at, drift = drift_after_rest()
    assert rested_at < 5.0, "the stalled robot never came to rest"
    assert drift == 0.0


def test_the_rest_lock_releases_when_the_pressure_rises():
    """A robot held at rest at 3 kPa moves again (and grows on) once the command is 8 kPa;
    with the lock disabled the robot never reports rest."""
    sim = stalled_robot(3000.0)
    while not sim.at_rest and sim.t < 6.0:
        sim.step(1)
    assert sim.at_rest, "the stalled robot never came to rest at 3 kPa"
    length, force = sim.length, sim.tip_force
    sim.set_pressure_command(8000.0)
    sim.run(0.5)
    assert not sim.at_rest
    assert sim.tip_force > 1.5 * force or sim.length > length + 0.005
    free = EversionSim(TubeDesign(length_m=0.375), config=SimConfig(engine="dynamic", rest_speed_m_per_s=0.0),
                       scene=sim.scene)
    free.set_pressure_command(3000.0)
    free.run(4.0)
    assert free.stalled and not free.at_rest


def colon_escape_m() -> float:
    """Largest distance (m) the 20 mm robot's surface reaches beyond the colon wall at its full
    travel plus a wall thickness, over the paper's banded case study (operator protocol)."""
    from evertgym.agents.policies import make_policy
    from evertgym.experiments.paper import colon_specs
    from evertgym.experiments.trial import make_trial_env

    spec = colon_specs()[1]
    env = make_trial_env(spec)
    policy = make_policy(dict(spec.policy))
    obs, info = env.reset(seed=0)
    policy.reset(env)
    mech = env.scene.wall_network().mechanics
    worst = -math.inf
    while env.sim.t < 20.0:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        nodes = env.sim.centreline()[1:]
        s, off = env.scene.project(nodes)
        bound = 0.5 * env.scene.lumen_at(s) + mech.max_travel_m + mech.thickness_m
        worst = max(worst, float(np.max(np.abs(off) + env.sim.radii() - bound)))
        if term or trunc:
            break
    return worst


def test_the_robot_stays_inside_a_pushed_colon_wall():
    """The banded robot pushed into the colon's bend up to 8 kPa stays inside the channel.

    Fixed defect, kept as a regression test: a wall piece pushed at one end turns about its
    tether, two turned neighbours opened a gap at the bend's outer corner, and the robot
    grew out through it into open space (reported as "passed" by ``reproduce colon``).  The
    scene now adds a static backstop behind compliant walls (``Scene._build_backstop``).
    """
    assert colon_escape_m() <= BODY_TOLERANCE_M


def test_a_vanishing_straight_still_builds_finite_walls():
    """A lead-in of 1e-200 mm passes validation (the range is [0, 3000] mm) and must build
    walls as 0 mm does.

    Fixed defect, kept as a regression test: ``polyline_normals`` normalised a segment whose squared length underflows to 0
    (lengths below about 1e-154 m), so the wall shell gets NaN points and every static wall
    segment built into the space is non-finite: the robot then grows through the channel's
    walls as if in open space.
    """
    for lead_mm in (0.0, 1e-200):
        scene = make_scene({"family": "bend", "params": {"lead_in_mm": lead_mm}})
        handles = scene.build(pymunk.Space())
        ends = np.array([(sh.a.x, sh.a.y, sh.b.x, sh.b.y) for sh in handles.shapes])
        assert len(ends) > 2 and np.all(np.isfinite(ends)), f"lead_in_mm = {lead_mm}: {len(ends)} wall segments"
