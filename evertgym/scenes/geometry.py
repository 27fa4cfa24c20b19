"""Planar channel geometry (SI): centrelines from straight/arc/clothoid pieces, and checks.

A centreline is a chain of :class:`Piece` objects, each of length ``length`` (m) whose
curvature varies linearly from ``k0`` to ``k1`` (1/m; positive turns left): a straight
(``k0 = k1 = 0``), a circular arc (``k0 = k1``) or a clothoid.  The heading is integrated
exactly; positions use the exact chord of a constant-curvature step, so arcs and straights
are exact to rounding and clothoids are accurate to ``O(ds^3 dk/ds)`` (nanometres here).

The channel is the set of discs of radius ``w(s)/2`` centred on the centreline; its walls are
the offsets ``c(s) +/- n(s) w(s)/2``.  :func:`self_intersection` checks that distinct parts of
the channel, walls included, never overlap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

#: Point-vertex pairs whose distances :func:`nearest_vertex` holds at a time (memory, not speed).
_NEAREST_BLOCK = 1 << 16


@dataclass(frozen=True)
class Piece:
    """A centreline piece: ``length`` (m), curvature ``k0`` -> ``k1`` (1/m, linear in arc length)."""

    length: float
    k0: float = 0.0
    k1: float | None = None

    @property
    def k_end(self) -> float:
        return self.k0 if self.k1 is None else self.k1

    @property
    def turn(self) -> float:
        """Heading change over the piece (rad)."""
        return 0.5 * (self.k0 + self.k_end) * self.length


def arc(inner_radius: float, half_width: float, angle: float) -> Piece:
    """A circular bend turning by ``angle`` (rad, positive left) whose inner wall has radius ``inner_radius``.

    The centreline radius is ``inner_radius + half_width``.
    """
    rc = inner_radius + half_width
    return Piece(length=abs(angle) * rc, k0=math.copysign(1.0 / rc, angle))


def clothoid_bend(r_start: float, r_end: float, half_width: float, angle: float) -> Piece:
    """A bend turning by ``angle`` (rad) whose centreline curvature varies linearly in arc length.

    The inner wall radius (of the mean lumen) is ``r_start`` at the bend's start and ``r_end``
    at its end; length ``2 |angle| / (k_start + k_end)``.
    """
    k0, k1 = 1.0 / (r_start + half_width), 1.0 / (r_end + half_width)
    sign = math.copysign(1.0, angle)
    return Piece(length=2.0 * abs(angle) / (k0 + k1), k0=sign * k0, k1=sign * k1)


@dataclass(frozen=True)
class Path:
    """A sampled centreline: ``s`` (N,), ``xy`` (N, 2), ``heading`` (N,), ``curvature`` (N,), ``piece`` (N,).

    ``piece[i]`` is the index of the piece sample ``i`` ends (0 for the first sample);
    ``starts`` are the arc lengths at which the pieces begin (plus the total length).
    """

    s: np.ndarray
    xy: np.ndarray
    heading: np.ndarray
    curvature: np.ndarray
    piece: np.ndarray
    starts: np.ndarray

    @property
    def normal(self) -> np.ndarray:
        """Unit left normals (N, 2)."""
        return np.column_stack([-np.sin(self.heading), np.cos(self.heading)])


#: Largest heading change (rad) between consecutive samples.
MAX_TURN_PER_SAMPLE = 0.1


def sample_path(pieces: list[Piece], ds_max: float, origin=(0.0, 0.0), heading0: float = 0.0) -> Path:
    """Sample ``pieces`` with spacing at most ``ds_max`` (m); piece joints are samples.

    Tight bends are sampled finer, so that the heading turns by at most
    :data:`MAX_TURN_PER_SAMPLE` between samples.  Pieces of zero length add no samples
    (a straight of length 0 is allowed).
    """
    if sum(p.length for p in pieces) <= 0.0:
        raise ValueError("a path needs a positive length")
    s_parts, th_parts = [np.zeros(1)], [np.array([heading0])]
    k_parts, idx_parts = [np.array([pieces[0].k0])], [np.zeros(1, int)]
    s0, th0 = 0.0, heading0
    starts = [0.0]
    for j, p in enumerate(pieces):
        if p.length <= 0.0:
            starts.append(s0)
            continue
        k_max = max(abs(p.k0), abs(p.k_end))
        n = max(1, math.ceil(p.length / ds_max - 1e-9),
                math.ceil(k_max * p.length / MAX_TURN_PER_SAMPLE - 1e-9))
        u = np.linspace(0.0, p.length, n + 1)[1:]
        dk = (p.k_end - p.k0) / p.length
        s_parts.append(s0 + u)
        th_parts.append(th0 + p.k0 * u + 0.5 * dk * u * u)
        k_parts.append(p.k0 + dk * u)
        idx_parts.append(np.full(n, j))
        s0 += p.length
        th0 += p.turn
        starts.append(s0)
    s = np.concatenate(s_parts)
    th = np.concatenate(th_parts)
    du = np.diff(s)
    dth = np.diff(th)
    chord = du * np.sinc(dth / (2.0 * np.pi))  # np.sinc(x) = sin(pi x) / (pi x)
    mid = th[:-1] + 0.5 * dth
    steps = np.column_stack([chord * np.cos(mid), chord * np.sin(mid)])
    xy = np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)]) + np.asarray(origin, float)
    return Path(s=s, xy=xy, heading=th, curvature=np.concatenate(k_parts),
                piece=np.concatenate(idx_parts), starts=np.asarray(starts))


def smoothstep(t: np.ndarray) -> np.ndarray:
    """C1 ramp from 0 (t <= 0) to 1 (t >= 1)."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def offset_walls(path: Path, width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left and right walls (inner surfaces of the lumen), each (N, 2)."""
    off = path.normal * (0.5 * width)[:, None]
    return path.xy + off, path.xy - off


