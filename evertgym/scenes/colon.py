"""Colon-like channels: the paper's phantom (``colon``) and procedural variants (``colon_random``).

The phantom of the paper's case study (Sec. V): silicone (Ecoflex 00-50) dimensioned after
typical anatomy (Alazmani et al. 2016, "Quantitative assessment of colorectal morphology:
implications for robotic colonoscopy", Med. Eng. Phys. 38:148-154); a sigmoid section about
510 mm long with a 26 mm internal diameter and 3 mm walls, haustral folds as wall undulations,
laid out to give a sharp 90-degree bend whose radius varies from about 20 to 80 mm, held on a
board by elastic bands and magnets (mesocolon-like) with the rectal end fixed, and entered
through a funnel of 30 mm outer diameter.  The paper's bare 20 mm robot stalled at the bend at
360 mm insertion.

Layout of the channel, from the entry (arc length 0, the funnel's mouth):

1. the rigid funnel, ``funnel_length_mm`` long, its lumen narrowing from ``funnel_mouth_mm``
   (the paper's 30 mm outer diameter, read as the mouth's lumen) to ``lumen_mm``;
2. a straight, then the sigmoid's S (two opposite arcs of ``sigmoid_angle_deg`` with inner-wall
   radius ``sigmoid_radius_mm``, the first turning away from the bend), then a straight up to
   ``bend_at_mm``; the straights share the room left equally;
3. the bend: ``bend_angle_deg`` towards ``turn``, a clothoid whose inner-wall radius (of the
   mean lumen) goes from ``bend_radius_start_mm`` to ``bend_radius_end_mm`` (curvature linear
   in arc length; the paper gives only the 20-80 mm range, the order is our choice);
   with ``n_flexures`` > 1 (the phantom has one), ``n_flexures - 1`` copies of that bend follow,
   each ``flexure_gap_mm`` of straight after the one before and turning the other way, so the
   heading swings back and forth as along a colon's flexures and the channel never crosses itself;
4. a straight exit up to ``length_mm``; the goal is ``goal_after_bend_mm`` past the last flexure.

Haustral folds: both walls move inwards by ``fold_depth_mm * f(s)``, symmetric so the
centreline stays central, with ``f = ((1 + cos(2 pi (s - s1) / spacing)) / 2)^3`` (narrow
ridges between wide haustra), crests every ``fold_spacing_mm`` from half a spacing past the
funnel, faded in over that half spacing.  The narrowest lumen is ``lumen_mm - 2 fold_depth_mm``,
which validation keeps at or above ``robot_diameter_mm``.

Walls: compliant by default (:mod:`evertgym.scenes.compliant`), the funnel always rigid;
``compliant=False`` makes every wall static.

Procedural variants (``variant=True``, the default of ``colon_random``) draw the parameters
not given, uniformly from these ranges (mm and degrees), so a given value pins that feature:

* ``lumen_mm`` 24-32: the phantom's 26 mm to a distended sigmoid's ~30 mm (Alazmani et al.
  2016; Khashab et al. 2009, "Colorectal anatomy in adults at CT colonography", Endoscopy
  41:674-678), never below ``robot_diameter_mm + 2``;
* ``fold_spacing_mm`` 20-45 and ``fold_depth_mm`` 1-3.5 (capped so the folds keep the lumen
  passable): haustral folds are crescentic ridges a few mm high a few cm apart, and thin out
  in the sigmoid; the ranges are our plausible envelope around the phantom, not measured data;
* ``sigmoid_angle_deg`` 0-40 with ``sigmoid_radius_mm`` 120-400 (angle capped so the S fits
  before the bend), ``bend_at_mm`` 280-400, ``bend_angle_deg`` 60-120, ``bend_radius_start_mm``
  50-100, ``bend_radius_end_mm`` 15-35 (the phantom's 20-80 mm; the sigmoid can be tighter,
  Alqarni et al. 2024), ``turn`` left/right, and the exit 80-160 mm past the bend (giving
  ``length_mm``; Khashab et al. report about 11 acute-angle flexures along a 1.9 m colon, one
  per ~170 mm, so ``flexure_gap_mm`` is drawn 40-120 mm: with the flexures' own length, the
  3-5 of Colon-v1 span 0.26-1.08 m, as along the sigmoid and descending colon);
* ``wall_modulus_kpa`` 70-110 (Ecoflex 00-50: 100 % modulus 12 psi = 83 kPa, Smooth-On;
  80-100 kPa is the usual quoted range, widened for cure variation) and
  ``mesocolon_n_per_m_per_mm`` 0.5-2 (the suspension's stiffness is not reported).

Every draw is taken, in a fixed order, whether or not its parameter is given, so pinning one
parameter leaves the others' draws for a seed unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from evertgym.scenes.compliant import WallMechanics
from evertgym.scenes.geometry import Piece, arc, clothoid_bend, sample_path, smoothstep
from evertgym.scenes.scene import Channel
from evertgym.scenes.spec import Family, Param, SceneError

MM = 1e-3
DEG = math.pi / 180.0
#: Largest centreline sample spacing (m) of colon scenes (folds need the finer sampling).
DS_MAX = 1e-3
#: Exponent of the fold profile (higher: narrower ridges).
FOLD_SHARPNESS = 3

PARAMS: dict[str, Param] = {
    "length_mm": Param(510.0, lo=100.0, hi=3000.0, unit="mm", doc="channel length from the entry (sigmoid ~510 mm)"),
    "lumen_mm": Param(26.0, lo=5.0, hi=80.0, unit="mm", doc="internal diameter between folds"),
    "robot_diameter_mm": Param(20.0, lo=1.0, hi=80.0, unit="mm", doc="the lumen is never narrower than this"),
    "funnel_mouth_mm": Param(30.0, lo=5.0, hi=150.0, unit="mm", doc="lumen at the funnel's mouth"),
    "funnel_length_mm": Param(30.0, lo=0.0, hi=300.0, unit="mm", doc="length of the rigid entry funnel"),
    "sigmoid_angle_deg": Param(25.0, lo=0.0, hi=90.0, unit="deg", doc="turn of each arc of the sigmoid's S"),
    "sigmoid_radius_mm": Param(250.0, lo=10.0, hi=3000.0, unit="mm", doc="inner-wall radius of the S's arcs"),
    "bend_at_mm": Param(360.0, lo=10.0, hi=3000.0, unit="mm", doc="arc length where the bend starts"),
    "bend_angle_deg": Param(90.0, lo=0.0, hi=180.0, lo_open=True, unit="deg", doc="turn of the bend"),
    "bend_radius_start_mm": Param(80.0, lo=3.0, hi=1000.0, unit="mm", doc="inner-wall radius at the bend's start"),
    "bend_radius_end_mm": Param(20.0, lo=3.0, hi=1000.0, unit="mm", doc="inner-wall radius at the bend's end"),
    "turn": Param("left", kind="choice", choices=("left", "right"), doc="direction of the bend"),
    "fold_spacing_mm": Param(30.0, lo=5.0, hi=300.0, unit="mm", doc="distance between haustral folds"),
    "fold_depth_mm": Param(2.0, lo=0.0, hi=30.0, unit="mm", doc="inward height of each fold on each wall"),
    "goal_after_bend_mm": Param(50.0, lo=0.0, hi=3000.0, unit="mm", doc="goal distance past the (last) flexure"),
    "n_flexures": Param(1, kind="int", lo=1, hi=8, doc="number of flexures: the bend, then copies turning alternately"),
    "flexure_gap_mm": Param(80.0, lo=0.0, hi=3000.0, unit="mm", doc="straight between consecutive flexures"),
    "compliant": Param(True, kind="bool", doc="compliant walls (False: every wall static)"),
    "wall_thickness_mm": Param(3.0, lo=0.5, hi=20.0, unit="mm", doc="wall thickness"),
    "wall_modulus_kpa": Param(83.0, lo=1.0, hi=10000.0, unit="kPa", doc="Young's modulus of the wall (Ecoflex 00-50)"),
    "mesocolon_n_per_m_per_mm": Param(1.0, lo=0.0, hi=1000.0, unit="N/m per mm",
                                      doc="suspension stiffness per mm of tube, normal and tangential"),
    "wall_influence_mm": Param(10.0, lo=0.0, hi=200.0, unit="mm", doc="decay length of an indentation along the wall"),
    "piece_length_mm": Param(10.0, lo=2.0, hi=100.0, unit="mm", doc="length of each compliant wall piece"),
    "wall_travel_mm": Param(8.0, lo=0.5, hi=100.0, unit="mm",
                            doc="largest excursion of the wall from rest (board, magnets, surrounding organs)"),
    "variant": Param(False, kind="bool", doc="draw the parameters not given from anatomical ranges"),
}


def _layout(p: Mapping[str, Any]) -> tuple[list[Piece], float, float]:
    """Centreline pieces, the sigmoid's length and the flexures' length from the first's start (m)."""
    w = p["lumen_mm"] * MM
    sign = 1.0 if p["turn"] == "left" else -1.0
    s_ang = p["sigmoid_angle_deg"] * DEG
    s1 = arc(p["sigmoid_radius_mm"] * MM, 0.5 * w, -sign * s_ang)
    s2 = arc(p["sigmoid_radius_mm"] * MM, 0.5 * w, sign * s_ang)
    flexures: list[Piece] = []
    for i in range(int(p["n_flexures"])):
        if i:
            flexures.append(Piece(p["flexure_gap_mm"] * MM))
        flexures.append(clothoid_bend(p["bend_radius_start_mm"] * MM, p["bend_radius_end_mm"] * MM, 0.5 * w,
                                      (-1.0) ** i * sign * p["bend_angle_deg"] * DEG))
    bends = sum(piece.length for piece in flexures)
    funnel = p["funnel_length_mm"] * MM
    room = p["bend_at_mm"] * MM - funnel - s1.length - s2.length
    exit_ = p["length_mm"] * MM - p["bend_at_mm"] * MM - bends
    pieces = [Piece(funnel), Piece(0.5 * room), s1, s2, Piece(0.5 * room), *flexures, Piece(exit_)]
    return pieces, s1.length + s2.length, bends


