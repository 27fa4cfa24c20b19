"""Compiled inner loop of the quasi-static engine: one static equilibrium of the active window.

The unknowns are the relative rotations ``phi`` (rad) of the window's joints and the
displacements ``u = (dx, dy, dtheta)`` (m, m, rad) of the compliant wall pieces near it.  The
window's first node and the direction of the segment before it are held; node ``k + 1`` is
``node k + l_k (cos theta_k, sin theta_k)`` with ``theta_k = theta_0 + sum_{j <= k} phi_j``.
Equilibrium is the stationary point of the incremental potential (Incremental Potential
Contact, Li et al., SIGGRAPH 2020):

    E = sum_j W_j(phi_j)                       joint law (linear, tension field, kink plateau)
      + sum_pairs kappa b(d)                   log barrier on every robot-wall capsule gap d < d_hat
      + sum_lagged mu lambda f0(|u_T|)         Coulomb friction, normal force and tangent lagged
      + 1/2 u^T K u + u^T f_h + travel(u)      compliant wall pieces (linear springs, tether stop)

``b(d) = -(d - d_hat)^2 ln(d / d_hat)``; ``f0`` is IPC's smoothed sliding potential (slip above
``eps_v`` of tangential displacement per increment).  Newton with a Levenberg shift where the
Hessian is indefinite (a collapse plateau under compression) and a backtracking line search
that keeps every gap positive.  The stop is a force criterion: the largest unbalanced joint
moment below ``tol_m`` (N m) and the largest unbalanced wall-piece force below ``tol_f`` (N).

Everything is SI.  The functions are compiled with numba (``cache=True``); the first call in a
fresh environment compiles them (a few seconds), later processes load the cache.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: solve status codes
CONVERGED = 0
MAX_ITERATIONS = 1
LINE_SEARCH_FAILED = 2
INFEASIBLE_START = 3

#: Reach (m) beyond the barrier gap of the pairs a Newton solve evaluates: re-listed from its candidates
#: whenever a gap may have changed by more than this since they were listed.
_NEAR_MARGIN_M = 1e-3
#: Allowance (m) for rounding in the bound on a gap's change.
_NEAR_SLACK_M = 1e-9
#: Segments per block in the candidate search of :func:`contacts` (a block's circle is tested first) and
#: in the box tests of :func:`overlaps` and :func:`select_features` (a block's box first).
_BLOCK = 8


@nb.njit(cache=True, nogil=True)
def _law_eval(x: float, table_u: np.ndarray, table_h: np.ndarray, table_hi: np.ndarray, slope_tail: float):
    """Normalised wrinkled law at curvature ratio ``x >= 1``: ``(h, dh/dx, H)`` with ``h = M / M_c``
    and ``H = int_1^x h``; tabulated in ``ln x`` on a uniform grid, linear beyond its end."""
    u = math.log(x)
    du = table_u[1] - table_u[0]
    n = table_u.shape[0]
    if u >= table_u[n - 1]:
        x_end = math.exp(table_u[n - 1])
        h = table_h[n - 1] + slope_tail * (x - x_end)
        hi = table_hi[n - 1] + table_h[n - 1] * (x - x_end) + 0.5 * slope_tail * (x - x_end) ** 2
        return h, slope_tail, hi
    i = int(u / du)
    if i > n - 2:
        i = n - 2
    t = (u - table_u[i]) / du
    h = table_h[i] * (1.0 - t) + table_h[i + 1] * t
    x0 = math.exp(table_u[i])
    x1 = math.exp(table_u[i + 1])
    dh = (table_h[i + 1] - table_h[i]) / (x1 - x0)
    # the integral of the linear-in-x interpolant over [x0, x]
    hi = table_hi[i] + (x - x0) * (table_h[i] + 0.5 * dh * (x - x0))
    return h, dh, hi


@nb.njit(cache=True, nogil=True)
def joint_law(phi: float, k: float, mw: float, table_u, table_h, table_hi, slope_tail, residual: float):
    """``(W, M, dM/dphi)`` of one joint: energy (J), moment (N m) and tangent stiffness (N m/rad).
    Linear ``k phi`` up to the wrinkling moment ``mw``, then ``M_c h(phi / phi_w)`` (the
    tension-field law with its kink plateau), never below ``residual k phi``."""
    if mw <= 0.0:
        kr = residual * k
        return 0.5 * kr * phi * phi, kr * phi, kr
    phiw = mw / k
    a = abs(phi)
    if a <= phiw:
        return 0.5 * k * phi * phi, k * phi, k
    mc = 2.0 * mw
    h, dh, hi = _law_eval(a / phiw, table_u, table_h, table_hi, slope_tail)
    s = 1.0 if phi > 0 else -1.0
    return 0.5 * k * phiw * phiw + mc * phiw * hi, s * mc * h, mc * dh / phiw


@nb.njit(cache=True, nogil=True)
def _closest(ax, ay, bx, by, cx, cy, dx, dy):
    """Closest points of segments ab and cd: ``(s, t, px, py, qx, qy, dist)`` with p = a + s (b - a)."""
    ux = bx - ax
    uy = by - ay
    vx = dx - cx
    vy = dy - cy
    wx = ax - cx
    wy = ay - cy
    a = ux * ux + uy * uy
    b = ux * vx + uy * vy
    c = vx * vx + vy * vy
    d = ux * wx + uy * wy
    e = vx * wx + vy * wy
    den = a * c - b * b
    if den > 1e-14 * a * c and den > 0.0:
        s = (b * e - c * d) / den
        s = min(max(s, 0.0), 1.0)
    else:
        s = 0.0
    t = (b * s + e) / c if c > 0.0 else 0.0
    if t < 0.0:
        t = 0.0
        s = min(max(-d / a, 0.0), 1.0) if a > 0.0 else 0.0
    elif t > 1.0:
        t = 1.0
        s = min(max((b - d) / a, 0.0), 1.0) if a > 0.0 else 0.0
    px = ax + s * ux
    py = ay + s * uy
    qx = cx + t * vx
    qy = cy + t * vy
    dist = math.sqrt((px - qx) ** 2 + (py - qy) ** 2)
    return s, t, px, py, qx, qy, dist


@nb.njit(cache=True, nogil=True)
def _point_segment(px, py, ax, ay, bx, by):
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
def _pair(ax, ay, bx, by, cx, cy, dx, dy, is_vertex):
    """IPC's point-edge pairs in 2-D, each smooth where a segment-segment distance is not: a wall
    vertex c against the robot segment ab, or the robot node b (the segment's distal end) against
    the wall segment cd.  Returns ``(s, px, py, qx, qy, dist)``: p on the robot at parameter s of ab,
    q on the wall."""
    if is_vertex:
        s, px, py, dist = _point_segment(cx, cy, ax, ay, bx, by)
        return s, px, py, cx, cy, dist
    _, qx, qy, dist = _point_segment(bx, by, cx, cy, dx, dy)
    return 1.0, bx, by, qx, qy, dist


@nb.njit(cache=True, nogil=True)
def _point_point(s, qx, qy, cx, cy, dx, dy, is_vertex):
    """Whether a pair's closest points are two points (a wall vertex at a robot node, or a robot
    node at a wall segment's end): its distance then curves, ``(I - n n^T) / dist``."""
    if is_vertex:
        return s <= 0.0 or s >= 1.0
    ux = dx - cx
    uy = dy - cy
    t = ((qx - cx) * ux + (qy - cy) * uy) / (ux * ux + uy * uy)
    return t <= 1e-12 or t >= 1.0 - 1e-12


@nb.njit(cache=True, nogil=True)
def chain_nodes(theta0: float, n0: np.ndarray, phi: np.ndarray, seg_len: np.ndarray):
    """Node positions (m + 1, 2) and segment directions (m,) of the window."""
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
def _pose_row(out, p, pc0, u):
    """Piece ``p``'s pose ``(cos, sin, x, y)`` at its displacement ``u[p]`` into ``out[p]``."""
    out[p, 0] = math.cos(u[p, 2])
    out[p, 1] = math.sin(u[p, 2])
    out[p, 2] = pc0[p, 0] + u[p, 0]
    out[p, 3] = pc0[p, 1] + u[p, 1]


@nb.njit(cache=True, nogil=True)
def poses(pc0, u):
    """Each wall piece's pose ``(cos, sin, x, y)`` at its displacement ``u``: the rotation and the
    origin that move its features (computed once per configuration, not once per feature)."""
    out = np.empty((u.shape[0], 4))
    for p in range(u.shape[0]):
        _pose_row(out, p, pc0, u)
    return out


@nb.njit(cache=True, nogil=True)
def _lazy_pose(pose, have, w, wpiece, pc0, u):
    """Fill ``pose``'s row (:func:`poses`) of wall feature ``w``'s piece if it is not yet (``have``):
    for tests that look at few of many pieces."""
    p = wpiece[w]
    if p >= 0 and not have[p]:
        _pose_row(pose, p, pc0, u)
        have[p] = True


@nb.njit(cache=True, nogil=True)
def wall_world(w: int, wa, wb, wpiece, pose):
    """World end points of wall segment ``w`` (static: as stored; a piece's: moved with it, by its
    :func:`poses` row)."""
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
def _barrier(d: float, dhat: float):
    """``b(d), b'(d), b''(d)`` of the IPC log barrier (0 beyond ``dhat``)."""
    if d >= dhat:
        return 0.0, 0.0, 0.0
    r = d - dhat
    lg = math.log(d / dhat)
    return -r * r * lg, -2.0 * r * lg - r * r / d, -2.0 * lg - 4.0 * r / d + r * r / (d * d)


@nb.njit(cache=True, nogil=True)
def _f0(y: float, eps: float):
    """IPC's smoothed sliding potential: ``f0(y)``, ``f1(y) / y`` (force per slip) and ``f1'(y)``
    (the exact stiffness of the one-dimensional tangent of a planar contact: 0 once sliding)."""
    if y >= eps:
        return y, 1.0 / y, 0.0
    return y * y / eps - y ** 3 / (3.0 * eps * eps) + eps / 3.0, (2.0 / eps - y / (eps * eps)), 2.0 / eps - 2.0 * y / (eps * eps)


@nb.njit(cache=True, nogil=True)
def contacts(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, dhat, margin):
    """Every robot-wall pair (:func:`_pair`) with gap below ``dhat + margin``: rows of
    ``(k, w, s, 0, px, py, qx, qy, nx, ny, gap)`` as float (k: window segment, w: wall feature,
    s: parameter of the robot point p on segment k, q: the wall point, n: unit normal from q to p)."""
    nodes, theta = chain_nodes(theta0, n0, phi, seg_len)
    m = phi.shape[0]
    nw = wa.shape[0]
    pose = poses(pc0, u)
    # each feature's bounding circle (centre, radius grown by its shape's radius and the reach), once
    circ = np.empty((nw, 3))
    for w in range(nw):
        cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
        circ[w, 0] = 0.5 * (cx + dx)
        circ[w, 1] = 0.5 * (cy + dy)
        circ[w, 2] = 0.5 * math.sqrt((dx - cx) ** 2 + (dy - cy) ** 2) + wrad[w] + dhat + margin
    cand = np.empty((m * 8 + 16, 2), np.int64)  # the pairs whose bounding circles come within reach
    cnt = 0
    near = np.empty(nw, np.int64)
    for k0 in range(0, m, _BLOCK):  # a block of segments' bounding circle first: the features near it
        k1 = min(k0 + _BLOCK, m)
        bx = 0.5 * (nodes[k0, 0] + nodes[k1, 0])
        by = 0.5 * (nodes[k0, 1] + nodes[k1, 1])
        big = 0.0
        for k in range(k0, k1):
            mx = 0.5 * (nodes[k, 0] + nodes[k + 1, 0])
            my = 0.5 * (nodes[k, 1] + nodes[k + 1, 1])
            big = max(big, math.sqrt((mx - bx) ** 2 + (my - by) ** 2) + 0.5 * seg_len[k] + seg_rad[k])
        big += 1e-9  # rounding: never narrower than its segments' circles
        nn = 0
        for w in range(nw):
            reach = big + circ[w, 2]
            ddx = circ[w, 0] - bx
            ddy = circ[w, 1] - by
            if ddx * ddx + ddy * ddy <= reach * reach:
                near[nn] = w
                nn += 1
        for k in range(k0, k1):
            mx = 0.5 * (nodes[k, 0] + nodes[k + 1, 0])
            my = 0.5 * (nodes[k, 1] + nodes[k + 1, 1])
            own = 0.5 * seg_len[k] + seg_rad[k]
            for i in range(nn):
                w = near[i]
                reach = own + circ[w, 2]
                ddx = circ[w, 0] - mx
                ddy = circ[w, 1] - my
                if ddx * ddx + ddy * ddy > reach * reach:
                    continue
                if cnt == cand.shape[0]:
                    bigger = np.empty((2 * cnt, 2), np.int64)
                    bigger[:cnt] = cand
                    cand = bigger
                cand[cnt, 0] = k
                cand[cnt, 1] = w
                cnt += 1
    return pair_rows(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, cand[:cnt], dhat, margin)


@nb.njit(cache=True, nogil=True)
def _pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvert, wrad, pose):
    """Pair ``(k, w)`` now (the pieces at ``pose``, :func:`poses`): the wall feature's end points,
    then :func:`_pair`'s ``(s, px, py, qx, qy, dist)`` and the gap between the surfaces (m)."""
    cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
    s, px, py, qx, qy, dist = _pair(nodes[k, 0], nodes[k, 1], nodes[k + 1, 0], nodes[k + 1, 1], cx, cy, dx, dy, wvert[w])
    return cx, cy, dx, dy, s, px, py, qx, qy, dist, dist - seg_rad[k] - wrad[w]


