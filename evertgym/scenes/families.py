"""Scene families and :func:`make_scene`.

Rigid families (walls are static segments of radius 1 mm; "radius" is always the radius of
the bend's *inner wall*, the wall the robot wraps around, so the centreline radius is
``radius + lumen / 2``):

* ``straight``: a straight pipe.
* ``ubend``: the paper's validation rig (Sec. IV-E): a pipe of 55 mm internal diameter
  leading into a 180-degree U-bend with bending radius 20-40 mm (tested from 40 down to 20 in
  2.5 mm steps: :data:`PAPER_UBEND_RADII_MM`), then a straight exit; goal 60 mm past the bend.
* ``bend``: one bend of any angle in (0, 180] degrees and any radius.
* ``sbend``: two opposite bends joined by a straight.
* ``tortuous``: random channels (see :func:`tortuous_geometry`).

Compliant families: ``colon`` and ``colon_random`` (:mod:`evertgym.scenes.colon`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from evertgym.scenes import colon
from evertgym.scenes.geometry import (
    Path,
    Piece,
    arc,
    sample_path,
    self_intersection,
    smoothstep,
)
from evertgym.scenes.registry import FAMILIES, register
from evertgym.scenes.scene import Channel, Scene
from evertgym.scenes.spec import Family, Param, SceneError, SceneSpec, fmt_value

MM = 1e-3
DEG = math.pi / 180.0
#: Radius (m) of rigid wall segments; the wall is twice this thick, outside the lumen.
RIGID_WALL_RADIUS = 1e-3
#: Largest centreline sample spacing (m) of the rigid families.
DS_MAX = 2e-3
#: The shortest channel (m) a scene may have (the shortest straight pipe).
MIN_CHANNEL_M = 0.01
#: The paper's U-bend radii (mm), Fig. 4d.
PAPER_UBEND_RADII_MM = (40.0, 37.5, 35.0, 32.5, 30.0, 27.5, 25.0, 22.5, 20.0)

_LUMEN = Param(55.0, lo=5.0, hi=200.0, unit="mm", doc="internal diameter of the channel")
_LEAD_IN = Param(300.0, lo=0.0, hi=3000.0, unit="mm", doc="straight before the (first) bend")
_LEAD_OUT = Param(150.0, lo=0.0, hi=3000.0, unit="mm", doc="straight after the (last) bend")
_GOAL = Param(60.0, lo=0.0, hi=3000.0, unit="mm", doc="goal distance past the end of the (last) bend")
_TURN = Param("left", kind="choice", choices=("left", "right"), doc="direction of the (first) bend")
# inner-wall radii stay above the 2 mm thickness of rigid walls, or the inner wall would fold over itself
_BEND_RADIUS = Param(30.0, lo=3.0, hi=1000.0, unit="mm", doc="radius of the bend's inner wall")
_ANGLE = Param(90.0, lo=0.0, hi=180.0, lo_open=True, unit="deg", doc="turning angle of the bend")


def channel_from_sections(sections: list[tuple[Piece, float, float]], goal: float,
                          ds_max: float = DS_MAX) -> Channel:
    """Rigid channel from ``(piece, w_start, w_end)`` sections (m); widths blend smoothly within a piece."""
    path = sample_path([p for p, _, _ in sections], ds_max)
    return Channel(path=path, lumen_width=section_widths(path, sections), goal_arclength=goal,
                   wall_radius=RIGID_WALL_RADIUS)


def section_widths(path: Path, sections: list[tuple[Piece, float, float]]) -> np.ndarray:
    """Lumen width at each sample: ``w_start -> w_end`` along each piece (smoothstep)."""
    w0 = np.array([w for _, w, _ in sections])
    w1 = np.array([w for _, _, w in sections])
    j = path.piece
    length = np.diff(path.starts)[j]
    u = np.where(length > 0, (path.s - path.starts[j]) / np.where(length > 0, length, 1.0), 1.0)
    return w0[j] + (w1[j] - w0[j]) * smoothstep(u)


#: The PLA U-bend casing's friction factor: with the robot's tip friction 0.2 an effective
#: 0.175, the value that reproduces the paper's no-band U-bend rows with the rigid-column
#: model (evertgym reproduce ubend).  The section law's own fit is
#: evertgym/data/navigation_fit.json (scripts/calibrate_navigation.py).
UBEND_WALL_FRICTION = 0.875


def _check_goal(p: Mapping[str, Any], after: str = "lead_out_mm") -> None:
    if p["goal_after_bend_mm"] > p[after]:
        raise SceneError(
            f"goal_after_bend_mm = {p['goal_after_bend_mm']:g} is out of range: "
            f"allowed [0, {after} = {p[after]:g}] mm"
        )


def _sign(turn: str) -> float:
    return 1.0 if turn == "left" else -1.0


def straight_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """A straight pipe; the goal is its far end."""
    w, length = p["lumen_mm"] * MM, p["length_mm"] * MM
    return channel_from_sections([(Piece(length), w, w)], goal=length)


def ubend_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """Pipe, a 180-degree left U-bend whose inner wall has radius ``radius_mm``, then the exit."""
    w = p["lumen_mm"] * MM
    bend = arc(p["radius_mm"] * MM, 0.5 * w, math.pi)
    sections = [(Piece(p["pipe_length_mm"] * MM), w, w), (bend, w, w), (Piece(p["exit_length_mm"] * MM), w, w)]
    return channel_from_sections(sections, goal=(p["pipe_length_mm"] + p["goal_after_bend_mm"]) * MM + bend.length)


def bend_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """Lead-in, one bend of ``angle_deg`` with inner-wall radius ``radius_mm``, lead-out."""
    w = p["lumen_mm"] * MM
    bend = arc(p["radius_mm"] * MM, 0.5 * w, _sign(p["turn"]) * p["angle_deg"] * DEG)
    sections = [(Piece(p["lead_in_mm"] * MM), w, w), (bend, w, w), (Piece(p["lead_out_mm"] * MM), w, w)]
    return channel_from_sections(sections, goal=(p["lead_in_mm"] + p["goal_after_bend_mm"]) * MM + bend.length)


def sbend_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """Lead-in, a bend, a straight of ``middle_mm``, the opposite bend, lead-out."""
    w = p["lumen_mm"] * MM
    angle = _sign(p["turn"]) * p["angle_deg"] * DEG
    b1, b2 = arc(p["radius_mm"] * MM, 0.5 * w, angle), arc(p["radius_mm"] * MM, 0.5 * w, -angle)
    sections = [(Piece(p["lead_in_mm"] * MM), w, w), (b1, w, w), (Piece(p["middle_mm"] * MM), w, w),
                (b2, w, w), (Piece(p["lead_out_mm"] * MM), w, w)]
    end = (p["lead_in_mm"] + p["middle_mm"]) * MM + b1.length + b2.length
    return channel_from_sections(sections, goal=end + p["goal_after_bend_mm"] * MM)


#: Attempts at each random bend before the whole tortuous channel is redrawn, and redraws allowed.
TORTUOUS_ATTEMPTS = 30
TORTUOUS_RESTARTS = 50
#: Shortest straight (m) across which the lumen may change between bends.
LUMEN_BLEND_MIN = 0.01


def _check_tortuous(p: Mapping[str, Any]) -> None:
    _check_goal(p)
    if p["lumen_mm"][0] < p["robot_diameter_mm"]:
        raise SceneError(
            f"lumen_mm = {fmt_value(p['lumen_mm'])} is out of range: its min must be >= "
            f"robot_diameter_mm = {p['robot_diameter_mm']:g} mm (the channel must stay passable)"
        )


def tortuous_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """A random tortuous channel, passable by construction and never self-intersecting.

    Draws, in order: the number of bends (``n_bends``, inclusive range), the lead-in lumen,
    then per bend: the straight before it (``straight_mm``; the first is ``lead_in_mm``),
    its lumen (``lumen_mm``, constant through the bend, blended along the straight before
    it), inner-wall radius (``radius_mm``), angle (``angle_deg``) and turn direction; the
    last bend is followed by ``lead_out_mm`` of straight.  The turn direction is random but
    chosen to keep the heading within ``max_heading_deg`` of the entry direction when one
    side does, so channels advance rather than coil.  A bend whose channel-so-far overlaps
    itself (walls 2 mm thick included, :func:`self_intersection`) is redrawn up to
    :data:`TORTUOUS_ATTEMPTS` times; then the whole channel is redrawn.  Lumens are drawn
    from a range whose minimum is at least ``robot_diameter_mm``, so the channel is
    passable.
    """
    lo_w, hi_w = (v * MM for v in p["lumen_mm"])
    max_heading = p["max_heading_deg"] * DEG
    wall = 2.0 * RIGID_WALL_RADIUS
    n_bends = int(rng.integers(p["n_bends"][0], p["n_bends"][1] + 1))
    for _ in range(TORTUOUS_RESTARTS):
        sections: list[tuple[Piece, float, float]] = []
        w_prev = rng.uniform(lo_w, hi_w)
        heading, bend_end = 0.0, 0.0
        for k in range(n_bends):
            last = k == n_bends - 1
            for _ in range(TORTUOUS_ATTEMPTS):
                straight = p["lead_in_mm"] * MM if k == 0 else rng.uniform(*p["straight_mm"]) * MM
                w = rng.uniform(lo_w, hi_w)
                if straight < LUMEN_BLEND_MIN:
                    w = w_prev
                radius = rng.uniform(*p["radius_mm"]) * MM
                angle = rng.uniform(*p["angle_deg"]) * DEG
                sign = 1.0 if rng.random() < 0.5 else -1.0
                options = [s for s in (sign, -sign) if abs(heading + s * angle) <= max_heading]
                if options:
                    sign = options[0]
                else:
                    sign = min((sign, -sign), key=lambda s: abs(heading + s * angle))
                bend = arc(radius, 0.5 * w, sign * angle)
                unit = [(Piece(straight), w_prev, w), (bend, w, w)]
                if last:
                    unit.append((Piece(p["lead_out_mm"] * MM), w, w))
                cand = sections + unit
                path = sample_path([s[0] for s in cand], DS_MAX)
                reach = 0.5 * section_widths(path, cand) + wall
                if not self_intersection(path.s, path.xy, reach, path.curvature):
                    sections, w_prev = cand, w
                    heading += sign * angle
                    bend_end += straight + bend.length
                    break
            else:
                break
        else:
            return channel_from_sections(sections, goal=bend_end + p["goal_after_bend_mm"] * MM)
    raise SceneError(
        "tortuous: no non-self-intersecting channel found for these parameters; "
        "widen straight_mm or radius_mm, or lower n_bends or lumen_mm"
    )


_BUILT_IN: dict[str, Family] = {
    "straight": Family(
        "straight",
        {"length_mm": Param(600.0, lo=10.0, hi=5000.0, unit="mm", doc="pipe length"), "lumen_mm": _LUMEN},
        straight_geometry,
        doc="a straight pipe; goal at its far end",
    ),
    "ubend": Family(
        "ubend",
        {
            "pipe_length_mm": Param(300.0, lo=0.0, hi=3000.0, unit="mm", doc="straight pipe before the bend"),
            "lumen_mm": _LUMEN,
            "radius_mm": Param(30.0, lo=20.0, hi=40.0, unit="mm",
                               doc="inner-wall radius of the 180-degree bend (the paper's 40..20 mm)"),
            "exit_length_mm": Param(150.0, lo=0.0, hi=3000.0, unit="mm", doc="straight after the bend"),
            "goal_after_bend_mm": _GOAL,
            "wall_friction": Param(UBEND_WALL_FRICTION, lo=0.0, hi=5.0,
                                   doc="friction factor of the PLA casing (multiplies the robot's); fitted on the "
                                       "paper's no-band U-bend rows"),
        },
        ubend_geometry,
        check=lambda p: _check_goal(p, "exit_length_mm"),
        doc="the paper's U-bend rig: 55 mm pipe into a 180-degree bend of inner radius 20-40 mm",
    ),
    "bend": Family(
        "bend",
        {"angle_deg": _ANGLE, "radius_mm": _BEND_RADIUS, "lumen_mm": _LUMEN, "lead_in_mm": _LEAD_IN,
         "lead_out_mm": _LEAD_OUT, "goal_after_bend_mm": _GOAL, "turn": _TURN},
        bend_geometry,
        check=_check_goal,
        doc="one bend of any angle and inner-wall radius",
    ),
    "sbend": Family(
        "sbend",
        {"angle_deg": _ANGLE, "radius_mm": Param(40.0, lo=3.0, hi=1000.0, unit="mm", doc="inner-wall radius of both bends"),
         "lumen_mm": _LUMEN, "lead_in_mm": _LEAD_IN,
         "middle_mm": Param(50.0, lo=0.0, hi=3000.0, unit="mm", doc="straight between the bends"),
         "lead_out_mm": _LEAD_OUT, "goal_after_bend_mm": _GOAL, "turn": _TURN},
        sbend_geometry,
        check=_check_goal,
        doc="two opposite bends joined by a straight",
    ),
    "tortuous": Family(
        "tortuous",
        {
            "n_bends": Param((3, 6), kind="int_range", lo=1, hi=12, doc="number of bends (inclusive range)"),
            "radius_mm": Param((20.0, 60.0), kind="float_range", lo=3.0, hi=500.0, unit="mm",
                               doc="inner-wall radius of each bend"),
            "angle_deg": Param((30.0, 150.0), kind="float_range", lo=0.0, hi=180.0, lo_open=True, unit="deg",
                               doc="turning angle of each bend"),
            "lumen_mm": Param((45.0, 60.0), kind="float_range", lo=5.0, hi=200.0, unit="mm",
                              doc="lumen of each bend (blended along the straights)"),
            "robot_diameter_mm": Param(40.0, lo=1.0, hi=200.0, unit="mm", doc="lumen never narrower than this"),
            "straight_mm": Param((20.0, 120.0), kind="float_range", lo=0.0, hi=2000.0, unit="mm",
                                 doc="straight between consecutive bends"),
            "lead_in_mm": Param(150.0, lo=0.0, hi=3000.0, unit="mm", doc="straight before the first bend"),
            "lead_out_mm": _LEAD_OUT,
            "goal_after_bend_mm": _GOAL,
            "max_heading_deg": Param(120.0, lo=0.0, hi=360.0, unit="deg",
                                     doc="turn directions keep the heading within this of the entry's when possible"),
        },
        tortuous_geometry,
        check=_check_tortuous,
        doc="random tortuous channel, passable and never self-intersecting",
    ),
    "colon": colon.family("colon", variant=False),
    "colon_random": colon.family("colon_random", variant=True),
}
for _family in _BUILT_IN.values():
    register(_family)


def make_scene(spec: SceneSpec | Mapping[str, Any]) -> Scene:
    """Build the :class:`Scene` a spec (or its dict form) describes; deterministic given the seed.

    With ``seed=None`` fresh entropy is drawn and recorded in ``scene.spec.seed``.  Raises
    :class:`SceneError` if the parameters give a channel that overlaps itself or is narrower
    than the family's robot diameter.
    """
    if not isinstance(spec, SceneSpec):
        spec = SceneSpec.from_dict(spec)
    if spec.seed is None:
        entropy = np.random.SeedSequence().entropy
        assert isinstance(entropy, int)  # a fresh SeedSequence draws an int
        spec = SceneSpec(spec.family, dict(spec.params), entropy % 2**63)
    fam = FAMILIES[spec.family]
    rng = np.random.default_rng(spec.seed)
    params = fam.resolve(dict(spec.params), rng)
    scene = Scene(spec, params, fam.geometry(params, rng))
    if scene.length < MIN_CHANNEL_M:  # e.g. a vanishing bend with no straights
        raise SceneError(f"{spec.family}: these parameters give a channel {scene.length:g} m long: allowed >= "
                         f"{MIN_CHANNEL_M:g} m; lengthen lead_in_mm or lead_out_mm: {spec.to_dict()}")
    if scene.self_intersecting():
        raise SceneError(f"{spec.family}: these parameters give a self-intersecting channel: {spec.to_dict()}")
    robot = params.get("robot_diameter_mm")
    if robot is not None and not scene.passable(robot * MM):
        raise SceneError(f"{spec.family}: the lumen is narrower than robot_diameter_mm = {robot:g} somewhere")
    return scene