def _check(p: Mapping[str, Any]) -> None:
    robot = p["robot_diameter_mm"]
    narrowest = (p["lumen_mm"] - robot) / 2.0
    if p["fold_depth_mm"] > narrowest:
        raise SceneError(
            f"fold_depth_mm = {p['fold_depth_mm']:g} is out of range: allowed [0, {max(narrowest, 0):g}] mm "
            f"((lumen_mm - robot_diameter_mm) / 2, so the folds keep the lumen passable)"
        )
    if p["funnel_mouth_mm"] < robot:
        raise SceneError(
            f"funnel_mouth_mm = {p['funnel_mouth_mm']:g} is out of range: must be >= robot_diameter_mm = {robot:g} mm"
        )
    if p["compliant"] and p["mesocolon_n_per_m_per_mm"] == 0 and p["wall_influence_mm"] == 0:
        raise SceneError(
            "mesocolon_n_per_m_per_mm = 0 is out of range: must be > 0 when wall_influence_mm = 0 "
            "(nothing would hold the compliant wall along the channel)"
        )
    for name in ("sigmoid_radius_mm", "bend_radius_start_mm", "bend_radius_end_mm"):
        if p[name] <= p["wall_thickness_mm"]:
            raise SceneError(
                f"{name} = {p[name]:g} is out of range: must be > wall_thickness_mm = {p['wall_thickness_mm']:g} mm "
                f"(or the inner wall folds over itself)"
            )
    _, s_len, b_len = _layout(p)
    need = p["funnel_length_mm"] + s_len / MM
    if p["bend_at_mm"] < need:
        raise SceneError(
            f"bend_at_mm = {p['bend_at_mm']:g} is out of range: must be >= funnel_length_mm + the sigmoid's "
            f"length = {need:g} mm (shorten the S with sigmoid_angle_deg or sigmoid_radius_mm)"
        )
    need = p["bend_at_mm"] + b_len / MM + p["goal_after_bend_mm"]
    if p["length_mm"] < need:
        raise SceneError(
            f"length_mm = {p['length_mm']:g} is out of range: must be >= bend_at_mm + the flexures' length "
            f"+ goal_after_bend_mm = {need:g} mm"
        )


