"""Geometry of a window: the chain's nodes from its joint rotations, the wall pieces' poses, wall
features in world coordinates, and IPC's point-edge distances between the robot and a wall."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Chain, Walls

#: Relative size of ``den`` below which two segments count as parallel in :func:`closest` (the
#: closest points of parallel segments are taken at the first one's start).
PARALLEL_TOLERANCE = 1e-14
#: A point this close (as a fraction of the segment) to a wall segment's end is at that end in
#: :func:`point_point` (the contact's normal then turns with the robot point).
END_TOLERANCE = 1e-12


@nb.njit(cache=True, nogil=True)
def closest(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
            d: tuple[float, float]) -> tuple[float, float, float, float, float, float, float]:
    """Closest points of segments ab and cd: ``(s, t, px, py, qx, qy, dist)`` with p = a + s (b - a)."""
    ax, ay = a
    bx, by = b
    cx, cy = c
    dx, dy = d
    ux = bx - ax
    uy = by - ay
    vx = dx - cx
    vy = dy - cy
    wx = ax - cx
    wy = ay - cy
    aa = ux * ux + uy * uy
    bb = ux * vx + uy * vy
    cc = vx * vx + vy * vy
    dd = ux * wx + uy * wy
    e = vx * wx + vy * wy
    den = aa * cc - bb * bb
    if den > PARALLEL_TOLERANCE * aa * cc and den > 0.0:
        s = (bb * e - cc * dd) / den
        s = min(max(s, 0.0), 1.0)
    else:
        s = 0.0
    t = (bb * s + e) / cc if cc > 0.0 else 0.0
    if t < 0.0:
        t = 0.0
        s = min(max(-dd / aa, 0.0), 1.0) if aa > 0.0 else 0.0
    elif t > 1.0:
        t = 1.0
        s = min(max((bb - dd) / aa, 0.0), 1.0) if aa > 0.0 else 0.0
    px = ax + s * ux
    py = ay + s * uy
    qx = cx + t * vx
    qy = cy + t * vy
    dist = math.sqrt((px - qx) ** 2 + (py - qy) ** 2)
    return s, t, px, py, qx, qy, dist


@nb.njit(cache=True, nogil=True)
def point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> tuple[float, float, float, float]:
    """Closest point of segment ab to p: ``(t, qx, qy, dist)`` with q = a + t (b - a)."""
    ux = bx - ax
    uy = by - ay
    uu = ux * ux + uy * uy
    t = ((px - ax) * ux + (py - ay) * uy) / uu if uu > 0.0 else 0.0
    t = min(max(t, 0.0), 1.0)
    qx = ax + t * ux
    qy = ay + t * uy
    return t, qx, qy, math.sqrt((px - qx) ** 2 + (py - qy) ** 2)


@nb.njit(cache=True, nogil=True)
def point_edge(ab: tuple[float, float, float, float], cd: tuple[float, float, float, float],
               is_vertex: bool) -> tuple[float, float, float, float, float, float]:
    """IPC's point-edge pairs in 2-D, each smooth where a segment-segment distance is not: a wall
    vertex c against the robot segment ab, or the robot node b (the segment's distal end) against
    the wall segment cd.  Returns ``(s, px, py, qx, qy, dist)``: p on the robot at parameter s of ab,
    q on the wall."""
    ax, ay, bx, by = ab
    cx, cy, dx, dy = cd
    if is_vertex:
        s, px, py, dist = point_segment(cx, cy, ax, ay, bx, by)
        return s, px, py, cx, cy, dist
    _, qx, qy, dist = point_segment(bx, by, cx, cy, dx, dy)
    return 1.0, bx, by, qx, qy, dist


@nb.njit(cache=True, nogil=True)
def point_point(s: float, q: tuple[float, float], cd: tuple[float, float, float, float], is_vertex: bool) -> bool:
    """Whether a pair's closest points are two points (a wall vertex at a robot node, or a robot
    node at a wall segment's end): its distance then curves, ``(I - n n^T) / dist``."""
    if is_vertex:
        return s <= 0.0 or s >= 1.0
    qx, qy = q
    cx, cy, dx, dy = cd
    ux = dx - cx
    uy = dy - cy
    t = ((qx - cx) * ux + (qy - cy) * uy) / (ux * ux + uy * uy)
    return t <= END_TOLERANCE or t >= 1.0 - END_TOLERANCE


@nb.njit(cache=True, nogil=True)
def chain_nodes(theta0: float, n0: np.ndarray, phi: np.ndarray, seg_len: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node positions (m + 1, 2) and segment directions (m,) of the window: node ``k + 1`` is
    ``node k + l_k (cos theta_k, sin theta_k)`` with ``theta_k = theta0 + sum_{j <= k} phi_j``."""
    m = phi.shape[0]
    nodes = np.empty((m + 1, 2))
    theta = np.empty(m)
    nodes[0, 0] = n0[0]
    nodes[0, 1] = n0[1]
    th = theta0
    for k in range(m):
        th += phi[k]
        theta[k] = th
        nodes[k + 1, 0] = nodes[k, 0] + seg_len[k] * math.cos(th)
        nodes[k + 1, 1] = nodes[k, 1] + seg_len[k] * math.sin(th)
    return nodes, theta


@nb.njit(cache=True, nogil=True)
def window_nodes(chain: Chain, phi: np.ndarray) -> np.ndarray:
    """The window's nodes (m + 1, 2) at ``phi`` (:func:`chain_nodes`)."""
    return chain_nodes(chain.theta0, chain.n0, phi, chain.seg_len)[0]


@nb.njit(cache=True, nogil=True)
def pose_row(out: np.ndarray, p: int, pc0: np.ndarray, u: np.ndarray) -> None:
    """Piece ``p``'s pose ``(cos, sin, x, y)`` at its displacement ``u[p]`` into ``out[p]``."""
    out[p, 0] = math.cos(u[p, 2])
    out[p, 1] = math.sin(u[p, 2])
    out[p, 2] = pc0[p, 0] + u[p, 0]
    out[p, 3] = pc0[p, 1] + u[p, 1]


@nb.njit(cache=True, nogil=True)
def poses(pc0: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Each wall piece's pose ``(cos, sin, x, y)`` at its displacement ``u``: the rotation and the
    origin that move its features (computed once per configuration, not once per feature)."""
    out = np.empty((u.shape[0], 4))
    for p in range(u.shape[0]):
        pose_row(out, p, pc0, u)
    return out


@nb.njit(cache=True, nogil=True)
def lazy_pose(pose: np.ndarray, have: np.ndarray, w: int, wpiece: np.ndarray, pc0: np.ndarray, u: np.ndarray) -> None:
    """Fill ``pose``'s row (:func:`poses`) of wall feature ``w``'s piece if it is not yet (``have``):
    for tests that look at few of many pieces."""
    p = wpiece[w]
    if p >= 0 and not have[p]:
        pose_row(pose, p, pc0, u)
        have[p] = True


@nb.njit(cache=True, nogil=True)
def wall_world(w: int, wa: np.ndarray, wb: np.ndarray, wpiece: np.ndarray, pose: np.ndarray) -> tuple[float, float, float, float]:
    """World end points of wall segment ``w`` (:class:`~evertgym.sim.kernel.bundles.Walls`' ``a``, ``b``,
    ``piece``; static: as stored; a piece's: moved with it, by its :func:`poses` row).  The functions
    called per pair take the walls' arrays, not their bundle: numba counts a reference for every
    array taken out of a tuple, which in a loop over the pairs costs more than the arithmetic."""
    p = wpiece[w]
    if p < 0:
        return wa[w, 0], wa[w, 1], wb[w, 0], wb[w, 1]
    c = pose[p, 0]
    s = pose[p, 1]
    ox = pose[p, 2]
    oy = pose[p, 3]
    return (ox + c * wa[w, 0] - s * wa[w, 1], oy + s * wa[w, 0] + c * wa[w, 1],
            ox + c * wb[w, 0] - s * wb[w, 1], oy + s * wb[w, 0] + c * wb[w, 1])


@nb.njit(cache=True, nogil=True)
def wall_point(w: int, lx: float, ly: float, wpiece: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    """World position of a point given in wall segment ``w``'s body frame (world for static walls;
    ``pose``: :func:`poses`)."""
    p = wpiece[w]
    if p < 0:
        return lx, ly
    c = pose[p, 0]
    s = pose[p, 1]
    return pose[p, 2] + c * lx - s * ly, pose[p, 3] + s * lx + c * ly


@nb.njit(cache=True, nogil=True)
def pair_at(nodes: np.ndarray, k: int, w: int, seg_rad: np.ndarray, wa: np.ndarray, wb: np.ndarray, wpiece: np.ndarray,
            wvertex: np.ndarray, wradius: np.ndarray,
            pose: np.ndarray) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """Pair ``(k, w)`` now (the walls' arrays as in :class:`~evertgym.sim.kernel.bundles.Walls`, the
    pieces at ``pose``, :func:`poses`): the wall feature's end points, then :func:`point_edge`'s
    ``(s, px, py, qx, qy, dist)`` and the gap between the surfaces (m)."""
    cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
    s, px, py, qx, qy, dist = point_edge((nodes[k, 0], nodes[k, 1], nodes[k + 1, 0], nodes[k + 1, 1]), (cx, cy, dx, dy), wvertex[w])
    return cx, cy, dx, dy, s, px, py, qx, qy, dist, dist - seg_rad[k] - wradius[w]


@nb.njit(cache=True, nogil=True)
def segment_box(nodes: np.ndarray, k: int, grow: float) -> tuple[float, float, float, float]:
    """Bounding box ``(lx, hx, ly, hy)`` of segment ``k`` of ``nodes``, grown by ``grow`` (m)."""
    return (min(nodes[k, 0], nodes[k + 1, 0]) - grow, max(nodes[k, 0], nodes[k + 1, 0]) + grow,
            min(nodes[k, 1], nodes[k + 1, 1]) - grow, max(nodes[k, 1], nodes[k + 1, 1]) + grow)


@nb.njit(cache=True, nogil=True)
def max_node_shift(chain: Chain, phi: np.ndarray, ref: np.ndarray) -> float:
    """Largest distance (m) of the chain's nodes at ``phi`` (:func:`chain_nodes`) from ``ref``."""
    nodes = window_nodes(chain, phi)
    d = 0.0
    for j in range(nodes.shape[0]):
        d = max(d, math.hypot(nodes[j, 0] - ref[j, 0], nodes[j, 1] - ref[j, 1]))
    return d


@nb.njit(cache=True, nogil=True)
def piece_reach(walls: Walls, npc: int) -> np.ndarray:
    """Per wall piece: the largest distance (m) of its features' end points from its origin (a
    rotation by ``dtheta`` moves none of them by more than this times ``|dtheta|``)."""
    wa, wb, wpiece, _, _ = walls
    rho = np.zeros(npc)
    for w in range(wa.shape[0]):
        p = wpiece[w]
        if p >= 0:
            rho[p] = max(rho[p], math.sqrt(wa[w, 0] ** 2 + wa[w, 1] ** 2), math.sqrt(wb[w, 0] ** 2 + wb[w, 1] ** 2))
    return rho


@nb.njit(cache=True, nogil=True)
def moved(nodes: np.ndarray, ref_nodes: np.ndarray, u: np.ndarray, ref_u: np.ndarray, rho: np.ndarray) -> float:
    """Bound (m) on the change of any robot-wall gap since the configuration ``ref_nodes``, ``ref_u``:
    the largest node displacement (a segment's points move no further than its ends) plus the largest
    displacement of a wall piece's point."""
    d = 0.0
    for j in range(nodes.shape[0]):
        d = max(d, math.sqrt((nodes[j, 0] - ref_nodes[j, 0]) ** 2 + (nodes[j, 1] - ref_nodes[j, 1]) ** 2))
    dp = 0.0
    for p in range(u.shape[0]):
        dp = max(dp, math.sqrt((u[p, 0] - ref_u[p, 0]) ** 2 + (u[p, 1] - ref_u[p, 1]) ** 2) + rho[p] * abs(u[p, 2] - ref_u[p, 2]))
    return d + dp