def polyline_normals(poly: np.ndarray) -> np.ndarray:
    """Unit left normals of a polyline at its vertices (central differences)."""
    d = np.gradient(poly, axis=0)
    n = np.linalg.norm(d, axis=1, keepdims=True)
    good = n[:, 0] > 1e-12
    if not np.all(good):  # coincident vertices (a vanishing piece): take the nearest good tangent
        idx = np.flatnonzero(good)
        nearest = idx[np.clip(np.searchsorted(idx, np.arange(len(d))), 0, len(idx) - 1)]
        d, n = d[nearest], n[nearest]
    d = d / n
    return np.column_stack([-d[:, 1], d[:, 0]])


def simplify(poly: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the vertices kept by Ramer-Douglas-Peucker at tolerance ``tol`` (m)."""
    return np.flatnonzero(_rdp_keep(np.ascontiguousarray(poly, dtype=np.float64), float(tol)))


@nb.njit(cache=True, nogil=True)
def _rdp_keep(poly: np.ndarray, tol: float) -> np.ndarray:
    """:func:`simplify`'s kept vertices as a mask: each span's farthest vertex from its chord (the first
    of equals), kept if farther than ``tol``, then both halves (the arithmetic of numpy's vectorised
    form, element by element)."""
    n = poly.shape[0]
    keep = np.zeros(n, np.bool_)
    if n == 0:
        return keep
    keep[0] = True
    keep[n - 1] = True
    stack = np.empty((2 * n + 2, 2), np.int64)
    top = 0
    stack[0, 0] = 0
    stack[0, 1] = n - 1
    top = 1
    while top > 0:
        top -= 1
        a = stack[top, 0]
        b = stack[top, 1]
        if b - a < 2:
            continue
        sx = poly[b, 0] - poly[a, 0]
        sy = poly[b, 1] - poly[a, 1]
        norm = math.hypot(sx, sy)
        best = -1.0
        at = 0
        for j in range(a + 1, b):
            rx = poly[j, 0] - poly[a, 0]
            ry = poly[j, 1] - poly[a, 1]
            d = abs(sx * ry - sy * rx) / norm if norm > 0 else math.hypot(rx, ry)
            if d > best or j == a + 1:
                best = d
                at = j
        if best > tol:
            keep[at] = True
            stack[top, 0] = a
            stack[top, 1] = at
            stack[top + 1, 0] = at
            stack[top + 1, 1] = b
            top += 2
    return keep


def nearest_vertex(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Index of the vertex of ``poly`` (K, 2) nearest to each point (M, 2) (the first of equals).

    A direct search over all pairs, in blocks of about 65,000 pairs (half a megabyte per
    temporary): the polylines of a scene have hundreds to a few thousand vertices, where this
    costs milliseconds and spares an env the 30 MB that importing a k-d tree
    (``scipy.spatial``) takes.
    """
    pts = np.atleast_2d(np.asarray(points, float))
    out = np.empty(len(pts), dtype=np.intp)
    rows = max(1, _NEAREST_BLOCK // max(1, len(poly)))
    for a in range(0, len(pts), rows):
        blk = pts[a:a + rows]
        dx = blk[:, 0, None] - poly[None, :, 0]
        dy = blk[:, 1, None] - poly[None, :, 1]
        out[a:a + rows] = np.argmin(dx * dx + dy * dy, axis=1)
    return out


def point_polyline_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance (m) from each point (M, 2) to a densely sampled polyline (K, 2).

    Measured to the two segments adjacent to the nearest vertex: exact whenever the nearest
    point of the polyline lies on one of them, which holds for points farther from the
    polyline than its vertex spacing.
    """
    j = nearest_vertex(points, poly)
    a = np.clip(np.stack([j - 1, j]), 0, len(poly) - 2)  # the segments ending and starting at vertex j
    pa = poly[a]
    seg = poly[a + 1] - pa
    rel = points[None] - pa
    ll = np.maximum(np.sum(seg * seg, axis=-1), 1e-300)
    t = np.clip(np.sum(rel * seg, axis=-1) / ll, 0.0, 1.0)
    off = rel - t[..., None] * seg
    return np.sqrt(np.min(np.sum(off * off, axis=-1), axis=0))


def self_intersection(s: np.ndarray, xy: np.ndarray, reach: np.ndarray, curvature: np.ndarray,
                      coarse: float = 0.01) -> bool:
    """True if the channel, walls included, overlaps itself.

    ``reach`` (N,) is the half-width plus the wall thickness at each sample: the channel
    with its walls is the union of discs of radius ``reach`` on the centreline.  It is
    embedded if (local) ``|curvature| * reach < 1`` everywhere, so no wall folds over itself,
    and (global) any two samples more than ``pi * max(reach)`` apart along the centreline are
    at least ``reach_i + reach_j`` apart in the plane.  Closer pairs belong to one stretch of
    channel, which turns by less than pi over that arc while the local condition holds; by
    Schur's comparison theorem its chord is then at least that of a circle of radius
    ``reach``.  Together: the walls of different parts never cross and the centreline never
    crosses itself.  The discs make the test conservative for stretches that turn by well
    over pi (a loop around a post thinner than the lumen is reported).

    The global test first compares windows of ``coarse`` (m) of arc length with bounds that
    can only over-report, then settles each candidate pair of windows on its samples: exact
    on the samples, at a cost of ``(L / coarse)^2`` window pairs plus the few candidates.
    """
    if np.any(np.abs(curvature) * reach >= 1.0):
        return True
    n = len(s)
    w = np.minimum(np.floor(s / coarse).astype(int), int(s[-1] / coarse))
    starts = np.flatnonzero(np.r_[True, w[1:] != w[:-1]])
    ends = np.r_[starts[1:], n]
    c_xy = xy[starts + (ends - starts) // 2]
    c_s = s[starts + (ends - starts) // 2]
    c_reach = np.maximum.reduceat(reach, starts)
    c_reach_min = np.minimum.reduceat(reach, starts)
    # half extent of each window along the arc (bounds the distance of its samples to its centre)
    c_half = np.maximum(c_s - s[starts], s[ends - 1] - c_s)
    d = np.hypot(*(c_xy[:, None, :] - c_xy[None, :, :]).transpose(2, 0, 1))
    ds = np.abs(c_s[:, None] - c_s[None, :])
    slack = c_half[:, None] + c_half[None, :]
    far = ds + slack > np.pi * np.maximum(c_reach_min[:, None], c_reach_min[None, :])
    close = d - slack < c_reach[:, None] + c_reach[None, :]
    ci, cj = np.nonzero(np.triu(far & close))
    for a, b in zip(ci, cj):
        ia = np.arange(starts[a], ends[a])
        ib = np.arange(starts[b], ends[b])
        dd = np.hypot(*(xy[ia][:, None, :] - xy[ib][None, :, :]).transpose(2, 0, 1))
        rr = reach[ia][:, None] + reach[ib][None, :]
        ss = np.abs(s[ia][:, None] - s[ib][None, :])
        mr = np.maximum(reach[ia][:, None], reach[ib][None, :])
        if np.any((ss > np.pi * mr) & (dd < rr)):
            return True
    return False