@nb.njit(cache=True, nogil=True)
def pair_rows(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, cand, dhat, margin):
    """:func:`contacts` restricted to the candidate pairs ``cand`` (k, w)."""
    nodes, _ = chain_nodes(theta0, n0, phi, seg_len)
    pose = poses(pc0, u)
    out = np.empty((cand.shape[0], 11))
    cnt = 0
    for c in range(cand.shape[0]):
        k = cand[c, 0]
        w = cand[c, 1]
        _, _, _, _, s, px, py, qx, qy, dist, gap = _pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvert, wrad, pose)
        if gap >= dhat + margin:
            continue
        out[cnt, 0] = k
        out[cnt, 1] = w
        out[cnt, 2] = s
        out[cnt, 3] = 0.0
        out[cnt, 4] = px
        out[cnt, 5] = py
        out[cnt, 6] = qx
        out[cnt, 7] = qy
        out[cnt, 8] = (px - qx) / dist if dist > 0 else 0.0
        out[cnt, 9] = (py - qy) / dist if dist > 0 else 0.0
        out[cnt, 10] = gap
        cnt += 1
    return out[:cnt]


@nb.njit(cache=True, nogil=True)
def _rows_to_pairs(rows):
    out = np.empty((rows.shape[0], 2), np.int64)
    for i in range(rows.shape[0]):
        out[i, 0] = int(rows[i, 0])
        out[i, 1] = int(rows[i, 1])
    return out


@nb.njit(cache=True, nogil=True)
def _slip(c, nodes, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_xr0, fr_xw0, wpiece, pose):
    """Lagged friction entry ``c`` now: its segment and parameter, the robot point, the wall point and
    the tangential slip ``u_T`` (m) since the configuration before the solve."""
    k = fr_k[c]
    s = fr_s[c]
    xr = nodes[k, 0] * (1 - s) + nodes[k + 1, 0] * s
    yr = nodes[k, 1] * (1 - s) + nodes[k + 1, 1] * s
    xw, yw = _wall_point(fr_w[c], fr_wl[c, 0], fr_wl[c, 1], wpiece, pose)
    ut = ((xr - fr_xr0[c, 0]) - (xw - fr_xw0[c, 0])) * fr_t[c, 0] + ((yr - fr_xr0[c, 1]) - (yw - fr_xw0[c, 1])) * fr_t[c, 1]
    return k, s, xr, yr, xw, yw, ut


@nb.njit(cache=True, nogil=True)
def energy(nodes, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
           wa, wb, wpiece, wvert, wrad, pc0, u, pairs, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0, fr_xw0,
           dhat, kappa, eps_v, geo):
    """The incremental potential (J) at ``phi`` (its nodes ``nodes``, :func:`chain_nodes`); ``inf`` where
    any robot-wall gap is not positive.  Each pair's :func:`_pair_at` goes into row ``c`` of ``geo``
    (at least as many rows as ``pairs``): :func:`grad_hess` at the same configuration reads it there."""
    m = phi.shape[0]
    e = 0.0
    for j in range(m):
        w_, _, _ = joint_law(phi[j], k_j[j], mw_j[j], law_u, law_h, law_hi, law_slope, residual)
        e += w_
    pose = poses(pc0, u)
    for c in range(pairs.shape[0]):
        g = _pair_at(nodes, pairs[c, 0], pairs[c, 1], seg_rad, wa, wb, wpiece, wvert, wrad, pose)
        for i in range(11):
            geo[c, i] = g[i]
        gap = g[10]
        if gap <= 0.0:
            return np.inf
        b, _, _ = _barrier(gap, dhat)
        e += kappa * b
    # lagged friction
    for c in range(fr_k.shape[0]):
        ut = _slip(c, nodes, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_xr0, fr_xw0, wpiece, pose)[6]
        f0, _, _ = _f0(abs(ut), eps_v)
        e += fr_mulam[c] * f0
    # compliant wall pieces
    npc = u.shape[0]
    if npc > 0:
        for p in range(npc):  # kaa: each piece's own 3 x 3 stiffness (independent springs)
            for i in range(3):
                e += fh[3 * p + i] * u[p, i]
                for j in range(3):
                    e += 0.5 * u[p, i] * kaa[p, i, j] * u[p, j]
        for p in range(npc):
            r = math.sqrt(u[p, 0] ** 2 + u[p, 1] ** 2)
            if r > travel[p]:
                e += 0.5 * k_travel[p] * (r - travel[p]) ** 2
    return e


@nb.njit(cache=True, nogil=True)
def _wall_point(w, lx, ly, wpiece, pose):
    """World position of a point given in wall segment ``w``'s body frame (world for static walls;
    ``pose``: :func:`poses`)."""
    p = wpiece[w]
    if p < 0:
        return lx, ly
    c = pose[p, 0]
    s = pose[p, 1]
    return pose[p, 2] + c * lx - s * ly, pose[p, 3] + s * lx + c * ly


@nb.njit(cache=True, nogil=True)
def _add_point_force(k, px, py, fx, fy, acc_f, acc_m, acc_fx):
    """Accumulate a force ``f`` (on the robot) at ``p`` on segment ``k``: sums per segment of f,
    p x f and f . p (for the generalised forces and the geometric stiffness)."""
    acc_f[k, 0] += fx
    acc_f[k, 1] += fy
    acc_m[k] += px * fy - py * fx
    acc_fx[k] += fx * px + fy * py


@nb.njit(cache=True, nogil=True)
def _record(rec, nrec, piece, k, a0, a1, a2, g0, g1, g2):
    """Append a coupling of wall piece ``piece`` to the joints ``j <= k``: the joints-pieces block
    gains ``(a_j . c) g^T`` in the piece's three columns, ``a_j = (1, x_j, y_j)`` node ``j``'s
    generator (:func:`grad_hess`); a row of ``rec`` is ``[piece, k, c, g]``, ``nrec[0]`` the rows used."""
    r = nrec[0]
    rec[r, 0] = piece
    rec[r, 1] = k
    rec[r, 2] = a0
    rec[r, 3] = a1
    rec[r, 4] = a2
    rec[r, 5] = g0
    rec[r, 6] = g1
    rec[r, 7] = g2
    nrec[0] = r + 1


@nb.njit(cache=True, nogil=True)
def _rank1(hjp, hpp, smat, k, px, py, nodes, dirx, diry, piece, pc_x, pc_y, wx, wy, coef, rec, nrec):
    """Add ``coef g g^T`` for the gradient ``g`` of ``dir . (p - q)``.  Its robot part,
    ``g_j = (p - n_j) x dir = v . w_j`` for the joints ``j <= k`` with ``v = (p x dir, dir_y, dir_x)``
    and ``w_j = (1, -n_jx, n_jy)``, goes into the 3 x 3 sums ``smat[k]`` (summed from the tip and
    expanded by :func:`grad_hess` in O(m^2)); a wall piece's part (``-dir``, ``-(q - c) x dir``) goes
    into its block ``hpp`` and its coupling to the joints into ``hjp`` directly, or, if ``rec`` has
    rows, as one record (:func:`_record`)."""
    v0 = px * diry - py * dirx
    v1 = diry
    v2 = dirx
    smat[k, 0, 0] += coef * v0 * v0
    smat[k, 0, 1] += coef * v0 * v1
    smat[k, 0, 2] += coef * v0 * v2
    smat[k, 1, 1] += coef * v1 * v1
    smat[k, 1, 2] += coef * v1 * v2
    smat[k, 2, 2] += coef * v2 * v2
    smat[k, 1, 0] = smat[k, 0, 1]
    smat[k, 2, 0] = smat[k, 0, 2]
    smat[k, 2, 1] = smat[k, 1, 2]
    if piece < 0:
        return
    gp0 = -dirx
    gp1 = -diry
    gp2 = -((wx - pc_x) * diry - (wy - pc_y) * dirx)
    o = 3 * piece
    if rec.shape[0] > 0:
        _record(rec, nrec, piece, k, coef * v0, -coef * v1, coef * v2, gp0, gp1, gp2)
    else:
        for j in range(k + 1):
            gj = v0 - nodes[j, 0] * v1 + nodes[j, 1] * v2
            c = coef * gj
            hjp[j, o] += c * gp0
            hjp[j, o + 1] += c * gp1
            hjp[j, o + 2] += c * gp2
    d = hpp[piece]
    d[0, 0] += coef * gp0 * gp0
    d[0, 1] += coef * gp0 * gp1
    d[0, 2] += coef * gp0 * gp2
    d[1, 0] += coef * gp1 * gp0
    d[1, 1] += coef * gp1 * gp1
    d[1, 2] += coef * gp1 * gp2
    d[2, 0] += coef * gp2 * gp0
    d[2, 1] += coef * gp2 * gp1
    d[2, 2] += coef * gp2 * gp2


@nb.njit(cache=True, nogil=True)
def _apply_force(m, k, s, px, py, qx, qy, fx, fy, p, pc0, u, ex, ey, acc_f, acc_m, acc_fx, tip, grad):
    """A wall force ``f`` (N) on the robot at ``p`` (parameter ``s`` of segment ``k``): into the
    segment sums, the tip's reaction against growth (``-s f . e_tip``) and total force if ``k`` is the
    tip segment, and the opposite force at ``q`` on wall piece ``p`` (if any) into ``grad``.  Returns
    the piece's current centre (0, 0 for a static wall)."""
    _add_point_force(k, px, py, fx, fy, acc_f, acc_m, acc_fx)
    if k == m - 1:
        tip[0] -= s * (fx * ex + fy * ey)
        tip[1] += fx
        tip[2] += fy
    if p < 0:
        return 0.0, 0.0
    ccx = pc0[p, 0] + u[p, 0]
    ccy = pc0[p, 1] + u[p, 1]
    o = m + 3 * p
    grad[o] += fx
    grad[o + 1] += fy
    grad[o + 2] += (qx - ccx) * fy - (qy - ccy) * fx
    return ccx, ccy


