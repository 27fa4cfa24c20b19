"""The :class:`Scene`: a channel's description (SI) and how it builds its walls into pymunk.

Conventions: the entry (where the robot's base sits) is the origin and the robot first grows
along +x; the centreline is ordered from the entry with spacing of at most 2 mm; ``walls``
are ``[left, right]`` (left of the direction of travel first), the inner surfaces of the
lumen, sampled at the centreline's samples.  Rigid walls become static ``pymunk.Segment``
shapes on ``space.static_body`` whose inner surfaces lie on the lumen boundary; compliant
walls (:mod:`evertgym.scenes.compliant`) become dynamic bodies only in scenes that ask.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Any

import numpy as np
import pymunk

from evertgym.scenes.compliant import (
    WallMechanics,
    WallNetwork,
    design_wall_network,
    style_wall_shape,
)
from evertgym.scenes.geometry import (
    Path,
    nearest_vertex,
    offset_walls,
    point_polyline_distance,
    polyline_normals,
    self_intersection,
    simplify,
)
from evertgym.scenes.spec import SceneSpec

#: Tolerance (m) of the polyline simplification of static walls.
STATIC_WALL_TOLERANCE = 2e-5
#: Numerical slack (m) of the passability test.
PASSABLE_SLACK = 1e-9


@dataclass(frozen=True)
class Channel:
    """What a family's geometry function returns (SI).

    ``path`` the sampled centreline, ``lumen_width`` (N,) at its samples, ``goal_arclength``,
    ``wall_radius`` (radius of the wall shapes), ``mechanics`` (compliant walls only) and
    ``compliant_from`` (arc length where the compliant wall begins).
    """

    path: Path
    lumen_width: np.ndarray
    goal_arclength: float
    wall_radius: float
    mechanics: WallMechanics | None = None
    compliant_from: float = 0.0


@dataclass
class SceneHandles:
    """What :meth:`Scene.build` added to a space.

    ``bodies``: compliant wall pieces (empty for rigid scenes); ``shapes``: every wall shape;
    ``springs``: the wall's constraints; ``network``: the compliant wall's design and linear
    statics (``None`` for rigid scenes); ``backstop``: the static shapes behind a compliant
    wall that bound its travel (also in ``shapes``).
    """

    bodies: list[pymunk.Body] = field(default_factory=list)
    shapes: list[pymunk.Shape] = field(default_factory=list)
    springs: list[pymunk.Constraint] = field(default_factory=list)
    network: WallNetwork | None = None
    backstop: list[pymunk.Shape] = field(default_factory=list)

    def positions(self) -> np.ndarray:
        """Current positions (P, 2) of the wall pieces (m)."""
        return np.array([tuple(b.position) for b in self.bodies]).reshape(-1, 2)

    def wall_displacement(self) -> float:
        """Largest displacement (m) of a compliant wall piece from its rest position (0 if rigid)."""
        if not self.bodies or self.network is None:
            return 0.0
        return float(np.max(np.hypot(*(self.positions() - self.network.position).T)))


class Scene:
    """A channel scene in SI units; made by :func:`evertgym.scenes.make_scene`.

    Attributes: ``spec`` (with the seed actually used), ``params`` (all parameters used, mm
    and degrees), ``centreline`` (N, 2), ``arclength`` (N,), ``heading`` (N,) (rad),
    ``curvature`` (N,) (1/m, positive left), ``lumen_width`` (N,) (internal diameter, m),
    ``entry``, ``entry_direction``, ``goal_arclength``, ``goal``, ``walls`` ([left, right],
    each (N, 2)), ``wall_radius`` (radius of the wall shapes, m; the wall is ``2 wall_radius``
    thick outside the lumen), ``compliant``, ``mechanics`` (compliant walls only),
    ``compliant_from`` (arc length where the compliant wall starts; walls before it are
    rigid), ``derived`` (derived numbers in the parameters' units).
    """

    def __init__(self, spec: SceneSpec, params: Mapping[str, Any], channel: Channel) -> None:
        path, mechanics = channel.path, channel.mechanics
        self.spec = spec
        self.params = MappingProxyType(dict(params))
        self._path = path
        self.centreline = _frozen(path.xy)
        self.arclength = _frozen(path.s)
        self.heading = _frozen(path.heading)
        self.curvature = _frozen(path.curvature)
        self.lumen_width = _frozen(channel.lumen_width)
        self.entry = _frozen(path.xy[0])
        self.entry_direction = _frozen(np.array([np.cos(path.heading[0]), np.sin(path.heading[0])]))
        self.goal_arclength = float(channel.goal_arclength)
        self.goal = _frozen(self.point_at(self.goal_arclength))
        self.walls = [_frozen(w) for w in offset_walls(path, self.lumen_width)]
        self.wall_radius = float(channel.wall_radius)
        self.mechanics = mechanics
        self.compliant = mechanics is not None
        self.compliant_from = float(channel.compliant_from)
        self.derived = MappingProxyType(mechanics.summary() if mechanics else {})

    def __repr__(self) -> str:
        return f"Scene({self.spec.family!r}, length={self.length * 1e3:.1f} mm, compliant={self.compliant})"

    @property
    def length(self) -> float:
        """Centreline length (m)."""
        return float(self.arclength[-1])

    def point_at(self, s: float | np.ndarray) -> np.ndarray:
        """Centreline point(s) at arc length ``s`` (m), linearly interpolated."""
        s = np.asarray(s, float)
        return np.stack([np.interp(s, self.arclength, self.centreline[:, 0]),
                         np.interp(s, self.arclength, self.centreline[:, 1])], axis=-1)

    def bend_regions(self, approach_m: float = 0.0, fraction: float = 0.5) -> list[tuple[float, float]]:
        """Arc-length intervals (m) of the scene's bends: where the centreline's |curvature| is
        at least ``fraction`` of its largest, each extended back by ``approach_m`` (the tip meets
        a bend's outer wall before the centreline turns).  Empty for a straight channel.

        This is what "at the bend" means in the env's ``peak_pressure_bend_kpa``:
        the tightest bends of the scene, whatever the family.
        """
        k = np.abs(self.curvature)
        k_max = float(k.max()) if k.size else 0.0
        if k_max <= 0.0:
            return []
        inside = k >= fraction * k_max
        edges = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(np.int8), [0]])))
        s = self.arclength
        return [(max(float(s[a]) - approach_m, float(s[0])), float(s[b - 1])) for a, b in zip(edges[::2], edges[1::2])]

    def lumen_at(self, s: float | np.ndarray) -> float | np.ndarray:
        """Lumen width (internal diameter, m) at arc length ``s`` (m)."""
        out = np.interp(s, self.arclength, self.lumen_width)
        return float(out) if np.ndim(out) == 0 else out

    def project(self, points: np.ndarray) -> tuple[np.ndarray | float, np.ndarray | float]:
        """Nearest centreline point of each point: ``(arclength, lateral offset)`` (m).

        The offset is positive to the left of the direction of travel.  Exact on straights; in
        bends the polyline's chords err by about ``offset * ds * curvature / 2`` in ``s``.
        Beyond the ends the first and last segments are extended, so points before the entry
        get ``s < 0``.  Accepts one point (2,) or many (M, 2).
        """
        if np.ndim(points) == 1:
            return self._project_one(float(points[0]), float(points[1]))
        pts = np.atleast_2d(np.asarray(points, float))
        c, s = self.centreline, self.arclength
        j = nearest_vertex(pts, c)
        n = len(c)
        best_d = np.full(len(pts), np.inf)
        best_s = np.zeros(len(pts))
        best_e = np.zeros(len(pts))
        for off in (-1, 0):
            a = np.clip(j + off, 0, n - 2)
            seg = c[a + 1] - c[a]
            ll = np.einsum("ij,ij->i", seg, seg)
            t = np.einsum("ij,ij->i", pts - c[a], seg) / ll
            t = np.maximum(t, np.where(a == 0, -np.inf, 0.0))  # the end segments extend beyond the ends
            t = np.minimum(t, np.where(a == n - 2, np.inf, 1.0))
            foot = c[a] + t[:, None] * seg
            rel = pts - foot
            d = np.hypot(rel[:, 0], rel[:, 1])
            better = d < best_d
            best_d = np.where(better, d, best_d)
            best_s = np.where(better, s[a] + t * (s[a + 1] - s[a]), best_s)
            cross = (seg[:, 0] * rel[:, 1] - seg[:, 1] * rel[:, 0]) / np.sqrt(ll)
            best_e = np.where(better, cross, best_e)
        return best_s, best_e

    def _project_one(self, x: float, y: float) -> tuple[float, float]:
        """:meth:`project` of one point, in scalars: the same operations in the same order (an env
        projects its tip once per step, where numpy's per-call cost was most of the time)."""
        c, s = self._centre_list
        cx, cy = self._centre_xy
        dx, dy = cx - x, cy - y
        j = int(np.argmin(dx * dx + dy * dy))
        n = len(c)
        best_d, best_s, best_e = math.inf, 0.0, 0.0
        for off in (-1, 0):
            a = min(max(j + off, 0), n - 2)
            (ax, ay), (bx, by) = c[a], c[a + 1]
            sx, sy = bx - ax, by - ay
            ll = sx * sx + sy * sy
            t = ((x - ax) * sx + (y - ay) * sy) / ll
            if a != 0:  # the end segments extend beyond the ends
                t = max(t, 0.0)
            if a != n - 2:
                t = min(t, 1.0)
            rx, ry = x - (ax + t * sx), y - (ay + t * sy)
            d = float(np.hypot(rx, ry))
            if d < best_d:
                best_d = d
                best_s = s[a] + t * (s[a + 1] - s[a])
                best_e = (sx * ry - sy * rx) / math.sqrt(ll)
        return best_s, best_e

    @cached_property
    def _centre_xy(self) -> tuple[np.ndarray, np.ndarray]:
        return np.ascontiguousarray(self.centreline[:, 0]), np.ascontiguousarray(self.centreline[:, 1])

    @cached_property
    def _centre_list(self) -> tuple[list[tuple[float, float]], list[float]]:
        return [tuple(p) for p in self.centreline.tolist()], self.arclength.tolist()

    def wall_distance(self, points: np.ndarray) -> np.ndarray:
        """Distance (m) from each point to the nearest wall surface."""
        pts = np.atleast_2d(np.asarray(points, float))
        return np.minimum(*(point_polyline_distance(pts, w) for w in self.walls))

    def is_inside(self, points: np.ndarray, radius: float) -> np.ndarray | bool:
        """Whether discs of ``radius`` (m) centred on ``points`` lie inside the lumen.

        A disc is inside if its centre projects onto the centreline between the entry and the
        exit, its lateral offset plus ``radius`` stays within half the local lumen, and it
        is at least ``radius`` from every wall.
        """
        pts = np.atleast_2d(np.asarray(points, float))
        s, e = self.project(pts)
        s, e = np.atleast_1d(s), np.atleast_1d(e)
        ok = (s >= 0.0) & (s <= self.length) & (np.abs(e) + radius <= 0.5 * self.lumen_at(s))
        ok &= self.wall_distance(pts) >= radius
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    @cached_property
    def _clearance(self) -> float:
        left, right = self.walls
        return float(min(point_polyline_distance(left, right).min(), point_polyline_distance(right, left).min()))

    def min_clearance(self) -> float:
        """Smallest distance (m) between the left and the right wall polylines."""
        return self._clearance

    @cached_property
    def chord_error(self) -> float:
        """Largest gap (m) between a wall polyline and the true wall: ``|k| ds^2 (1 + |k| w/2) / 8``."""
        ds = np.diff(self.arclength)
        k = np.abs(self.curvature[1:])
        return float(np.max(k * ds * ds * (1.0 + k * 0.5 * self.lumen_width[1:]) / 8.0))

    def passable(self, robot_diameter_m: float) -> bool:
        """Whether a robot of ``robot_diameter_m`` (m) fits everywhere.

        The lumen width must never be narrower, nor the distance between the wall polylines
        (up to twice their :attr:`chord_error`, the polylines being chords of the walls).
        """
        d = robot_diameter_m - PASSABLE_SLACK
        return bool(self.lumen_width.min() >= d and self.min_clearance() >= d - 2.0 * self.chord_error)

    @cached_property
    def _self_intersecting(self) -> bool:
        reach = 0.5 * self.lumen_width + 2.0 * self.wall_radius
        return self_intersection(self.arclength, self.centreline, reach, self.curvature)

    def self_intersecting(self) -> bool:
        """Whether distinct parts of the channel, walls included, overlap (see :func:`self_intersection`)."""
        return self._self_intersecting

    @property
    def compliant_start(self) -> int:
        """Index of the sample where the compliant wall begins (the number of samples if rigid)."""
        if not self.compliant:
            return len(self.arclength)
        return int(np.searchsorted(self.arclength, self.compliant_from))

    def wall_network(self) -> WallNetwork | None:
        """Design (not build) the compliant wall; ``None`` for rigid scenes."""
        if not self.compliant or self.mechanics is None:
            return None
        return design_wall_network(self.mechanics, self.arclength, self._path.normal, self.walls, self.compliant_start)

    def build(self, space: pymunk.Space, dt: float | None = None, dynamics: bool = True) -> SceneHandles:
        """Add the walls to ``space``: static segments, plus the compliant wall's bodies if any.

        ``dt``: the step (s) the space will use.  When given, the compliant wall's spring
        stiffnesses are divided by ``space.damping ** dt``: pymunk damps the spring impulses
        of a step but neither contact impulses nor applied forces, which would otherwise make
        the wall softer by that factor at equilibrium (2.8 % at damping 1e-6, dt = 2 ms).
        ``dynamics=False``: ``space`` is never stepped (:meth:`WallNetwork.build`).
        """
        handles = SceneHandles()
        last = min(self.compliant_start + 1, len(self.arclength))  # the static part shares its end vertex
        handles.shapes += self._build_static_shell(space, slice(0, last), self.wall_radius)
        if "wall_friction" in self.params:  # a family may declare its wall material's friction factor
            for seg in handles.shapes:
                seg.friction = float(self.params["wall_friction"])
        net = self.wall_network()
        if net is not None:
            factor = 1.0 if dt is None else 1.0 / space.damping**dt
            handles.bodies, shapes, handles.springs = net.build(space, factor, dynamics)
            handles.shapes += shapes
            handles.network = net
            # The backstop: static walls the tether travel plus a wall thickness behind the
            # compliant walls.  A tethered piece's centre moves at most its travel, but a piece
            # pushed at one end also turns about it, and two turned neighbours open a gap that
            # a robot pushed at 8 kPa escapes through.  Only the robot touches the backstop (the
            # pieces pass it): the channel widens by at most the travel, wherever it is pushed.
            handles.backstop = self._build_static_shell(
                space, slice(self.compliant_start, None), net.mechanics.max_travel_m + 3.0 * self.wall_radius)
            handles.shapes += handles.backstop
        return handles

    def _build_static_shell(self, space: pymunk.Space, part: slice, offset: float) -> list[pymunk.Shape]:
        """Static wall segments (radius ``wall_radius``) along both walls' samples ``part``,
        their centre line ``offset`` (m) outside the lumen surface; none for fewer than 2 samples."""
        shapes: list[pymunk.Shape] = []
        for side, wall in enumerate(self.walls):
            pts = wall[part]
            if len(pts) < 2:
                continue
            sign = 1.0 if side == 0 else -1.0
            shell = pts + sign * polyline_normals(pts) * offset
            pts = shell[simplify(shell, STATIC_WALL_TOLERANCE)]
            segs = [style_wall_shape(pymunk.Segment(space.static_body, tuple(pts[i]), tuple(pts[i + 1]), self.wall_radius))
                    for i in range(len(pts) - 1)]
            space.add(*segs)
            shapes += segs
        return shapes


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, float)
    a.setflags(write=False)
    return a