def _draw(given: Mapping[str, Any], rng: np.random.Generator, variant_default: bool) -> dict[str, Any]:
    """Random variant parameters (see the module docstring); ``{}`` unless ``variant``."""
    if not given.get("variant", variant_default):
        return {}
    u = rng.random(15)  # one uniform per feature, in a fixed order
    out: dict[str, Any] = {}

    def pick(name: str, value: Any) -> Any:
        out[name] = given.get(name, value if isinstance(value, str) else float(value))
        return out[name]

    def span(lo: float, hi: float, x: float) -> float:
        return lo + (hi - lo) * x

    robot = given.get("robot_diameter_mm", PARAMS["robot_diameter_mm"].default)
    lumen = pick("lumen_mm", span(min(max(24.0, robot + 2.0), 32.0), 32.0, u[0]))
    pick("fold_spacing_mm", span(20.0, 45.0, u[1]))
    depth_hi = max(0.0, min(3.5, (lumen - robot) / 2.0))
    pick("fold_depth_mm", span(min(1.0, depth_hi), depth_hi, u[2]))
    bend_at = pick("bend_at_mm", span(280.0, 400.0, u[3]))
    radius = pick("sigmoid_radius_mm", span(120.0, 400.0, u[4]))
    funnel = given.get("funnel_length_mm", PARAMS["funnel_length_mm"].default)
    fits = max(0.0, bend_at - funnel - 20.0) / (2.0 * (radius + 0.5 * lumen)) / DEG
    pick("sigmoid_angle_deg", span(0.0, min(40.0, fits), u[5]))
    angle = pick("bend_angle_deg", span(60.0, 120.0, u[6]))
    r0 = pick("bend_radius_start_mm", span(50.0, 100.0, u[7]))
    r1 = pick("bend_radius_end_mm", span(15.0, 35.0, u[8]))
    pick("turn", "left" if u[9] < 0.5 else "right")
    pick("wall_modulus_kpa", span(70.0, 110.0, u[10]))
    pick("mesocolon_n_per_m_per_mm", span(0.5, 2.0, u[11]))
    n = int(given.get("n_flexures", PARAMS["n_flexures"].default))
    gap = span(40.0, 120.0, u[13])
    if n > 1:
        gap = pick("flexure_gap_mm", gap)
    bend_len = clothoid_bend(r0 * MM, r1 * MM, 0.5 * lumen * MM, angle * DEG).length / MM
    pick("length_mm", bend_at + n * bend_len + (n - 1) * gap + span(80.0, 160.0, u[12]))
    return out