@nb.njit(cache=True, nogil=True)
def _contact_terms(nodes, m, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, pairs, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0, fr_xw0,
                   dhat, kappa, eps_v, grad, hjp, hpp, smat, va, vf, want_hess, rec, nrec, geo, use_geo):
    """Barrier and lagged-friction forces of the window: per segment the sums of the force on the
    robot ``f`` (N), of ``p x f`` (N m) and of ``f . p`` (N m); the wall pieces' generalised forces
    go into ``grad[m:]``, the rank-one Hessian terms into ``smat``, ``hjp`` and ``hpp`` (if ``want_hess``; see
    :func:`grad_hess`; the joints-pieces couplings as records into ``rec`` instead if it has rows; with
    ``use_geo`` each pair's :func:`_pair_at` read from ``geo``, as :func:`energy` left it).  Also the
    wall's reaction against growth ``-sum s f . e_tip`` over the tip segment (N) and the total force
    on the tip segment (N)."""
    acc_f = np.zeros((m, 2))
    acc_m = np.zeros(m)
    acc_fx = np.zeros(m)
    ex = (nodes[m, 0] - nodes[m - 1, 0]) / seg_len[m - 1]
    ey = (nodes[m, 1] - nodes[m - 1, 1]) / seg_len[m - 1]
    tip = np.zeros(4)
    tip[3] = np.inf
    pose = poses(pc0, u)
    for c in range(pairs.shape[0]):
        k = pairs[c, 0]
        w = pairs[c, 1]
        if use_geo:
            cx, cy, dx, dy, s, px, py, qx, qy, dist, gap = (geo[c, 0], geo[c, 1], geo[c, 2], geo[c, 3], geo[c, 4], geo[c, 5],
                                                            geo[c, 6], geo[c, 7], geo[c, 8], geo[c, 9], geo[c, 10])
        else:
            cx, cy, dx, dy, s, px, py, qx, qy, dist, gap = _pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvert, wrad, pose)
        if gap >= dhat or gap <= 0.0:
            continue
        _, b1, b2 = _barrier(gap, dhat)
        nx = (px - qx) / dist
        ny = (py - qy) / dist
        fmag = -kappa * b1  # > 0: pushes the robot away from the wall
        p = wpiece[w]
        ccx, ccy = _apply_force(m, k, s, px, py, qx, qy, fmag * nx, fmag * ny, p, pc0, u, ex, ey, acc_f, acc_m, acc_fx, tip, grad)
        if want_hess:
            _rank1(hjp, hpp, smat, k, px, py, nodes, nx, ny, p, ccx, ccy, qx, qy, kappa * b2, rec, nrec)
            if wvert[w] and 0.0 < s < 1.0:
                # a wall vertex against the segment's side: the distance to a line that turns with the
                # joints, d2D/dphi_i dphi_j = n . (p - n_min(i,j)) - D, replaces the material point's
                # -n . (p - n_max(i,j)) (the contact point slides along the segment)
                fx = fmag * nx
                fy = fmag * ny
                acc_fx[k] -= fx * px + fy * py
                va[k] += -(fx * px + fy * py) + fmag * dist
                vf[k, 0] += fx
                vf[k, 1] += fy
                if p >= 0:  # the vertex moves with its piece; the line turns with the joints
                    o = 3 * p
                    hx = -ny * fmag
                    hy = nx * fmag
                    hr = fmag * (nx * (qx - ccx) + ny * (qy - ccy))
                    if rec.shape[0] > 0:
                        _record(rec, nrec, p, k, 1.0, 0.0, 0.0, hx, hy, hr)
                    else:
                        for j in range(k + 1):
                            hjp[j, o] += hx
                            hjp[j, o + 1] += hy
                            hjp[j, o + 2] += hr
                    hpp[p, 2, 2] -= hr
            elif _point_point(s, qx, qy, cx, cy, dx, dy, wvert[w]):  # the normal turns as p moves across
                _rank1(hjp, hpp, smat, k, px, py, nodes, -ny, nx, p, ccx, ccy, qx, qy, kappa * b1 / dist, rec, nrec)
            elif p >= 0:
                # a robot node against the side of a piece's segment: the line turns with the piece,
                # D = R(theta) n0 . (x - c - u)
                d = hpp[p]
                d[0, 2] -= fmag * ny
                d[2, 0] -= fmag * ny
                d[1, 2] += fmag * nx
                d[2, 1] += fmag * nx
                d[2, 2] += fmag * (nx * (px - ccx) + ny * (py - ccy))
                if rec.shape[0] > 0:
                    _record(rec, nrec, p, k, -fmag * (nx * px + ny * py), fmag * nx, fmag * ny, 0.0, 0.0, 1.0)
                else:
                    for j in range(k + 1):
                        hjp[j, 3 * p + 2] += -fmag * (nx * (px - nodes[j, 0]) + ny * (py - nodes[j, 1]))
    for c in range(fr_k.shape[0]):
        k, s, xr, yr, xw, yw, ut = _slip(c, nodes, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_xr0, fr_xw0, wpiece, pose)
        w = fr_w[c]
        tx = fr_t[c, 0]
        ty = fr_t[c, 1]
        _, f1y, df1 = _f0(abs(ut), eps_v)
        ff = -fr_mulam[c] * f1y * ut  # tangential force on the robot (along t)
        p = wpiece[w]
        ccx, ccy = _apply_force(m, k, s, xr, yr, xw, yw, ff * tx, ff * ty, p, pc0, u, ex, ey, acc_f, acc_m, acc_fx, tip, grad)
        if want_hess:
            _rank1(hjp, hpp, smat, k, xr, yr, nodes, tx, ty, p, ccx, ccy, xw, yw, fr_mulam[c] * df1, rec, nrec)
    return acc_f, acc_m, acc_fx, tip


@nb.njit(cache=True, nogil=True)
def segment_forces(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, wide, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0,
                   fr_xw0, dhat, kappa, eps_v):
    """The wall forces on the window at ``phi``: per segment the force (N, m x 2) and its moment
    about the origin (N m, m); and ``(F_tip, fx, fy, gap)``: the reaction against growth and the
    total force on the tip segment (N), and the tip segment's smallest gap to a candidate wall (m).
    ``wide``: the candidates' contact rows (:func:`pair_rows`) at ``phi`` with a gap below ``dhat + 1`` m."""
    nodes, _ = chain_nodes(theta0, n0, phi, seg_len)
    m = phi.shape[0]
    grad = np.zeros(m + 3 * u.shape[0])
    pairs = _rows_to_pairs(_rows_where(wide, dhat))
    acc_f, acc_m, _, tip = _contact_terms(nodes, m, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, pairs, fr_k, fr_s, fr_w, fr_wl, fr_t,
                                          fr_mulam, fr_xr0, fr_xw0, dhat, kappa, eps_v, grad, np.zeros((1, 1)), np.zeros((1, 3, 3)),
                                          np.zeros((m, 3, 3)), np.zeros(m), np.zeros((m, 2)), False, np.zeros((0, 8)),
                                          np.zeros(1, np.int64), np.zeros((0, 11)), False)
    # the tip segment's clearance among the candidates (inf if none)
    for i in range(wide.shape[0]):
        if int(wide[i, 0]) == m - 1:
            tip[3] = min(tip[3], wide[i, 10])
    return acc_f, acc_m, tip


@nb.njit(cache=True, nogil=True)
def joint_moments(phi, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual):
    """Moments (N m) of joints at ``phi`` (rad) under :func:`joint_law`."""
    out = np.empty(phi.shape[0])
    for j in range(phi.shape[0]):
        out[j] = joint_law(phi[j], k_j[j], mw_j[j], law_u, law_h, law_hi, law_slope, residual)[1]
    return out


@nb.njit(cache=True, nogil=True)
def grad_hess(nodes, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
              wa, wb, wpiece, wvert, wrad, pc0, u, pairs, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0, fr_xw0,
              dhat, kappa, eps_v, want_hess, semi, geo):
    """Gradient (n,) and Hessian of :func:`energy` at ``phi`` (its nodes ``nodes``) over
    ``z = [phi, u.ravel()]``, in blocks: joints ``hess`` (m, m), joints-pieces ``hjp`` (m, 3 npc) and
    each piece's own ``hpp`` (npc, 3, 3) (the pieces are independent springs: no piece-piece
    coupling); the Hessian drops the distance's own curvature (Gauss-Newton on the normal) but keeps
    the chain's geometric stiffness under every contact and friction force.

    The joints' block is diagonal plus semiseparable of rank 3: ``H_ij = d_j [i = j] + a_i . p_j`` for
    ``i <= j`` (``a_i = (1, x_i, y_i)`` of node ``i``).  With ``semi`` that block is returned as those
    generators, ``gen`` (m, 7) = ``[d, a, p]`` (:func:`_semi_solve`), instead of the dense ``hess`` ((1, 1)
    then), and ``hjp`` holds the joints-pieces couplings as records (:func:`_record`; every coupling is
    ``a_j``-linear on the joints ``j <= k`` proximal to its contact's segment ``k``; :func:`_semi_schur_solve`):
    returns ``(grad, hess, gen, hjp, hpp)``.  ``geo``: the pairs' geometry as :func:`energy` left it at
    this configuration (the same bits as computing it again)."""
    m = phi.shape[0]
    npc = u.shape[0]
    n = m + 3 * npc
    grad = np.zeros(n)
    dense = want_hess and not semi
    hess = np.zeros((m, m)) if dense else np.zeros((1, 1))
    gen = np.zeros((m, 7)) if want_hess and semi else np.zeros((1, 7))
    hjp = np.zeros((m, 3 * npc)) if dense else np.zeros((1, 1))
    records = want_hess and semi and npc > 0
    rec = np.empty((2 * pairs.shape[0] + fr_k.shape[0], 8)) if records else np.zeros((0, 8))
    nrec = np.zeros(1, np.int64)
    hpp = np.zeros((npc, 3, 3)) if want_hess else np.zeros((1, 3, 3))
    for j in range(m):
        _, mj, dmj = joint_law(phi[j], k_j[j], mw_j[j], law_u, law_h, law_hi, law_slope, residual)
        grad[j] += mj
        if want_hess:
            if semi:
                gen[j, 0] += dmj
            if dense:
                hess[j, j] += dmj
    smat = np.zeros((m, 3, 3))
    va = np.zeros(m)
    vf = np.zeros((m, 2))
    acc_f, acc_m, acc_fx, _ = _contact_terms(nodes, m, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, pairs, fr_k, fr_s, fr_w, fr_wl, fr_t,
                                             fr_mulam, fr_xr0, fr_xw0, dhat, kappa, eps_v, grad, hjp, hpp, smat, va, vf, want_hess,
                                             rec, nrec, geo, True)
    if records:
        hjp = rec[:nrec[0]]
    # generalised forces of the contact and friction forces on the joints: suffix sums
    sfx = 0.0
    sfy = 0.0
    sm = 0.0
    sfp = 0.0
    gsum = np.zeros(m)  # G(M) = sum_{k >= M} f . (p - n_M)
    for j in range(m - 1, -1, -1):
        sfx += acc_f[j, 0]
        sfy += acc_f[j, 1]
        sm += acc_m[j]
        sfp += acc_fx[j]
        # dE/dphi_j = -(sum (p - n_j) x f)
        grad[j] -= sm - (nodes[j, 0] * sfy - nodes[j, 1] * sfx)
        gsum[j] = sfp - (nodes[j, 0] * sfx + nodes[j, 1] * sfy)
    if want_hess:
        for k in range(m - 2, -1, -1):  # suffix sums: the contacts on segments >= k
            for r in range(3):
                for c in range(3):
                    smat[k, r, c] += smat[k + 1, r, c]
            va[k] += va[k + 1]
            vf[k, 0] += vf[k + 1, 0]
            vf[k, 1] += vf[k + 1, 1]
        # H_ij (j >= i) = w_i^T smat[j] w_j + gsum_j + va_j + vf_j . n_i with w = (1, -n_x, n_y): the
        # parts that depend on j alone first
        cj = np.empty((m, 4))
        for j in range(m):
            wj1 = -nodes[j, 0]
            wj2 = nodes[j, 1]
            cj[j, 0] = smat[j, 0, 0] + smat[j, 0, 1] * wj1 + smat[j, 0, 2] * wj2
            cj[j, 1] = smat[j, 1, 0] + smat[j, 1, 1] * wj1 + smat[j, 1, 2] * wj2
            cj[j, 2] = smat[j, 2, 0] + smat[j, 2, 1] * wj1 + smat[j, 2, 2] * wj2
            cj[j, 3] = gsum[j] + va[j]
        if semi:
            for j in range(m):
                gen[j, 1] = 1.0
                gen[j, 2] = nodes[j, 0]
                gen[j, 3] = nodes[j, 1]
                gen[j, 4] = cj[j, 0] + cj[j, 3]
                gen[j, 5] = vf[j, 0] - cj[j, 1]
                gen[j, 6] = cj[j, 2] + vf[j, 1]
        for i in range(m if dense else 0):
            wi1 = -nodes[i, 0]
            wi2 = nodes[i, 1]
            ni0 = nodes[i, 0]
            ni1 = nodes[i, 1]
            for j in range(i, m):  # max(i, j) = j
                val = cj[j, 0] + wi1 * cj[j, 1] + wi2 * cj[j, 2]
                val += cj[j, 3] + vf[j, 0] * ni0 + vf[j, 1] * ni1
                hess[i, j] += val
                if j != i:
                    hess[j, i] += val
    # compliant pieces: springs and the tether stop
    if npc > 0:
        for p in range(npc):
            o = m + 3 * p
            for i in range(3):
                grad[o + i] += fh[3 * p + i]
                for j in range(3):
                    grad[o + i] += kaa[p, i, j] * u[p, j]
                    if want_hess:
                        hpp[p, i, j] += kaa[p, i, j]
        for p in range(npc):
            r = math.sqrt(u[p, 0] ** 2 + u[p, 1] ** 2)
            if r > travel[p]:
                o = m + 3 * p
                ex = u[p, 0] / r
                ey = u[p, 1] / r
                f = k_travel[p] * (r - travel[p])
                grad[o] += f * ex
                grad[o + 1] += f * ey
                if want_hess:
                    hpp[p, 0, 0] += k_travel[p] * ex * ex + f / r * (1 - ex * ex)
                    hpp[p, 0, 1] += k_travel[p] * ex * ey - f / r * ex * ey
                    hpp[p, 1, 0] += k_travel[p] * ex * ey - f / r * ex * ey
                    hpp[p, 1, 1] += k_travel[p] * ey * ey + f / r * (1 - ey * ey)
    return grad, hess, gen, hjp, hpp


@nb.njit(cache=True, nogil=True)
def _try_cholesky(a):
    try:
        return np.linalg.cholesky(a), True
    except Exception:  # not positive definite
        return a, False


