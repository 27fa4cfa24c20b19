"""Continuous collision detection: the largest fraction of a step along which no robot-wall pair
touches, so that the line search never accepts a configuration on the far side of a wall (the
barrier's energy is finite there, and the gaps positive, once the body has passed through).

The step moves every chain node and every wall feature's end point on the straight line between
the two configurations (IPC's linear trajectories; a joint rotation moves a node on an arc, whose
chord this is).  Each point-edge pair (:func:`~evertgym.sim.kernel.geometry.point_edge`) is advanced
conservatively (IPC's additive CCD): its gap ``g(t)`` falls no faster than the speed bound ``V``
(the largest end-point displacement of its robot segment plus that of its wall feature: every point
of a segment moves no further than its ends), so it stays positive up to ``t + g(t) / V``.  A pair
whose gap at the start exceeds ``V`` cannot touch; any other is advanced by
:data:`ACCD_SAFETY` of that bound until it reaches the step's end or its gap falls below
:data:`ACCD_IMPACT_FRACTION` of its start (an impact)."""

from __future__ import annotations

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Walls
from evertgym.sim.kernel.geometry import point_edge, poses, wall_world

#: Fraction of the conservative bound ``g / V`` taken per advance: the gap stays above ``(1 - s) g``.
ACCD_SAFETY = 0.9
#: A pair whose gap falls below this fraction of its gap at the start has met the wall (an impact):
#: small enough that a step that ends close to a wall, without passing it, is not cut.
ACCD_IMPACT_FRACTION = 1e-6
#: Advances of one pair before its bound is taken as found (a pair sliding along a wall at a gap far
#: below its step advances by ``g / V`` of it each time).
ACCD_MAX_ADVANCES = 10_000
#: The line search's next trial after a step found not collision-free: this fraction of the safe part.
CCD_BACKOFF = 0.8


@nb.njit(cache=True, nogil=True)
def _lerp4(p0: tuple[float, float, float, float], p1: tuple[float, float, float, float], t: float) -> tuple[float, float, float, float]:
    """Two points ``(x, y, x, y)`` moved a fraction ``t`` of the way from ``p0`` to ``p1``."""
    return (p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1]), p0[2] + t * (p1[2] - p0[2]), p0[3] + t * (p1[3] - p0[3]))


@nb.njit(cache=True, nogil=True)
def _speed(p0: tuple[float, float, float, float], p1: tuple[float, float, float, float]) -> float:
    """The larger displacement of the two points ``(x, y, x, y)`` from ``p0`` to ``p1``."""
    return max(np.hypot(p1[0] - p0[0], p1[1] - p0[1]), np.hypot(p1[2] - p0[2], p1[3] - p0[3]))


@nb.njit(cache=True, nogil=True)
def pair_toi(ab0: tuple[float, float, float, float], ab1: tuple[float, float, float, float], cd0: tuple[float, float, float, float],
             cd1: tuple[float, float, float, float], is_vertex: bool, radii: float) -> float:
    """The fraction (0-1] of the straight-line motion of robot segment ``ab`` (``ab0`` to ``ab1``) and
    wall feature ``cd`` (``cd0`` to ``cd1``) along which their gap (distance less ``radii``) stays
    positive: 1 if it does all the way, else a fraction at which it is still positive."""
    speed = _speed(ab0, ab1) + _speed(cd0, cd1)
    g0 = point_edge(ab0, cd0, is_vertex)[5] - radii
    if g0 > speed:
        return 1.0
    if g0 <= 0.0:
        return 0.0
    t = 0.0
    g = g0
    for _ in range(ACCD_MAX_ADVANCES):
        t += ACCD_SAFETY * g / speed
        if t >= 1.0:
            return 1.0
        g = point_edge(_lerp4(ab0, ab1, t), _lerp4(cd0, cd1, t), is_vertex)[5] - radii
        if g <= ACCD_IMPACT_FRACTION * g0:
            return t
    return t


@nb.njit(cache=True, nogil=True)
def step_bound(nodes0: np.ndarray, nodes1: np.ndarray, u0: np.ndarray, u1: np.ndarray, pairs: np.ndarray, seg_rad: np.ndarray,
               walls: Walls, pc0: np.ndarray) -> float:
    """The largest fraction (0-1] of the step from ``nodes0``, ``u0`` to ``nodes1``, ``u1`` along which
    none of the ``pairs`` (k, w) touches (:func:`pair_toi`); 1 if the whole step is free."""
    pose0 = poses(pc0, u0)
    pose1 = poses(pc0, u1)
    wa, wb, wpiece, wvertex, wradius = walls
    out = 1.0
    for c in range(pairs.shape[0]):
        k = pairs[c, 0]
        w = pairs[c, 1]
        ab0 = (nodes0[k, 0], nodes0[k, 1], nodes0[k + 1, 0], nodes0[k + 1, 1])
        ab1 = (nodes1[k, 0], nodes1[k, 1], nodes1[k + 1, 0], nodes1[k + 1, 1])
        out = min(out, pair_toi(ab0, ab1, wall_world(w, wa, wb, wpiece, pose0), wall_world(w, wa, wb, wpiece, pose1), wvertex[w],
                                seg_rad[k] + wradius[w]))
    return out