def lumen_profile(s: np.ndarray, p: Mapping[str, Any]) -> np.ndarray:
    """Lumen width (m) along arc length ``s`` (m): funnel taper, then ``lumen_mm`` minus the folds."""
    lumen, funnel = p["lumen_mm"] * MM, p["funnel_length_mm"] * MM
    taper = 1.0 - smoothstep(s / funnel) if funnel > 0 else np.zeros_like(s)
    base = lumen + (p["funnel_mouth_mm"] * MM - lumen) * taper
    spacing = p["fold_spacing_mm"] * MM
    first = funnel + 0.5 * spacing
    ridge = ((1.0 + np.cos(2.0 * np.pi * (s - first) / spacing)) / 2.0) ** FOLD_SHARPNESS
    fade = smoothstep((s - funnel) / (0.5 * spacing))
    return base - 2.0 * p["fold_depth_mm"] * MM * ridge * fade


def colon_geometry(p: Mapping[str, Any], rng: np.random.Generator) -> Channel:
    """The colon channel described in the module docstring."""
    pieces, _, b_len = _layout(p)
    path = sample_path(pieces, DS_MAX)
    h = p["wall_thickness_mm"] * MM
    mech = None
    if p["compliant"]:
        mech = WallMechanics(
            modulus_pa=p["wall_modulus_kpa"] * 1e3,
            thickness_m=h,
            lumen_m=p["lumen_mm"] * MM,
            suspension_n_per_m2=p["mesocolon_n_per_m_per_mm"] * 1e3,
            influence_m=p["wall_influence_mm"] * MM,
            piece_length_m=p["piece_length_mm"] * MM,
            max_travel_m=p["wall_travel_mm"] * MM,
        )
    goal = p["bend_at_mm"] * MM + b_len + p["goal_after_bend_mm"] * MM
    return Channel(path=path, lumen_width=lumen_profile(path.s, p), goal_arclength=goal, wall_radius=0.5 * h,
                   mechanics=mech, compliant_from=p["funnel_length_mm"] * MM)


def family(name: str, variant: bool) -> Family:
    """The colon family under ``name``, whose ``variant`` parameter defaults to ``variant``."""
    params = dict(PARAMS)
    params["variant"] = Param(variant, kind="bool", doc=PARAMS["variant"].doc)
    doc = ("procedural colon-like channel (random anatomy per seed)" if variant
           else "the paper's colon phantom: funnel, sigmoid, 90-degree bend of 80->20 mm radius, compliant walls")
    return Family(name, params, colon_geometry, check=_check,
                  draw=lambda given, rng: _draw(given, rng, variant), doc=doc)