@nb.njit(cache=True, nogil=True)
def _next_shift(mu, diag_max):
    """The Levenberg shift tried after ``mu`` failed: 1e-8 of the largest diagonal term (at least
    1e-12) after zero, else ten times ``mu``."""
    return max(1e-8 * diag_max, 1e-12) if mu == 0.0 else mu * 10.0


@nb.njit(cache=True, nogil=True)
def _cholesky_solve(hess, rhs, mu0=0.0):
    """Solve ``(H + mu I) x = rhs`` with the smallest shift ``mu`` (0, then growing tenfold from
    1e-8 of the largest diagonal term) that makes the matrix positive definite (a Levenberg
    step where the collapse plateau under compression makes ``H`` indefinite); returns ``(x, mu)``,
    ``mu < 0`` if no shift did."""
    n = hess.shape[0]
    diag_max = 0.0
    for i in range(n):
        diag_max = max(diag_max, abs(hess[i, i]))
    mu = mu0
    for _ in range(40):
        a = hess.copy()
        for i in range(n):
            a[i, i] += mu
        low, ok = _try_cholesky(a)
        if ok:
            return _substitute(low, rhs), mu
        mu = _next_shift(mu, diag_max)
    return np.zeros(n), -1.0


@nb.njit(cache=True, nogil=True)
def _substitute(low, rhs):
    """Solve ``L L^T x = rhs`` for the Cholesky factor ``L`` (forward, then back substitution)."""
    n = rhs.shape[0]
    y = np.empty(n)
    for i in range(n):
        t = rhs[i]
        for k in range(i):
            t -= low[i, k] * y[k]
        y[i] = t / low[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        t = y[i]
        for k in range(i + 1, n):
            t -= low[k, i] * x[k]
        x[i] = t / low[i, i]
    return x


@nb.njit(cache=True, nogil=True)
def _semi_factor(gen, mu, q, low):
    """Cholesky factor of ``H + mu I`` for the joints' block ``H`` in generators (:func:`grad_hess`,
    ``gen = [d, a, p]``): ``L_ij = p_i . q_j`` below the diagonal, ``L_jj = low[j]``, in O(m) (``q``
    (m, 3) and ``low`` (m,) are written); whether it is positive definite.  From ``L L^T = H``:
    ``low_j^2 = d_j + mu + a_j . p_j - p_j^T P_j p_j`` and ``q_j = (a_j - P_j p_j) / low_j`` with
    ``P_j = sum_{k < j} q_k q_k^T``."""
    m = gen.shape[0]
    p00 = p01 = p02 = p11 = p12 = p22 = 0.0
    for j in range(m):
        a0, a1, a2 = gen[j, 1], gen[j, 2], gen[j, 3]
        b0, b1, b2 = gen[j, 4], gen[j, 5], gen[j, 6]
        c0 = p00 * b0 + p01 * b1 + p02 * b2
        c1 = p01 * b0 + p11 * b1 + p12 * b2
        c2 = p02 * b0 + p12 * b1 + p22 * b2
        l2 = gen[j, 0] + mu + (a0 * b0 + a1 * b1 + a2 * b2) - (b0 * c0 + b1 * c1 + b2 * c2)
        if not l2 > 0.0:
            return False
        lj = math.sqrt(l2)
        low[j] = lj
        q0 = (a0 - c0) / lj
        q1 = (a1 - c1) / lj
        q2 = (a2 - c2) / lj
        q[j, 0] = q0
        q[j, 1] = q1
        q[j, 2] = q2
        p00 += q0 * q0
        p01 += q0 * q1
        p02 += q0 * q2
        p11 += q1 * q1
        p12 += q1 * q2
        p22 += q2 * q2
    return True


@nb.njit(cache=True, nogil=True)
def _semi_diag_max(gen, hpp):
    """Largest absolute diagonal term of the Hessian: its joints' block in generators, its pieces' ``hpp``."""
    out = 0.0
    for j in range(gen.shape[0]):
        out = max(out, abs(gen[j, 0] + gen[j, 1] * gen[j, 4] + gen[j, 2] * gen[j, 5] + gen[j, 3] * gen[j, 6]))
    for p in range(hpp.shape[0]):
        for i in range(3):
            out = max(out, abs(hpp[p, i, i]))
    return out


@nb.njit(cache=True, nogil=True)
def _semi_solve(gen, rhs, mu0):
    """:func:`_cholesky_solve` for the joints' block in generators (:func:`grad_hess` with ``semi``):
    the same Levenberg shifts, each factor :func:`_semi_factor` in O(m), and the two substitutions in
    O(m) (``L_ik = p_i . q_k``: the sums over ``k`` are running sums of ``q_k y_k`` and ``p_k x_k``)."""
    m = gen.shape[0]
    diag_max = _semi_diag_max(gen, np.zeros((0, 3, 3)))
    q = np.empty((m, 3))
    low = np.empty(m)
    mu = mu0
    for _ in range(40):
        if _semi_factor(gen, mu, q, low):
            return _semi_substitute(gen, q, low, rhs), mu
        mu = _next_shift(mu, diag_max)
    return np.zeros(m), -1.0


@nb.njit(cache=True, nogil=True)
def _semi_substitute(gen, q, low, rhs):
    """Solve ``L L^T x = rhs`` for the factor of :func:`_semi_factor` (``L_ik = p_i . q_k`` below the
    diagonal: the sums over ``k`` are running sums of ``q_k y_k`` and ``p_k x_k``), in O(m)."""
    m = gen.shape[0]
    y = np.empty(m)
    s0 = s1 = s2 = 0.0
    for i in range(m):
        y[i] = (rhs[i] - (gen[i, 4] * s0 + gen[i, 5] * s1 + gen[i, 6] * s2)) / low[i]
        s0 += q[i, 0] * y[i]
        s1 += q[i, 1] * y[i]
        s2 += q[i, 2] * y[i]
    x = np.empty(m)
    t0 = t1 = t2 = 0.0
    for i in range(m - 1, -1, -1):
        x[i] = (y[i] - (q[i, 0] * t0 + q[i, 1] * t1 + q[i, 2] * t2)) / low[i]
        t0 += gen[i, 4] * x[i]
        t1 += gen[i, 5] * x[i]
        t2 += gen[i, 6] * x[i]
    return x


@nb.njit(cache=True, nogil=True)
def _mul3(a, b, out):
    """``out = a b`` for 3 x 3 matrices."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@nb.njit(cache=True, nogil=True)
def _abt3(a, b, out):
    """``out = a b^T`` for 3 x 3 matrices."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


@nb.njit(cache=True, nogil=True)
def _semi_schur_solve(gen, rec, hpp, rhs, m, npc, mu0):
    """:func:`_schur_solve` with the joints' block in generators and the joints-pieces couplings as
    records (:func:`grad_hess` with ``semi``), in O(m + pieces) per shift instead of O(m^2 pieces + m^3).

    A piece's coupling to joint ``i`` is ``a_i^T C(i)``, ``C(i)`` the sum of its records' ``c g^T`` on
    segments ``>= i``.  Eliminating the piece (its own block ``D``) adds ``-a_i^T C(i) D^-1 C(j)^T a_j``;
    for ``i < j`` that is of the generators' form ``a_i . p_j`` when ``C(i)`` is the same for every
    ``i < j`` where ``C(j) != 0``: when the piece's contacts lie on one segment or two adjacent ones
    (every piece of the colon's windows measured).  Those are eliminated into ``p`` (and the last
    segment's diagonal ``d``); any other stays an unknown beside the joints and is eliminated after
    them (its own Schur complement, one O(m) solve per column).  The same shifts are tried in the same
    order; a shift is taken when every factor is positive definite, the condition of :func:`_schur_solve`
    (the shifted Hessian positive definite).  Returns ``(x, mu)``, ``mu < 0`` if no shift did."""
    if npc == 0:
        return _semi_solve(gen, rhs, mu0)
    n = m + 3 * npc
    nrec = rec.shape[0]
    diag_max = _semi_diag_max(gen, hpp)
    klo = np.full(npc, m, np.int64)
    khi = np.full(npc, -1, np.int64)
    for r in range(nrec):
        p = int(rec[r, 0])
        k = int(rec[r, 1])
        klo[p] = min(klo[p], k)
        khi[p] = max(khi[p], k)
    # pieces on at most two adjacent segments: C on all of them and on the last; any other: a column
    # block of B (its couplings, m x 3) and a slot among the unknowns kept
    ctot = np.zeros((npc, 3, 3))
    chi = np.zeros((npc, 3, 3))
    slot = np.full(npc, -1, np.int64)
    nb_ = 0
    for p in range(npc):
        if khi[p] > klo[p] + 1:
            slot[p] = nb_
            nb_ += 1
    suf = np.zeros((max(nb_, 1), m, 3, 3))
    for r in range(nrec):
        p = int(rec[r, 0])
        k = int(rec[r, 1])
        dst = ctot[p] if slot[p] < 0 else suf[slot[p], k]
        for i in range(3):
            for j in range(3):
                cij = rec[r, 2 + i] * rec[r, 5 + j]
                dst[i, j] += cij
                if slot[p] < 0 and k > klo[p]:
                    chi[p, i, j] += cij
    bm = np.zeros((m, 3 * nb_))
    for p in range(npc):
        c = slot[p]
        if c < 0:
            continue
        for k in range(m - 2, -1, -1):  # suffix sums: the couplings on segments >= k
            for i in range(3):
                for j in range(3):
                    suf[c, k, i, j] += suf[c, k + 1, i, j]
        for k in range(m):
            for j in range(3):
                bm[k, 3 * c + j] = suf[c, k, 0, j] + gen[k, 2] * suf[c, k, 1, j] + gen[k, 3] * suf[c, k, 2, j]
    gen2 = gen.copy()
    q = np.empty((m, 3))
    low = np.empty(m)
    d = np.empty((3, 3))
    dinv = np.empty((npc, 3, 3))
    msum = np.zeros((m, 3, 3))  # C D^-1 C^T of the pieces ending at each segment (then summed from the tip)
    mhi = np.zeros((m, 3))  # the second segment's own p term, C D^-1 C_hi^T a
    vsum = np.zeros((m, 3))  # C D^-1 rhs_p likewise
    r = np.empty(m)
    cd = np.empty((3, 3))
    chd = np.empty((3, 3))
    t33 = np.empty((3, 3))
    mu = mu0
    for _ in range(40):
        if _pieces_inverse(hpp, mu, d, dinv):
            msum[:, :, :] = 0.0
            mhi[:, :] = 0.0
            vsum[:, :] = 0.0
            for j in range(m):
                gen2[j, 0] = gen[j, 0]
                r[j] = rhs[j]
            for p in range(npc):
                if khi[p] < 0 or slot[p] >= 0:
                    continue
                kl = klo[p]
                c = ctot[p]
                dv = dinv[p]
                _mul3(c, dv, cd)
                _abt3(cd, c, t33)
                o = m + 3 * p
                for i in range(3):
                    vsum[kl, i] += cd[i, 0] * rhs[o] + cd[i, 1] * rhs[o + 1] + cd[i, 2] * rhs[o + 2]
                    for j in range(3):
                        msum[kl, i, j] += t33[i, j]
                kh = khi[p]
                if kh > kl:  # on two segments: the second's row against the joints before it, and its diagonal
                    a0, a1, a2 = 1.0, gen[kh, 2], gen[kh, 3]
                    ch = chi[p]
                    _abt3(cd, ch, t33)
                    h0 = t33[0, 0] * a0 + t33[0, 1] * a1 + t33[0, 2] * a2
                    h1 = t33[1, 0] * a0 + t33[1, 1] * a1 + t33[1, 2] * a2
                    h2 = t33[2, 0] * a0 + t33[2, 1] * a1 + t33[2, 2] * a2
                    mhi[kh, 0] += h0
                    mhi[kh, 1] += h1
                    mhi[kh, 2] += h2
                    # its diagonal is -a^T C_hi D^-1 C_hi^T a, of which p gives -a^T C D^-1 C_hi^T a: d takes the rest
                    _mul3(ch, dv, chd)
                    _abt3(chd, ch, t33)
                    gen2[kh, 0] += (a0 * h0 + a1 * h1 + a2 * h2) - (
                        a0 * (t33[0, 0] * a0 + t33[0, 1] * a1 + t33[0, 2] * a2)
                        + a1 * (t33[1, 0] * a0 + t33[1, 1] * a1 + t33[1, 2] * a2)
                        + a2 * (t33[2, 0] * a0 + t33[2, 1] * a1 + t33[2, 2] * a2))
                    e0 = dv[0, 0] * rhs[o] + dv[0, 1] * rhs[o + 1] + dv[0, 2] * rhs[o + 2]
                    e1 = dv[1, 0] * rhs[o] + dv[1, 1] * rhs[o + 1] + dv[1, 2] * rhs[o + 2]
                    e2 = dv[2, 0] * rhs[o] + dv[2, 1] * rhs[o + 1] + dv[2, 2] * rhs[o + 2]
                    r[kh] -= (a0 * (ch[0, 0] * e0 + ch[0, 1] * e1 + ch[0, 2] * e2)
                              + a1 * (ch[1, 0] * e0 + ch[1, 1] * e1 + ch[1, 2] * e2)
                              + a2 * (ch[2, 0] * e0 + ch[2, 1] * e1 + ch[2, 2] * e2))
            for k in range(m - 2, -1, -1):
                for i in range(3):
                    vsum[k, i] += vsum[k + 1, i]
                    for j in range(3):
                        msum[k, i, j] += msum[k + 1, i, j]
            for j in range(m):
                a0, a1, a2 = 1.0, gen[j, 2], gen[j, 3]
                for i in range(3):
                    gen2[j, 4 + i] = gen[j, 4 + i] - (msum[j, i, 0] * a0 + msum[j, i, 1] * a1 + msum[j, i, 2] * a2) - mhi[j, i]
                r[j] -= vsum[j, 0] * a0 + vsum[j, 1] * a1 + vsum[j, 2] * a2
            if _semi_factor(gen2, mu, q, low):
                z = _semi_substitute(gen2, q, low, r)
                spd = True
                xb = np.zeros(3 * nb_)
                if nb_ > 0:  # the pieces kept: T = D + mu I - B^T S^-1 B
                    y = np.empty((m, 3 * nb_))
                    for c in range(3 * nb_):
                        y[:, c] = _semi_substitute(gen2, q, low, np.ascontiguousarray(bm[:, c]))
                    t = np.zeros((3 * nb_, 3 * nb_))
                    rb = np.empty(3 * nb_)
                    for p in range(npc):
                        c = slot[p]
                        if c < 0:
                            continue
                        for i in range(3):
                            for j in range(3):
                                t[3 * c + i, 3 * c + j] = hpp[p, i, j]
                            t[3 * c + i, 3 * c + i] += mu
                            rb[3 * c + i] = rhs[m + 3 * p + i]
                    t -= bm.T @ y
                    rb -= bm.T @ z
                    for i in range(3 * nb_):  # symmetric to rounding: its lower half
                        for j in range(i + 1, 3 * nb_):
                            t[i, j] = t[j, i]
                    lt, spd = _try_cholesky(t)
                    if spd:
                        xb = _substitute(lt, rb)
                        z -= y @ xb
                if spd:
                    x = np.empty(n)
                    x[:m] = z
                    # the eliminated pieces: x_p = D^-1 (rhs_p - B_p^T z), B_p^T z = C^T sum_{i <= k_lo} a_i z_i
                    # (+ C_hi^T a_kh z_kh on a second segment)
                    pre = np.empty((m, 3))
                    s0 = s1 = s2 = 0.0
                    for i in range(m):
                        s0 += z[i]
                        s1 += gen[i, 2] * z[i]
                        s2 += gen[i, 3] * z[i]
                        pre[i, 0] = s0
                        pre[i, 1] = s1
                        pre[i, 2] = s2
                    for p in range(npc):
                        o = m + 3 * p
                        if slot[p] >= 0:
                            for i in range(3):
                                x[o + i] = xb[3 * slot[p] + i]
                            continue
                        v0 = rhs[o]
                        v1 = rhs[o + 1]
                        v2 = rhs[o + 2]
                        if khi[p] >= 0:
                            kl = klo[p]
                            c = ctot[p]
                            v0 -= c[0, 0] * pre[kl, 0] + c[1, 0] * pre[kl, 1] + c[2, 0] * pre[kl, 2]
                            v1 -= c[0, 1] * pre[kl, 0] + c[1, 1] * pre[kl, 1] + c[2, 1] * pre[kl, 2]
                            v2 -= c[0, 2] * pre[kl, 0] + c[1, 2] * pre[kl, 1] + c[2, 2] * pre[kl, 2]
                            kh = khi[p]
                            if kh > kl:
                                ch = chi[p]
                                w0 = z[kh]
                                w1 = gen[kh, 2] * z[kh]
                                w2 = gen[kh, 3] * z[kh]
                                v0 -= ch[0, 0] * w0 + ch[1, 0] * w1 + ch[2, 0] * w2
                                v1 -= ch[0, 1] * w0 + ch[1, 1] * w1 + ch[2, 1] * w2
                                v2 -= ch[0, 2] * w0 + ch[1, 2] * w1 + ch[2, 2] * w2
                        for i in range(3):
                            x[o + i] = dinv[p, i, 0] * v0 + dinv[p, i, 1] * v1 + dinv[p, i, 2] * v2
                    return x, mu
        mu = _next_shift(mu, diag_max)
    return np.zeros(n), -1.0


@nb.njit(cache=True, nogil=True)
def _inv3_spd(d, out):
    """The inverse of a symmetric 3 x 3 matrix into ``out``; whether it is positive definite (leading
    minors; ``out`` is left unset if not)."""
    m1 = d[0, 0]
    m2 = d[0, 0] * d[1, 1] - d[0, 1] * d[1, 0]
    c00 = d[1, 1] * d[2, 2] - d[1, 2] * d[2, 1]
    c01 = d[1, 2] * d[2, 0] - d[1, 0] * d[2, 2]
    c02 = d[1, 0] * d[2, 1] - d[1, 1] * d[2, 0]
    det = d[0, 0] * c00 + d[0, 1] * c01 + d[0, 2] * c02
    if not (m1 > 0.0 and m2 > 0.0 and det > 0.0):
        return False
    out[0, 0] = c00 / det
    out[1, 0] = c01 / det
    out[2, 0] = c02 / det
    out[0, 1] = (d[0, 2] * d[2, 1] - d[0, 1] * d[2, 2]) / det
    out[1, 1] = (d[0, 0] * d[2, 2] - d[0, 2] * d[2, 0]) / det
    out[2, 1] = (d[0, 1] * d[2, 0] - d[0, 0] * d[2, 1]) / det
    out[0, 2] = (d[0, 1] * d[1, 2] - d[0, 2] * d[1, 1]) / det
    out[1, 2] = (d[0, 2] * d[1, 0] - d[0, 0] * d[1, 2]) / det
    out[2, 2] = m2 / det
    return True


@nb.njit(cache=True, nogil=True)
def _pieces_inverse(hpp, mu, d, dinv):
    """Each wall piece's own block shifted by ``mu``, inverted into ``dinv`` (``d``: a 3 x 3 scratch);
    whether every one is positive definite (stops at the first that is not)."""
    for p in range(hpp.shape[0]):
        for i in range(3):
            for j in range(3):
                d[i, j] = hpp[p, i, j]
            d[i, i] += mu
        if not _inv3_spd(d, dinv[p]):
            return False
    return True


@nb.njit(cache=True, nogil=True)
def _diag_max(hess, hpp):
    """Largest absolute diagonal term of the Hessian (its joint block ``hess``, its pieces' ``hpp``)."""
    out = 0.0
    for i in range(hess.shape[0]):
        out = max(out, abs(hess[i, i]))
    for p in range(hpp.shape[0]):
        for i in range(3):
            out = max(out, abs(hpp[p, i, i]))
    return out


@nb.njit(cache=True, nogil=True)
def _schur_solve(hess, hjp, hpp, rhs, m, npc, mu0):
    """Solve ``(H + mu I) x = rhs`` for the Hessian in :func:`grad_hess`'s blocks (``hess``, ``hjp``,
    ``hpp``; the wall pieces' block is block diagonal, each piece an independent spring): the pieces
    are eliminated (Schur complement on the joints), so the cost grows with the joints, not the pieces.
    The shift ``mu`` is the smallest (``mu0``, then growing tenfold) that makes every factor positive
    definite; returns ``(x, mu)``, ``mu < 0`` if none did."""
    if npc == 0:
        return _cholesky_solve(hess, rhs, mu0)
    n = m + 3 * npc
    diag_max = _diag_max(hess, hpp)
    coupled = np.zeros(npc, np.bool_)  # pieces a contact couples to the joints
    nc = 0
    for p in range(npc):
        o = 3 * p
        for i in range(m):
            if hjp[i, o] != 0.0 or hjp[i, o + 1] != 0.0 or hjp[i, o + 2] != 0.0:
                coupled[p] = True
                nc += 1
                break
    cols = np.empty(nc, np.int64)  # the coupled pieces, and B = H[joints, their dofs] (m x 3 nc)
    b = np.empty((m, 3 * nc))
    c = 0
    for p in range(npc):
        if coupled[p]:
            cols[c] = p
            for i in range(m):
                for j in range(3):
                    b[i, 3 * c + j] = hjp[i, 3 * p + j]
            c += 1
    bt = np.ascontiguousarray(b.T)
    mu = mu0
    d = np.empty((3, 3))
    bd = np.empty((m, 3 * nc))
    rc = np.empty(3 * nc)
    dinv = np.empty((npc, 3, 3))
    for _ in range(40):
        if _pieces_inverse(hpp, mu, d, dinv):
            # Schur complement S = H_jj + mu I - B D^-1 B^T, r = rhs_j - B D^-1 rhs_p
            for c in range(nc):
                p = cols[c]
                for j in range(3):
                    rc[3 * c + j] = rhs[m + 3 * p + j]
                    for i in range(m):
                        bd[i, 3 * c + j] = b[i, 3 * c] * dinv[p, 0, j] + b[i, 3 * c + 1] * dinv[p, 1, j] + b[i, 3 * c + 2] * dinv[p, 2, j]
            schur = hess - bd @ bt if nc else hess.copy()
            r = rhs[:m] - bd @ rc if nc else rhs[:m].copy()
            for i in range(m):
                schur[i, i] += mu
            low, spd = _try_cholesky(schur)  # else a larger shift for every factor
            if spd:
                xs = _substitute(low, r)
                x = np.empty(n)
                x[:m] = xs
                btx = bt @ xs if nc else np.zeros(0)
                c = 0
                for p in range(npc):  # x_p = D_p^-1 (rhs_p - B_p^T x_joints)
                    o = m + 3 * p
                    v = rhs[o:o + 3].copy()
                    if coupled[p]:
                        for i in range(3):
                            v[i] -= btx[3 * c + i]
                        c += 1
                    for i in range(3):
                        x[o + i] = dinv[p, i, 0] * v[0] + dinv[p, i, 1] * v[1] + dinv[p, i, 2] * v[2]
                return x, mu
        mu = _next_shift(mu, diag_max)
    return np.zeros(n), -1.0


@nb.njit(cache=True, nogil=True)
def _piece_reach(wa, wb, wpiece, npc):
    """Per wall piece: the largest distance (m) of its features' end points from its origin (a
    rotation by ``dtheta`` moves none of them by more than this times ``|dtheta|``)."""
    rho = np.zeros(npc)
    for w in range(wa.shape[0]):
        p = wpiece[w]
        if p >= 0:
            rho[p] = max(rho[p], math.sqrt(wa[w, 0] ** 2 + wa[w, 1] ** 2), math.sqrt(wb[w, 0] ** 2 + wb[w, 1] ** 2))
    return rho


@nb.njit(cache=True, nogil=True)
def _moved(nodes, ref_nodes, u, ref_u, rho):
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


@nb.njit(cache=True, nogil=True)
def _rows_where(rows, reach):
    """The contact rows (:func:`pair_rows`) with a gap below ``reach`` (m), in order."""
    cnt = 0
    for i in range(rows.shape[0]):
        if rows[i, 10] < reach:
            cnt += 1
    out = np.empty((cnt, rows.shape[1]))
    cnt = 0
    for i in range(rows.shape[0]):
        if rows[i, 10] < reach:
            out[cnt] = rows[i]
            cnt += 1
    return out


@nb.njit(cache=True, nogil=True)
def _near_pairs(nodes, pairs, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, reach):
    """The pairs ``(k, w)`` of ``pairs`` with a gap below ``reach`` (m) at ``nodes``, ``u``, in order."""
    keep = np.empty(pairs.shape[0], np.bool_)
    cnt = 0
    pose = poses(pc0, u)
    for c in range(pairs.shape[0]):
        keep[c] = _pair_at(nodes, pairs[c, 0], pairs[c, 1], seg_rad, wa, wb, wpiece, wvert, wrad, pose)[10] < reach
        cnt += keep[c]
    out = np.empty((cnt, 2), np.int64)
    cnt = 0
    for c in range(pairs.shape[0]):
        if keep[c]:
            out[cnt, 0] = pairs[c, 0]
            out[cnt, 1] = pairs[c, 1]
            cnt += 1
    return out


@nb.njit(cache=True, nogil=True)
def solve(theta0, n0, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
          wa, wb, wpiece, wvert, wrad, pc0, u, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0, fr_xw0,
          dhat, kappa, eps_v, tol_m, tol_f, max_iter, max_move, rows0, semi):
    """Newton's method on :func:`energy` from ``(phi, u)`` (updated in place); ``rows0`` the contact
    rows (:func:`pair_rows`) at the start, at least those within ``dhat + 2 max_move``; once anything
    has moved by ``max_move`` the rows are listed again from every wall (:func:`contacts`).

    Returns ``(status, iterations, residual_m, residual_f)``: the largest unbalanced joint
    moment (N m) and wall-piece force (N) at the end; ``status`` is :data:`CONVERGED` when they
    are below ``tol_m`` and ``tol_f``.  A step moves no node by more than ``max_move`` (m)."""
    m = phi.shape[0]
    npc = u.shape[0]
    n = m + 3 * npc
    rows = _rows_where(rows0, dhat + 2.0 * max_move)
    pairs = _rows_to_pairs(rows)
    anchor, _ = chain_nodes(theta0, n0, phi, seg_len)
    anchor_u = u.copy()
    # the pairs within dhat + _NEAR_MARGIN_M of the reference configuration (ref_nodes, ref_u): every pair
    # that can act while nothing has moved by more than the margin since (the others add exactly zero)
    rho = _piece_reach(wa, wb, wpiece, npc)
    near = _rows_to_pairs(_rows_where(rows, dhat + _NEAR_MARGIN_M))
    # the near pairs' geometry at the last configuration whose energy was taken: the one grad_hess is
    # asked for next (the start; an accepted trial; the start after the pairs were listed again)
    geo = np.empty((pairs.shape[0], 11))
    ref_nodes = anchor
    ref_u = u.copy()
    nodes = anchor  # of phi, as phi moves
    e0 = energy(nodes, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                wa, wb, wpiece, wvert, wrad, pc0, u, near, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam, fr_xr0, fr_xw0,
                dhat, kappa, eps_v, geo)
    if not math.isfinite(e0):
        return INFEASIBLE_START, 0, np.inf, np.inf
    res_m = np.inf
    res_f = np.inf
    shift = 0.0  # the last Levenberg shift, warm start of the next (a tenth of it)
    damp = 0.0  # Levenberg-Marquardt damping: grows while steps are cut short, shrinks when they are taken whole
    for it in range(max_iter + 1):
        grad, hess, gen, hjp, hpp = grad_hess(nodes, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                               wa, wb, wpiece, wvert, wrad, pc0, u, near, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam,
                               fr_xr0, fr_xw0, dhat, kappa, eps_v, True, semi, geo)
        res_m = 0.0
        for j in range(m):
            res_m = max(res_m, abs(grad[j]))
        res_f = 0.0
        for p in range(npc):
            res_f = max(res_f, abs(grad[m + 3 * p]), abs(grad[m + 3 * p + 1]))
            res_m = max(res_m, abs(grad[m + 3 * p + 2]))
        if res_m <= tol_m and res_f <= tol_f:
            return CONVERGED, it, res_m, res_f
        if it == max_iter:
            break
        if semi:
            step, shift = _semi_schur_solve(gen, hjp, hpp, -grad, m, npc, max(0.1 * shift, damp))
        else:
            step, shift = _schur_solve(hess, hjp, hpp, -grad, m, npc, max(0.1 * shift, damp))
        if shift < 0:
            return LINE_SEARCH_FAILED, it, res_m, res_f
        # limit the step: no joint turns by more than 0.5 rad, no node moves more than max_move
        smax = 0.0
        for j in range(m):
            smax = max(smax, abs(step[j]))
        scale = 1.0 if smax <= 0.5 else 0.5 / smax
        nodes0 = nodes
        trial_phi = phi + scale * step[:m]
        nodes1, _ = chain_nodes(theta0, n0, trial_phi, seg_len)
        move = 0.0
        for j in range(m + 1):
            move = max(move, math.sqrt((nodes1[j, 0] - nodes0[j, 0]) ** 2 + (nodes1[j, 1] - nodes0[j, 1]) ** 2))
        for p in range(npc):
            move = max(move, math.sqrt(step[m + 3 * p] ** 2 + step[m + 3 * p + 1] ** 2) * scale)
        whole = move <= max_move  # the first trial below is then this one (its nodes: nodes1)
        if not whole:
            scale *= max_move / move
        slope = 0.0
        for i in range(n):
            slope += grad[i] * step[i]
        alpha = scale
        accepted = False
        u_try = u.copy()
        for ls in range(60):
            trial_phi = phi + alpha * step[:m]
            for p in range(npc):
                u_try[p, 0] = u[p, 0] + alpha * step[m + 3 * p]
                u_try[p, 1] = u[p, 1] + alpha * step[m + 3 * p + 1]
                u_try[p, 2] = u[p, 2] + alpha * step[m + 3 * p + 2]
            if ls == 0 and whole:
                trial_nodes = nodes1
            else:
                trial_nodes, _ = chain_nodes(theta0, n0, trial_phi, seg_len)
            if _moved(trial_nodes, ref_nodes, u_try, ref_u, rho) > _NEAR_MARGIN_M - _NEAR_SLACK_M:
                near = _near_pairs(trial_nodes, pairs, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u_try, dhat + _NEAR_MARGIN_M)
                ref_nodes = trial_nodes
                ref_u = u_try.copy()
            e1 = energy(trial_nodes, trial_phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                        wa, wb, wpiece, wvert, wrad, pc0, u_try, near, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam,
                        fr_xr0, fr_xw0, dhat, kappa, eps_v, geo)
            if math.isfinite(e1) and (e1 <= e0 + 1e-4 * alpha * slope or (e1 - e0) <= 1e-13 * abs(e0)):
                accepted = True
                break
            alpha *= 0.5
        if not accepted:
            return LINE_SEARCH_FAILED, it, res_m, res_f
        # an indefinite model (a kink's plateau under compression) gives long steps that the line search
        # cuts: damp the next step instead (a trust region in Levenberg-Marquardt's form)
        if alpha < 0.1 * scale:
            damp = max(10.0 * max(damp, shift), 1e-6 * (_semi_diag_max(gen, hpp) if semi else _diag_max(hess, hpp)))
        elif alpha >= 0.5 * scale:
            damp *= 0.1
        phi[:] = trial_phi
        u[:, :] = u_try
        # rebuild the pair list once anything has moved by a step's length since it was built
        now = trial_nodes  # the nodes of the accepted phi
        nodes = now
        drift = 0.0
        for j in range(m + 1):
            drift = max(drift, math.sqrt((now[j, 0] - anchor[j, 0]) ** 2 + (now[j, 1] - anchor[j, 1]) ** 2))
        for p in range(npc):
            drift = max(drift, math.sqrt((u[p, 0] - anchor_u[p, 0]) ** 2 + (u[p, 1] - anchor_u[p, 1]) ** 2) + 0.05 * abs(u[p, 2] - anchor_u[p, 2]))
        if drift > max_move:
            # from every wall given, not only the caller's candidates: those were listed near the
            # start, and a body that moved this far may meet walls that were not among them
            rows = contacts(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, dhat, 2.0 * max_move)
            pairs = _rows_to_pairs(rows)
            geo = np.empty((pairs.shape[0], 11))
            anchor = now
            anchor_u = u.copy()
            near = _rows_to_pairs(_rows_where(rows, dhat + _NEAR_MARGIN_M))
            ref_nodes = now
            ref_u = u.copy()
            e0 = energy(nodes, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                        wa, wb, wpiece, wvert, wrad, pc0, u, near, kaa, fh, travel, k_travel, fr_k, fr_s, fr_w, fr_wl, fr_t, fr_mulam,
                        fr_xr0, fr_xw0, dhat, kappa, eps_v, geo)
        else:  # the same pairs at the accepted trial: its energy
            e0 = e1
    return MAX_ITERATIONS, max_iter, res_m, res_f


@nb.njit(cache=True, nogil=True)
def _friction_inputs(e_s, e_w, e_wl, start_nodes, s_nodes, seg_len, wpiece, pc0, u0):
    """Window segment, parameter and start positions of lagged friction entries (material
    coordinate ``e_s``, -1 for the tip's cap; wall feature ``e_w``; wall-frame point ``e_wl``)."""
    nf = e_s.shape[0]
    m = seg_len.shape[0]
    fr_k = np.empty(nf, np.int64)
    fr_s = np.empty(nf)
    fr_xr0 = np.empty((nf, 2))
    fr_xw0 = np.empty((nf, 2))
    pose = poses(pc0, u0)
    for i in range(nf):
        if e_s[i] < 0:
            k = m - 1
            s = 1.0
        else:
            k = 0
            while k < m - 1 and e_s[i] >= s_nodes[k + 1] - 1e-12:
                k += 1
            s = min(max((e_s[i] - s_nodes[k]) / seg_len[k], 0.0), 1.0)
        fr_k[i] = k
        fr_s[i] = s
        fr_xr0[i, 0] = start_nodes[k, 0] * (1 - s) + start_nodes[k + 1, 0] * s
        fr_xr0[i, 1] = start_nodes[k, 1] * (1 - s) + start_nodes[k + 1, 1] * s
        x, y = _wall_point(e_w[i], e_wl[i, 0], e_wl[i, 1], wpiece, pose)
        fr_xw0[i, 0] = x
        fr_xw0[i, 1] = y
    return fr_k, fr_s, fr_xr0, fr_xw0


@nb.njit(cache=True, nogil=True)
def _empty_entries(n):
    """``n`` lagged friction entries, unset: material coordinate, wall feature, wall-frame point,
    tangent, ``mu lambda``."""
    return np.empty(n), np.empty(n, np.int64), np.empty((n, 2)), np.empty((n, 2)), np.empty(n)


@nb.njit(cache=True, nogil=True)
def _entries(rows, s_nodes, seg_len, robot_mu, wall_mu, wpiece, pc0, u, dhat, kappa):
    """Lagged friction entries of the contacts ``rows``: material coordinate (-1: the cap), wall
    feature, wall-frame point, tangent and ``mu lambda`` (the barrier's normal force times the
    product of the robot's and the wall's coefficients, as pymunk combines them)."""
    nr = rows.shape[0]
    m = seg_len.shape[0]
    e_s, e_w, e_wl, e_t, e_ml = _empty_entries(nr)
    cnt = 0
    for i in range(nr):
        k = int(rows[i, 0])
        w = int(rows[i, 1])
        s = rows[i, 2]
        gap = rows[i, 10]
        _, b1, _ = _barrier(gap, dhat)
        lam = -kappa * b1
        mu = robot_mu[k] * wall_mu[w]
        if lam <= 0.0 or mu <= 0.0:
            continue
        e_s[cnt] = -1.0 if (k == m - 1 and s > 0.999) else s_nodes[k] + s * seg_len[k]
        e_w[cnt] = w
        qx = rows[i, 6]
        qy = rows[i, 7]
        p = wpiece[w]
        if p >= 0:
            c = math.cos(u[p, 2])
            sn = math.sin(u[p, 2])
            dx = qx - pc0[p, 0] - u[p, 0]
            dy = qy - pc0[p, 1] - u[p, 1]
            qx = c * dx + sn * dy
            qy = -sn * dx + c * dy
        e_wl[cnt, 0] = qx
        e_wl[cnt, 1] = qy
        e_t[cnt, 0] = -rows[i, 9]
        e_t[cnt, 1] = rows[i, 8]
        e_ml[cnt] = mu * lam
        cnt += 1
    return e_s[:cnt], e_w[:cnt], e_wl[:cnt], e_t[:cnt], e_ml[:cnt]


@nb.njit(cache=True, nogil=True)
def _same_entries(a_s, a_w, a_ml, b_s, b_w, b_ml, tol_f):
    """Whether two entry sets hold the same contacts with normal forces within ``tol_f``."""
    if a_s.shape[0] != b_s.shape[0]:
        return False
    for i in range(a_s.shape[0]):
        found = False
        for j in range(b_s.shape[0]):
            if a_w[i] == b_w[j] and abs(a_s[i] - b_s[j]) <= 1e-9:
                found = abs(a_ml[i] - b_ml[j]) <= tol_f
                break
        if not found:
            return False
    return True


@nb.njit(cache=True, nogil=True)
def solve_increment(theta0, n0, phi, phi_ref, seg_len, seg_rad, s_nodes, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                    wa, wb, wpiece, wvert, wrad, wall_mu, robot_mu, pc0, u, kaa, fh, travel, k_travel,
                    e_s, e_w, e_wl, e_t, e_ml, dhat, kappa, eps_v, tol_m, tol_f, max_iter, max_move, lag_iterations, semi):
    """One equilibrium of the window with lagged friction (:func:`solve`, then the normal forces
    and tangents updated from the solution and the solve repeated, at most ``lag_iterations``
    times, until they stop changing).  Friction resists slip from the configuration before the
    call, ``phi_ref`` (``phi`` may hold a predicted start).  Returns ``(status, iterations, residual_m, residual_f, entries, acc_f, acc_m, tip,
    rows)``: the new friction entries, the wall forces per segment, the tip's reaction and total
    force, and the contact rows (:func:`contacts`) at the end."""
    start_nodes, _ = chain_nodes(theta0, n0, phi_ref, seg_len)
    u0 = u.copy()
    reach = 2.0 * max_move + dhat  # candidates for every pair a solve can reach; re-listed if the body moves further
    wide = contacts(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, dhat, reach)  # their rows now
    cand = _rows_to_pairs(wide)
    wide_now = False  # whether ``wide`` holds every candidate within dhat + 1 m (segment_forces' rows)
    anchor = start_nodes.copy()
    anchor_u = u.copy()
    iters = 0
    status = CONVERGED
    res_m = 0.0
    res_f = 0.0
    rows = np.zeros((0, 11))
    for lag in range(lag_iterations + 1):
        fr_k, fr_s, fr_xr0, fr_xw0 = _friction_inputs(e_s, e_w, e_wl, start_nodes, s_nodes, seg_len, wpiece, pc0, u0)
        status, it, res_m, res_f = solve(theta0, n0, phi, seg_len, seg_rad, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual,
                                         wa, wb, wpiece, wvert, wrad, pc0, u, kaa, fh, travel, k_travel, fr_k, fr_s, e_w, e_wl, e_t,
                                         e_ml, fr_xr0, fr_xw0, dhat, kappa, eps_v, tol_m, tol_f, max_iter, max_move, wide, semi)
        iters += it
        if status == INFEASIBLE_START:
            break
        now, _ = chain_nodes(theta0, n0, phi, seg_len)
        drift = 0.0
        for j in range(now.shape[0]):
            drift = max(drift, math.sqrt((now[j, 0] - anchor[j, 0]) ** 2 + (now[j, 1] - anchor[j, 1]) ** 2))
        for p in range(u.shape[0]):
            drift = max(drift, math.sqrt((u[p, 0] - anchor_u[p, 0]) ** 2 + (u[p, 1] - anchor_u[p, 1]) ** 2)
                        + 0.05 * abs(u[p, 2] - anchor_u[p, 2]))
        if drift > 0.5 * reach:
            cand = _rows_to_pairs(contacts(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, dhat, reach))
            anchor = now
            anchor_u = u.copy()
        wide = pair_rows(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, cand, dhat, 1.0)
        wide_now = True
        rows = _rows_where(wide, dhat)
        n_s, n_w, n_wl, n_t, n_ml = _entries(rows, s_nodes, seg_len, robot_mu, wall_mu, wpiece, pc0, u, dhat, kappa)
        done = _same_entries(e_s, e_w, e_ml, n_s, n_w, n_ml, tol_f)
        e_s, e_w, e_wl, e_t, e_ml = n_s, n_w, n_wl, n_t, n_ml
        if done or lag == lag_iterations:
            break
    fr_k, fr_s, fr_xr0, fr_xw0 = _friction_inputs(e_s, e_w, e_wl, start_nodes, s_nodes, seg_len, wpiece, pc0, u0)
    if not wide_now:
        wide = pair_rows(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, cand, dhat, 1.0)
    acc_f, acc_m, tip = segment_forces(theta0, n0, phi, seg_len, seg_rad, wa, wb, wpiece, wvert, wrad, pc0, u, wide, fr_k, fr_s, e_w, e_wl,
                                       e_t, e_ml, fr_xr0, fr_xw0, dhat, kappa, eps_v)
    return status, iters, res_m, res_f, e_s, e_w, e_wl, e_t, e_ml, acc_f, acc_m, tip, rows


@nb.njit(cache=True, nogil=True)
def _segment_box(nodes, k, grow):
    """Bounding box ``(lx, hx, ly, hy)`` of segment ``k`` of ``nodes``, grown by ``grow`` (m)."""
    return (min(nodes[k, 0], nodes[k + 1, 0]) - grow, max(nodes[k, 0], nodes[k + 1, 0]) + grow,
            min(nodes[k, 1], nodes[k + 1, 1]) - grow, max(nodes[k, 1], nodes[k + 1, 1]) + grow)


@nb.njit(cache=True, nogil=True)
def overlaps(theta0, n0, phi, seg_len, seg_rad, feats, box_lo, box_hi, wa, wb, wpiece, wvert, wrad, pc0, u):
    """Whether the window ``phi`` overlaps a wall: a robot-wall pair (:func:`_pair`) with a gap at
    or below zero, among the features ``feats`` whose boxes (``box_lo``, ``box_hi``) meet a segment's.  The
    same test that makes :func:`solve` return :data:`INFEASIBLE_START`, without a solve's setup
    (a growth increment that would overlap is refused before it is assembled)."""
    nodes, _ = chain_nodes(theta0, n0, phi, seg_len)
    m = phi.shape[0]
    blocks = _block_boxes(nodes, seg_rad)
    pose = np.empty((u.shape[0], 4))
    have = np.zeros(u.shape[0], np.bool_)
    for w in feats:
        # a wall piece's box covers its whole travel: its feature where it is now (grown by its radius)
        # is a tighter test before the exact one
        flx, fhx, fly, fhy = box_lo[w, 0], box_hi[w, 0], box_lo[w, 1], box_hi[w, 1]
        posed = False
        for b in range(blocks.shape[0] - 1, -1, -1):  # from the tip, where an overlap is likeliest
            if fhx < blocks[b, 0] or flx > blocks[b, 1] or fhy < blocks[b, 2] or fly > blocks[b, 3]:
                continue
            if not posed and wpiece[w] >= 0:
                _lazy_pose(pose, have, w, wpiece, pc0, u)
                cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
                flx, fhx = min(cx, dx) - wrad[w], max(cx, dx) + wrad[w]
                fly, fhy = min(cy, dy) - wrad[w], max(cy, dy) + wrad[w]
                posed = True
                if fhx < blocks[b, 0] or flx > blocks[b, 1] or fhy < blocks[b, 2] or fly > blocks[b, 3]:
                    continue
            for k in range(min(m, (b + 1) * _BLOCK) - 1, b * _BLOCK - 1, -1):
                lx, hx, ly, hy = _segment_box(nodes, k, seg_rad[k])
                if fhx < lx or flx > hx or fhy < ly or fly > hy:
                    continue
                _lazy_pose(pose, have, w, wpiece, pc0, u)
                if _pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvert, wrad, pose)[10] <= 0.0:
                    return True
    return False


@nb.njit(cache=True, nogil=True)
def _block_boxes(nodes, grow):
    """Per block of :data:`_BLOCK` segments of the chain ``nodes``: the box ``(lx, hx, ly, hy)``
    around its segments' boxes (:func:`_segment_box`, segment ``k``'s grown by ``grow[k]``); a box
    that misses a block's misses each of its segments'."""
    m = grow.shape[0]
    out = np.empty(((m + _BLOCK - 1) // _BLOCK, 4))
    for b in range(out.shape[0]):
        out[b, 0] = np.inf
        out[b, 1] = -np.inf
        out[b, 2] = np.inf
        out[b, 3] = -np.inf
        for k in range(b * _BLOCK, min(m, (b + 1) * _BLOCK)):
            lx, hx, ly, hy = _segment_box(nodes, k, grow[k])
            out[b, 0] = min(out[b, 0], lx)
            out[b, 1] = max(out[b, 1], hx)
            out[b, 2] = min(out[b, 2], ly)
            out[b, 3] = max(out[b, 3], hy)
    return out


@nb.njit(cache=True, nogil=True)
def touching(nodes, seg_rad, box_lo, box_hi, wa, wb, wpiece, wvert, wrad, pc0, u, reach):
    """Mask of the wall features within ``reach`` (m) of a segment of the chain ``nodes``: a
    robot-wall pair (:func:`_pair`) with a gap below ``reach``."""
    nf = box_lo.shape[0]
    out = np.zeros(nf, np.bool_)
    pose = np.empty((u.shape[0], 4))
    have = np.zeros(u.shape[0], np.bool_)
    for k in range(seg_rad.shape[0]):
        lx, hx, ly, hy = _segment_box(nodes, k, seg_rad[k] + reach)
        for w in range(nf):
            if out[w] or box_hi[w, 0] < lx or box_lo[w, 0] > hx or box_hi[w, 1] < ly or box_lo[w, 1] > hy:
                continue
            _lazy_pose(pose, have, w, wpiece, pc0, u)
            if _pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvert, wrad, pose)[10] < reach:
                out[w] = True
    return out


@nb.njit(cache=True, nogil=True)
def select_features(nodes, seg_rad, box_lo, box_hi, reach):
    """Indices of the wall features (boxes ``box_lo``, ``box_hi``) within ``reach`` (m) of a
    segment's box (its nodes grown by its radius): the window's box first, then each block's of
    :data:`_BLOCK` segments (:func:`_block_boxes`), then each segment's."""
    m = seg_rad.shape[0]
    g = reach
    for k in range(m):
        g = max(g, seg_rad[k] + reach)
    wlx = nodes[0, 0]
    whx = nodes[0, 0]
    wly = nodes[0, 1]
    why = nodes[0, 1]
    for k in range(m + 1):
        wlx = min(wlx, nodes[k, 0])
        whx = max(whx, nodes[k, 0])
        wly = min(wly, nodes[k, 1])
        why = max(why, nodes[k, 1])
    blocks = _block_boxes(nodes, seg_rad + reach)
    out = np.empty(box_lo.shape[0], np.int64)
    cnt = 0
    for f in range(box_lo.shape[0]):
        if box_hi[f, 0] < wlx - g or box_lo[f, 0] > whx + g or box_hi[f, 1] < wly - g or box_lo[f, 1] > why + g:
            continue
        hit = False
        for b in range(blocks.shape[0]):
            if box_hi[f, 0] < blocks[b, 0] or box_lo[f, 0] > blocks[b, 1] or box_hi[f, 1] < blocks[b, 2] or box_lo[f, 1] > blocks[b, 3]:
                continue
            for k in range(b * _BLOCK, min(m, (b + 1) * _BLOCK)):
                lx, hx, ly, hy = _segment_box(nodes, k, seg_rad[k] + reach)
                if box_hi[f, 0] >= lx and box_lo[f, 0] <= hx and box_hi[f, 1] >= ly and box_lo[f, 1] <= hy:
                    hit = True
                    break
            if hit:
                break
        if hit:
            out[cnt] = f
            cnt += 1
    return out[:cnt]


@nb.njit(cache=True, nogil=True)
def max_node_shift(theta0, n0, phi, seg_len, ref):
    """Largest distance (m) of the chain's nodes at ``phi`` (:func:`chain_nodes`) from ``ref``."""
    nodes, _ = chain_nodes(theta0, n0, phi, seg_len)
    d = 0.0
    for j in range(nodes.shape[0]):
        d = max(d, math.hypot(nodes[j, 0] - ref[j, 0], nodes[j, 1] - ref[j, 1]))
    return d


@nb.njit(cache=True, nogil=True)
def gather_walls(sel, wa, wb, wpiece, wvert, wrad, wmu):
    """The wall features ``sel`` (indices, ascending) of the scene's arrays, in one pass."""
    k = sel.shape[0]
    a = np.empty((k, 2))
    b = np.empty((k, 2))
    piece = np.empty(k, np.int64)
    vert = np.empty(k, wvert.dtype)
    rad = np.empty(k)
    mu = np.empty(k)
    for i in range(k):
        f = sel[i]
        a[i, 0] = wa[f, 0]
        a[i, 1] = wa[f, 1]
        b[i, 0] = wb[f, 0]
        b[i, 1] = wb[f, 1]
        piece[i] = wpiece[f]
        vert[i] = wvert[f]
        rad[i] = wrad[f]
        mu[i] = wmu[f]
    return a, b, piece, vert, rad, mu


@nb.njit(cache=True, nogil=True)
def window_friction(e_s, e_wall, e_wl, e_t, e_ml, sel, ds, n, a):
    """The lagged friction entries (material coordinate ``e_s``, m, -1 for the tip's cap; wall feature
    ``e_wall``; wall point ``e_wl``; tangent ``e_t``; ``mu N`` ``e_ml``) of a solve of joints ``a..`` of
    ``n`` segments of length ``ds`` (m) seeing the features ``sel`` (ascending): whether each entry's
    robot point is in the window, and the entries in the window on a seen feature, their feature given
    as its position in ``sel``."""
    ne = e_s.shape[0]
    in_window = np.empty(ne, np.bool_)
    pos = np.empty(ne, np.int64)
    cnt = 0
    for i in range(ne):
        s = e_s[i]
        if s < 0.0:
            j = n - 1
        else:
            j = min(np.int64(math.floor(s / ds + 1e-9)), n - 1)
        in_window[i] = j >= a
        pos[i] = -1
        if in_window[i]:
            q = np.searchsorted(sel, e_wall[i])
            if q < sel.shape[0] and sel[q] == e_wall[i]:
                pos[i] = q
                cnt += 1
    o_s, o_w, o_wl, o_t, o_ml = _empty_entries(cnt)
    c = 0
    for i in range(ne):
        if pos[i] >= 0:
            o_s[c] = e_s[i]
            o_w[c] = pos[i]
            o_wl[c, 0] = e_wl[i, 0]
            o_wl[c, 1] = e_wl[i, 1]
            o_t[c, 0] = e_t[i, 0]
            o_t[c, 1] = e_t[i, 1]
            o_ml[c] = e_ml[i]
            c += 1
    return in_window, o_s, o_w, o_wl, o_t, o_ml


@nb.njit(cache=True, nogil=True)
def kinked_joints(phi, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual, fraction):
    """The joints' moments (N m, :func:`joint_moments`) and the joints whose moment reaches ``fraction``
    of the collapse moment ``2 mw_j`` (none if no joint has one)."""
    moments = joint_moments(phi, k_j, mw_j, law_u, law_h, law_hi, law_slope, residual)
    m = phi.shape[0]
    out = np.empty(m, np.int64)
    cnt = 0
    anyc = False
    for j in range(m):
        if 2.0 * mw_j[j] > 0.0:
            anyc = True
            break
    if anyc:
        for j in range(m):
            if abs(moments[j]) >= fraction * (2.0 * mw_j[j]):
                out[cnt] = j
                cnt += 1
    return moments, out[:cnt]


@nb.njit(cache=True, nogil=True)
def piece_window(nodes, seg_rad, held_nodes, held_rad, a, box_lo, box_hi, sel, a_sel, b_sel, wpiece_g, wvert, wrad, pc0, u,
                 cos_u, sin_u, reach):
    """The compliant wall pieces of a solve of joints ``a..`` (``nodes``, ``seg_rad``; the held body
    ``held_nodes``, ``held_rad``) seeing the features ``sel`` (their ends ``a_sel``, ``b_sel`` in their
    piece's frame, pieces ``wpiece_g``): the pieces within ``reach`` (m) of the window are unknowns,
    except those the held body touches (held with it, else a solve could push one into it).  Returns
    the features' ends ``wa``, ``wb`` (world coordinates for a piece held where it is, its frame for an
    unknown one), the unknown pieces (ascending) and each feature's unknown piece (its position among
    them; -1 for a static wall or a held piece).  ``cos_u``, ``sin_u``: the cosine and sine of every
    piece's rotation ``u[:, 2]``."""
    nf = sel.shape[0]
    npc = u.shape[0]
    wpiece = np.full(nf, -1, np.int64)
    any_piece = False
    for f in range(nf):
        if wpiece_g[f] >= 0:
            any_piece = True
            break
    if not any_piece:
        return a_sel, b_sel, np.zeros(0, np.int64), wpiece
    blo = np.empty((nf, 2))
    bhi = np.empty((nf, 2))
    for f in range(nf):
        blo[f, 0] = box_lo[sel[f], 0]
        blo[f, 1] = box_lo[sel[f], 1]
        bhi[f, 0] = box_hi[sel[f], 0]
        bhi[f, 1] = box_hi[sel[f], 1]
    unknown = np.zeros(npc, np.bool_)
    close = select_features(nodes, seg_rad, blo, bhi, reach)
    n_unknown = 0
    for i in range(close.shape[0]):
        p = wpiece_g[close[i]]
        if p >= 0 and not unknown[p]:
            unknown[p] = True
            n_unknown += 1
    if a > 0 and n_unknown > 0:
        held = touching(held_nodes, held_rad, blo, bhi, a_sel, b_sel, wpiece_g, wvert, wrad, pc0, u, reach)
        for f in range(nf):
            if held[f] and wpiece_g[f] >= 0:
                unknown[wpiece_g[f]] = False
    n_unknown = 0
    for p in range(npc):
        if unknown[p]:
            n_unknown += 1
    pieces = np.empty(n_unknown, np.int64)
    local = np.full(npc, -1, np.int64)
    c = 0
    for p in range(npc):
        if unknown[p]:
            pieces[c] = p
            local[p] = c
            c += 1
    wa = a_sel.copy()
    wb = b_sel.copy()
    for f in range(nf):
        p = wpiece_g[f]
        if p < 0:
            continue
        wpiece[f] = local[p]
        if unknown[p]:
            continue  # in the piece's frame
        cs = cos_u[p]
        sn = sin_u[p]
        o0 = pc0[p, 0] + u[p, 0]
        o1 = pc0[p, 1] + u[p, 1]
        wa[f, 0] = o0 + cs * a_sel[f, 0] - sn * a_sel[f, 1]
        wa[f, 1] = o1 + sn * a_sel[f, 0] + cs * a_sel[f, 1]
        wb[f, 0] = o0 + cs * b_sel[f, 0] - sn * b_sel[f, 1]
        wb[f, 1] = o1 + sn * b_sel[f, 0] + cs * b_sel[f, 1]
    return wa, wb, pieces, wpiece


@nb.njit(cache=True, nogil=True)
def window_setup(nodes, theta0, a, phi_all, seg_len_all, seg_rad_all, s_all, length, k_all, mw_all, box_lo, box_hi,
                 w_a, w_b, w_piece, w_vert, w_rad, w_mu, pc0_all, u_all, cos_u, sin_u, k_piece, travel, k_travel,
                 fr_s, fr_wall, fr_wl, fr_t, fr_ml, ds, reach, piece_reach, wall_friction, tip_friction):
    """Everything a solve of joints ``a..`` needs, in one call (the scene's chain ``nodes``, its joints'
    rotations ``phi_all`` (rad), lengths and radii (m), material coordinates of the nodes ``s_all`` and
    the tip's ``length`` (m), stiffnesses ``k_all`` and collapse moments ``mw_all``; the wall features
    (boxes, ends, pieces, vertex flags, radii, friction); the compliant pieces (rest centres ``pc0_all``,
    displacements ``u_all`` and the cosine and sine of their rotations, own stiffnesses ``k_piece``, the
    travel stop); the lagged friction entries ``fr_*``): the features within ``reach`` (m) of the window
    (:func:`select_features`), whether the window overlaps one (:func:`overlaps`; nothing else is
    gathered then), the features' arrays (:func:`gather_walls`), the unknown pieces within ``piece_reach``
    (:func:`piece_window`) and their arrays, the robot's friction coefficients per segment, and the
    friction entries in the window (:func:`window_friction`).

    Returns ``(overlap, n0, phi, seg_len, seg_rad, s_nodes, k_j, mw_j, sel, wa, wb, wpiece, w_vertex,
    w_radius, w_friction, pieces, pc0, u, kaa, fh, travel, k_travel, robot_mu, in_window, f_s, f_w, f_wl,
    f_t, f_ml)``."""
    n = phi_all.shape[0]
    m = n - a
    wnodes = nodes[a:]
    n0 = nodes[a].copy()
    phi = phi_all[a:].copy()
    seg_len = seg_len_all[a:].copy()
    seg_rad = seg_rad_all[a:].copy()
    sel = select_features(wnodes, seg_rad, box_lo, box_hi, reach)
    npc_all = pc0_all.shape[0]
    if overlaps(theta0, n0, phi, seg_len, seg_rad, sel, box_lo, box_hi, w_a, w_b, w_piece, w_vert, w_rad, pc0_all, u_all):
        e2 = np.zeros((0, 2))
        e_i = np.zeros(0, np.int64)
        e_f = np.zeros(0)
        return (True, n0, phi, seg_len, seg_rad, e_f, e_f, e_f, sel, e2, e2, e_i, np.zeros(0, w_vert.dtype), e_f, e_f, e_i,
                e2, np.zeros((0, 3)), np.zeros((0, 3, 3)), e_f, e_f, e_f, e_f, np.zeros(0, np.bool_), e_f, e_i, e2, e2, e_f)
    s_nodes = np.empty(m + 1)
    for j in range(m):
        s_nodes[j] = s_all[a + j]
    s_nodes[m] = length
    k_j = k_all[a:a + m].copy()
    mw_j = mw_all[a:a + m].copy()
    a_sel, b_sel, wpiece_g, w_vertex, w_radius, w_friction = gather_walls(sel, w_a, w_b, w_piece, w_vert, w_rad, w_mu)
    if npc_all > 0:
        wa, wb, pieces, wpiece = piece_window(wnodes, seg_rad, nodes[:a + 1], seg_rad_all[:a], a, box_lo, box_hi, sel, a_sel,
                                              b_sel, wpiece_g, w_vertex, w_radius, pc0_all, u_all, cos_u, sin_u, piece_reach)
    else:
        wa, wb = a_sel, b_sel
        pieces = np.zeros(0, np.int64)
        wpiece = np.full(sel.shape[0], -1, np.int64)
    npc = pieces.shape[0]
    pc0 = np.empty((npc, 2))
    u = np.empty((npc, 3))
    kaa = np.empty((npc, 3, 3))
    for i in range(npc):
        p = pieces[i]
        pc0[i, 0] = pc0_all[p, 0]
        pc0[i, 1] = pc0_all[p, 1]
        for c in range(3):
            u[i, c] = u_all[p, c]
            for d in range(3):
                kaa[i, c, d] = k_piece[p, c, d]
    fh = np.zeros(3 * npc)
    travel_p = np.full(npc, travel)
    k_travel_p = np.full(npc, k_travel)
    robot_mu = np.full(m, wall_friction)
    robot_mu[m - 1] = tip_friction
    in_window, f_s, f_w, f_wl, f_t, f_ml = window_friction(fr_s, fr_wall, fr_wl, fr_t, fr_ml, sel, ds, n, a)
    return (False, n0, phi, seg_len, seg_rad, s_nodes, k_j, mw_j, sel, wa, wb, wpiece, w_vertex, w_radius, w_friction, pieces,
            pc0, u, kaa, fh, travel_p, k_travel_p, robot_mu, in_window, f_s, f_w, f_wl, f_t, f_ml)


@nb.njit(cache=True, nogil=True)
def merge_friction(fr_s, fr_wall, fr_wl, fr_t, fr_ml, in_window, sel, e_s, e_w, e_wl, e_t, e_ml):
    """The lagged friction entries after a solve: those outside its window as they were, then the
    solve's own (``e_*``; their features ``e_w`` positions in ``sel``, mapped back to the scene's)."""
    keep = 0
    for i in range(fr_s.shape[0]):
        keep += not in_window[i]
    n = keep + e_s.shape[0]
    o_s, o_w, o_wl, o_t, o_ml = _empty_entries(n)
    c = 0
    for i in range(fr_s.shape[0]):
        if not in_window[i]:
            o_s[c] = fr_s[i]
            o_w[c] = fr_wall[i]
            o_wl[c, 0] = fr_wl[i, 0]
            o_wl[c, 1] = fr_wl[i, 1]
            o_t[c, 0] = fr_t[i, 0]
            o_t[c, 1] = fr_t[i, 1]
            o_ml[c] = fr_ml[i]
            c += 1
    for i in range(e_s.shape[0]):
        o_s[c] = e_s[i]
        o_w[c] = sel[e_w[i]]
        o_wl[c, 0] = e_wl[i, 0]
        o_wl[c, 1] = e_wl[i, 1]
        o_t[c, 0] = e_t[i, 0]
        o_t[c, 1] = e_t[i, 1]
        o_ml[c] = e_ml[i]
        c += 1
    return o_s, o_w, o_wl, o_t, o_ml


@nb.njit(cache=True, nogil=True)
def segment_gap(nodes, k, rad_k, sel, w_a, w_b, w_piece, w_vert, w_rad, pc0, u):
    """Smallest gap (m) between segment ``k`` of the chain ``nodes`` (radius ``rad_k``) and the wall
    segments among the features ``sel`` (vertices skipped), each piece's where its displacement ``u``
    puts it; ``inf`` if none."""
    best = np.inf
    for i in range(sel.shape[0]):
        w = sel[i]
        if w_vert[w]:
            continue
        ax, ay, bx, by = w_a[w, 0], w_a[w, 1], w_b[w, 0], w_b[w, 1]
        p = w_piece[w]
        if p >= 0:
            c = math.cos(u[p, 2])
            s = math.sin(u[p, 2])
            ox = pc0[p, 0] + u[p, 0]
            oy = pc0[p, 1] + u[p, 1]
            ax, ay, bx, by = ox + (c * ax - s * ay), oy + (s * ax + c * ay), ox + (c * bx - s * by), oy + (s * bx + c * by)
        d = _closest(nodes[k, 0], nodes[k, 1], nodes[k + 1, 0], nodes[k + 1, 1], ax, ay, bx, by)[6]
        best = min(best, d - rad_k - w_rad[w])
    return best
