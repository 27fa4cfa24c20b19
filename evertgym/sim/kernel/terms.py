"""The four terms of the incremental potential, each with its value, gradient and Hessian:

    joint law            sum_j W_j(phi_j)                     (linear, tension field, kink plateau)
    barrier              sum_pairs kappa b(d)                 (IPC's log barrier on each capsule gap)
    friction             sum_lagged mu lambda f0(|u_T|)       (IPC's smoothed lagged friction)
    wall-piece springs   1/2 u^T K u + travel(u)              (linear springs, the tether stop)

A term's value adds to a running sum (the order of the additions is the potential's; the same bits
whatever calls it).  The contact and friction terms act through points of the chain: their forces
add into per-segment sums (:class:`~evertgym.sim.kernel.bundles.Accumulators`) that
:mod:`evertgym.sim.kernel.potential` turns into the joints' gradient and Hessian.

Every Hessian is exact (``tests/test_kernel_terms.py`` holds each against central differences).
The barrier's: the rank-one ``kappa b'' g g^T`` of the distance's gradient, the chain's geometric
stiffness under the contact force, and the distance's own curvature where it has one (a pair whose
closest points are two points: ``kappa b' (I - n n^T) / dist``; a wall vertex against a segment's
side: the distance to a line that turns with the joints; a robot node against a piece's side: the
line turns with the piece; a wall point that turns with its piece).  The friction term's: the 1-D
tangent's ``f1'`` (0 once sliding), the chain's geometric stiffness under the friction force and the
turn of a piece's wall point.  The joint law's stiffness is its table's slope over a cell, consistent
with its moment to the table's resolution.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Accumulators, ContactLaw, Friction, Joints, LawTable, Pieces, Walls
from evertgym.sim.kernel.geometry import point_point, wall_point


# ---- joint law ---------------------------------------------------------------------------------
@nb.njit(cache=True, nogil=True)
def law_eval(x: float, table_u: np.ndarray, table_h: np.ndarray, table_hi: np.ndarray, slope_tail: float) -> tuple[float, float, float]:
    """Normalised wrinkled law at curvature ratio ``x >= 1`` (the table of
    :class:`~evertgym.sim.kernel.bundles.LawTable`): ``(h, dh/dx, H)`` with ``h = M / M_c`` and
    ``H = int_1^x h``; tabulated in ``ln x`` on a uniform grid, linear beyond its end."""
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
def joint_law(phi: float, k: float, mw: float, table_u: np.ndarray, table_h: np.ndarray, table_hi: np.ndarray, slope_tail: float,
              residual: float) -> tuple[float, float, float]:
    """``(W, M, dM/dphi)`` of one joint (the law's table and residual stiffness fraction as in
    :class:`~evertgym.sim.kernel.bundles.LawTable`): energy (J), moment (N m) and tangent stiffness
    (N m/rad).  Linear ``k phi`` up to the wrinkling moment ``mw``, then ``M_c h(phi / phi_w)`` (the
    tension-field law with its kink plateau, ``M_c = 2 mw``), never below ``residual k phi``.  (The
    functions called per joint take arrays, not the bundle: numba counts a reference for every array
    taken out of a tuple.)"""
    if mw <= 0.0:
        kr = residual * k
        return 0.5 * kr * phi * phi, kr * phi, kr
    phiw = mw / k
    a = abs(phi)
    if a <= phiw:
        return 0.5 * k * phi * phi, k * phi, k
    mc = 2.0 * mw
    h, dh, hi = law_eval(a / phiw, table_u, table_h, table_hi, slope_tail)
    s = 1.0 if phi > 0 else -1.0
    return 0.5 * k * phiw * phiw + mc * phiw * hi, s * mc * h, mc * dh / phiw


@nb.njit(cache=True, nogil=True)
def joint_energy(e: float, phi: np.ndarray, joints: Joints, law: LawTable) -> float:
    """``e`` plus the joints' energy (J) at ``phi``."""
    k, mw = joints
    lu, lh, lhi, slope, residual = law
    for j in range(phi.shape[0]):
        w_, _, _ = joint_law(phi[j], k[j], mw[j], lu, lh, lhi, slope, residual)
        e += w_
    return e


@nb.njit(cache=True, nogil=True)
def joint_moments(phi: np.ndarray, joints: Joints, law: LawTable) -> np.ndarray:
    """Moments (N m) of joints at ``phi`` (rad) under :func:`joint_law`."""
    out = np.empty(phi.shape[0])
    k, mw = joints
    lu, lh, lhi, slope, residual = law
    for j in range(phi.shape[0]):
        out[j] = joint_law(phi[j], k[j], mw[j], lu, lh, lhi, slope, residual)[1]
    return out


@nb.njit(cache=True, nogil=True)
def joint_grad_hess(grad: np.ndarray, diag: np.ndarray, phi: np.ndarray, joints: Joints, law: LawTable, want_hess: bool) -> None:
    """The joints' moments into ``grad[:m]`` and, if ``want_hess``, their stiffnesses into ``diag``
    (the Hessian is diagonal in the joints' own law)."""
    k, mw = joints
    lu, lh, lhi, slope, residual = law
    for j in range(phi.shape[0]):
        _, mj, dmj = joint_law(phi[j], k[j], mw[j], lu, lh, lhi, slope, residual)
        grad[j] += mj
        if want_hess:
            diag[j] += dmj


@nb.njit(cache=True, nogil=True)
def kinked_joints(phi: np.ndarray, joints: Joints, law: LawTable, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """The joints' moments (N m, :func:`joint_moments`) and the joints whose moment reaches ``fraction``
    of the collapse moment ``2 mw`` (none if no joint has one)."""
    moments = joint_moments(phi, joints, law)
    mw_j = joints.mw
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


# ---- barrier and friction: scalar laws ------------------------------------------------------------
@nb.njit(cache=True, nogil=True)
def barrier(d: float, dhat: float) -> tuple[float, float, float]:
    """``b(d), b'(d), b''(d)`` of the IPC log barrier ``b = -(d - dhat)^2 ln(d / dhat)`` (0 beyond ``dhat``)."""
    if d >= dhat:
        return 0.0, 0.0, 0.0
    r = d - dhat
    lg = math.log(d / dhat)
    return -r * r * lg, -2.0 * r * lg - r * r / d, -2.0 * lg - 4.0 * r / d + r * r / (d * d)


@nb.njit(cache=True, nogil=True)
def f0(y: float, eps: float) -> tuple[float, float, float]:
    """IPC's smoothed sliding potential: ``f0(y)``, ``f1(y) / y`` (force per slip) and ``f1'(y)``
    (the exact stiffness of the one-dimensional tangent of a planar contact: 0 once sliding)."""
    if y >= eps:
        return y, 1.0 / y, 0.0
    return y * y / eps - y ** 3 / (3.0 * eps * eps) + eps / 3.0, (2.0 / eps - y / (eps * eps)), 2.0 / eps - 2.0 * y / (eps * eps)


# ---- barrier and friction: values ---------------------------------------------------------------
@nb.njit(cache=True, nogil=True)
def barrier_energy(e: float, geo: np.ndarray, npairs: int, contact: ContactLaw) -> float:
    """``e`` plus the barrier's energy (J) of the ``npairs`` pairs whose geometry is in ``geo``
    (:func:`evertgym.sim.kernel.geometry.pair_at`); ``inf`` if a gap is not positive."""
    for c in range(npairs):
        gap = geo[c, 10]
        if gap <= 0.0:
            return np.inf
        b, _, _ = barrier(gap, contact.dhat)
        e += contact.kappa * b
    return e


@nb.njit(cache=True, nogil=True)
def slip_at(c: int, nodes: np.ndarray, fk: np.ndarray, fs: np.ndarray, fw: np.ndarray, fwl: np.ndarray, ft: np.ndarray, fxr0: np.ndarray,
            fxw0: np.ndarray, wpiece: np.ndarray, pose: np.ndarray) -> tuple[int, float, float, float, float, float, float]:
    """:func:`slip` with the entries' arrays taken out of their bundle once by the caller (numba counts
    a reference for every array taken out of a tuple: in a loop over the entries that costs more than
    the arithmetic)."""
    k = fk[c]
    s = fs[c]
    xr = nodes[k, 0] * (1 - s) + nodes[k + 1, 0] * s
    yr = nodes[k, 1] * (1 - s) + nodes[k + 1, 1] * s
    xw, yw = wall_point(fw[c], fwl[c, 0], fwl[c, 1], wpiece, pose)
    ut = ((xr - fxr0[c, 0]) - (xw - fxw0[c, 0])) * ft[c, 0] + ((yr - fxr0[c, 1]) - (yw - fxw0[c, 1])) * ft[c, 1]
    return k, s, xr, yr, xw, yw, ut


@nb.njit(cache=True, nogil=True)
def slip(c: int, nodes: np.ndarray, fr: Friction, wpiece: np.ndarray, pose: np.ndarray) -> tuple[int, float, float, float, float, float, float]:
    """Lagged friction entry ``c`` now: its segment and parameter, the robot point, the wall point and
    the tangential slip ``u_T`` (m) since the configuration before the solve."""
    return slip_at(c, nodes, fr.k, fr.s, fr.w, fr.wl, fr.t, fr.xr0, fr.xw0, wpiece, pose)


@nb.njit(cache=True, nogil=True)
def friction_energy(e: float, nodes: np.ndarray, fr: Friction, wpiece: np.ndarray, pose: np.ndarray, eps_v: float) -> float:
    """``e`` plus the lagged friction's energy (J)."""
    fk, fs, fw, fwl, ft, fmulam, fxr0, fxw0 = fr
    for c in range(fk.shape[0]):
        ut = slip_at(c, nodes, fk, fs, fw, fwl, ft, fxr0, fxw0, wpiece, pose)[6]
        f, _, _ = f0(abs(ut), eps_v)
        e += fmulam[c] * f
    return e


# ---- wall-piece springs -----------------------------------------------------------------------
@nb.njit(cache=True, nogil=True)
def piece_energy(e: float, u: np.ndarray, pieces: Pieces) -> float:
    """``e`` plus the pieces' spring energy (J): each piece's own 3 x 3 stiffness (independent
    springs), then the tether stop beyond its free travel."""
    kaa = pieces.kaa
    npc = u.shape[0]
    for p in range(npc):
        for i in range(3):
            for j in range(3):
                e += 0.5 * u[p, i] * kaa[p, i, j] * u[p, j]
    for p in range(npc):
        r = math.sqrt(u[p, 0] ** 2 + u[p, 1] ** 2)
        if r > pieces.travel[p]:
            e += 0.5 * pieces.k_travel[p] * (r - pieces.travel[p]) ** 2
    return e


@nb.njit(cache=True, nogil=True)
def piece_grad_hess(grad: np.ndarray, hpp: np.ndarray, m: int, u: np.ndarray, pieces: Pieces, want_hess: bool) -> None:
    """The pieces' spring forces into ``grad[m:]`` and their stiffness into ``hpp`` (if ``want_hess``)."""
    kaa = pieces.kaa
    npc = u.shape[0]
    for p in range(npc):
        o = m + 3 * p
        for i in range(3):
            for j in range(3):
                grad[o + i] += kaa[p, i, j] * u[p, j]
                if want_hess:
                    hpp[p, i, j] += kaa[p, i, j]
    for p in range(npc):
        r = math.sqrt(u[p, 0] ** 2 + u[p, 1] ** 2)
        travel = pieces.travel[p]
        if r > travel:
            kt = pieces.k_travel[p]
            o = m + 3 * p
            ex = u[p, 0] / r
            ey = u[p, 1] / r
            f = kt * (r - travel)
            grad[o] += f * ex
            grad[o + 1] += f * ey
            if want_hess:
                hpp[p, 0, 0] += kt * ex * ex + f / r * (1 - ex * ex)
                hpp[p, 0, 1] += kt * ex * ey - f / r * ex * ey
                hpp[p, 1, 0] += kt * ex * ey - f / r * ex * ey
                hpp[p, 1, 1] += kt * ey * ey + f / r * (1 - ey * ey)


# ---- barrier and friction: forces and Hessian parts --------------------------------------------
# (the hot loops take the accumulators' arrays out of their bundle once, and the functions they call
# take arrays: numba counts a reference for every array taken out of a tuple, which in a loop over the
# contacts cost ten times the arithmetic)
@nb.njit(cache=True, nogil=True)
def record(rec: np.ndarray, nrec: np.ndarray, piece: int, k: int, c: tuple[float, float, float], g: tuple[float, float, float]) -> None:
    """Append a coupling of wall piece ``piece`` to the joints ``j <= k``: the joints-pieces block
    gains ``(a_j . c) g^T`` in the piece's three columns, ``a_j = (1, x_j, y_j)`` node ``j``'s
    generator; a row of ``rec`` is ``[piece, k, c, g]``, ``nrec[0]`` the rows used."""
    r = nrec[0]
    rec[r, 0] = piece
    rec[r, 1] = k
    rec[r, 2] = c[0]
    rec[r, 3] = c[1]
    rec[r, 4] = c[2]
    rec[r, 5] = g[0]
    rec[r, 6] = g[1]
    rec[r, 7] = g[2]
    nrec[0] = r + 1


@nb.njit(cache=True, nogil=True)
def _add_outer(d: np.ndarray, coef: float, g0: float, g1: float, g2: float) -> None:
    """``d += coef g g^T`` for a 3 x 3 block."""
    d[0, 0] += coef * g0 * g0
    d[0, 1] += coef * g0 * g1
    d[0, 2] += coef * g0 * g2
    d[1, 0] += coef * g1 * g0
    d[1, 1] += coef * g1 * g1
    d[1, 2] += coef * g1 * g2
    d[2, 0] += coef * g2 * g0
    d[2, 1] += coef * g2 * g1
    d[2, 2] += coef * g2 * g2


@nb.njit(cache=True, nogil=True)
def rank1(smat: np.ndarray, hjp: np.ndarray, hpp: np.ndarray, rec: np.ndarray, nrec: np.ndarray, nodes: np.ndarray, k: int,
          line: tuple[float, float, float, float], piece: int, wall: tuple[float, float, float, float], coef: float) -> None:
    """Add ``coef g g^T`` for the gradient ``g`` of ``dir . (p - q)`` (``line = (p, dir)``,
    ``wall = (centre, q)``: the piece's current centre and the wall point).  Its robot part,
    ``g_j = (p - n_j) x dir = v . w_j`` for the joints ``j <= k`` with ``v = (p x dir, dir_y, dir_x)``
    and ``w_j = (1, -n_jx, n_jy)``, goes into the 3 x 3 sums ``smat[k]`` (summed from the tip and
    expanded by :mod:`evertgym.sim.kernel.potential` in O(m^2)); a wall piece's part (``-dir``,
    ``-(q - centre) x dir``) goes into its block ``hpp`` and its coupling to the joints into ``hjp``
    directly, or, if ``rec`` has rows, as one record (:func:`record`)."""
    px, py, dirx, diry = line
    cx, cy, qx, qy = wall
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
    gp2 = -((qx - cx) * diry - (qy - cy) * dirx)
    o = 3 * piece
    if rec.shape[0] > 0:
        record(rec, nrec, piece, k, (coef * v0, -coef * v1, coef * v2), (gp0, gp1, gp2))
    else:
        for j in range(k + 1):
            gj = v0 - nodes[j, 0] * v1 + nodes[j, 1] * v2
            c = coef * gj
            hjp[j, o] += c * gp0
            hjp[j, o + 1] += c * gp1
            hjp[j, o + 2] += c * gp2
    _add_outer(hpp[piece], coef, gp0, gp1, gp2)


@nb.njit(cache=True, nogil=True)
def piece_centre(piece: int, pc0: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """Wall piece ``piece``'s current centre (0, 0 for a static wall, ``piece < 0``)."""
    if piece < 0:
        return 0.0, 0.0
    return pc0[piece, 0] + u[piece, 0], pc0[piece, 1] + u[piece, 1]


@nb.njit(cache=True, nogil=True)
def apply_force(acc_f: np.ndarray, acc_m: np.ndarray, acc_fx: np.ndarray, tip: np.ndarray, grad: np.ndarray, k: int, s: float,
                pq: tuple[float, float, float, float], f: tuple[float, float], piece: int, centre: tuple[float, float],
                e_tip: tuple[float, float]) -> None:
    """A wall force ``f`` (N) on the robot at ``p`` (parameter ``s`` of segment ``k``; ``pq = (p, q)``):
    into the segment sums, the tip's reaction against growth (``-s f . e_tip``) and total force if
    ``k`` is the tip segment, and the opposite force at ``q`` on wall piece ``piece`` (if any, its
    current centre ``centre``) into ``grad``."""
    px, py, qx, qy = pq
    fx, fy = f
    m = acc_m.shape[0]
    acc_f[k, 0] += fx
    acc_f[k, 1] += fy
    acc_m[k] += px * fy - py * fx
    acc_fx[k] += fx * px + fy * py
    if k == m - 1:
        tip[0] -= s * (fx * e_tip[0] + fy * e_tip[1])
        tip[1] += fx
        tip[2] += fy
    if piece < 0:
        return
    ccx, ccy = centre
    o = m + 3 * piece
    grad[o] += fx
    grad[o + 1] += fy
    grad[o + 2] += (qx - ccx) * fy - (qy - ccy) * fx


@nb.njit(cache=True, nogil=True)
def _vertex_side(acc_fx: np.ndarray, va: np.ndarray, vf: np.ndarray, hjp: np.ndarray, hpp: np.ndarray, rec: np.ndarray, nrec: np.ndarray,
                 k: int, pq: tuple[float, float, float, float], nfd: tuple[float, float, float, float], piece: int,
                 centre: tuple[float, float]) -> None:
    """The curvature of a wall vertex's distance to a segment's side (``nfd = (n, fmag, dist)``): the
    distance to a line that turns with the joints, ``d2D/dphi_i dphi_j = n . (p - n_min(i,j)) - D``,
    replaces the material point's geometric stiffness (the contact point slides along the segment):
    ``acc_fx`` takes back its ``f . p``, ``va`` and ``vf`` carry the rest
    (:func:`evertgym.sim.kernel.potential.chain_columns`); a piece's vertex moves with the piece while
    the line turns with the joints."""
    px, py, qx, qy = pq
    nx, ny, fmag, dist = nfd
    fx = fmag * nx
    fy = fmag * ny
    acc_fx[k] -= fx * px + fy * py
    va[k] += -(fx * px + fy * py) + fmag * dist
    vf[k, 0] += fx
    vf[k, 1] += fy
    if piece < 0:
        return
    o = 3 * piece
    hx = -ny * fmag
    hy = nx * fmag
    hr = fmag * (nx * (qx - centre[0]) + ny * (qy - centre[1]))
    if rec.shape[0] > 0:
        record(rec, nrec, piece, k, (1.0, 0.0, 0.0), (hx, hy, hr))
    else:
        for j in range(k + 1):
            hjp[j, o] += hx
            hjp[j, o + 1] += hy
            hjp[j, o + 2] += hr
    hpp[piece, 2, 2] -= hr


@nb.njit(cache=True, nogil=True)
def _piece_side(hjp: np.ndarray, hpp: np.ndarray, rec: np.ndarray, nrec: np.ndarray, nodes: np.ndarray, k: int, p: tuple[float, float],
                n: tuple[float, float], fmag: float, piece: int, centre: tuple[float, float]) -> None:
    """The curvature of a robot node's distance to the side of a piece's segment: the line turns
    with the piece, ``D = R(theta) n0 . (x - c - u)``."""
    px, py = p
    nx, ny = n
    ccx, ccy = centre
    d = hpp[piece]
    d[0, 2] -= fmag * ny
    d[2, 0] -= fmag * ny
    d[1, 2] += fmag * nx
    d[2, 1] += fmag * nx
    d[2, 2] += fmag * (nx * (px - ccx) + ny * (py - ccy))
    if rec.shape[0] > 0:
        record(rec, nrec, piece, k, (-fmag * (nx * px + ny * py), fmag * nx, fmag * ny), (0.0, 0.0, 1.0))
    else:
        for j in range(k + 1):
            hjp[j, 3 * piece + 2] += -fmag * (nx * (px - nodes[j, 0]) + ny * (py - nodes[j, 1]))


@nb.njit(cache=True, nogil=True)
def barrier_forces(acc: Accumulators, nodes: np.ndarray, pairs: np.ndarray, geo: np.ndarray, walls: Walls, pc0: np.ndarray,
                   u: np.ndarray, contact: ContactLaw, e_tip: tuple[float, float], want_hess: bool) -> None:
    """The barrier's forces of the ``pairs`` (their geometry in ``geo``,
    :func:`evertgym.sim.kernel.geometry.pair_at`) into ``acc``, and if ``want_hess`` its Hessian
    parts: the rank-one term of the distance's gradient and the distance's own curvature."""
    grad, acc_f, acc_m, acc_fx, tip, smat, va, vf, hjp, hpp, rec, nrec = acc
    dhat = contact.dhat
    kappa = contact.kappa
    wpiece = walls.piece
    wvertex = walls.vertex
    for c in range(pairs.shape[0]):
        k = pairs[c, 0]
        w = pairs[c, 1]
        cx, cy, dx, dy, s, px, py, qx, qy, dist, gap = (geo[c, 0], geo[c, 1], geo[c, 2], geo[c, 3], geo[c, 4], geo[c, 5],
                                                        geo[c, 6], geo[c, 7], geo[c, 8], geo[c, 9], geo[c, 10])
        if gap >= dhat or gap <= 0.0:
            continue
        _, b1, b2 = barrier(gap, dhat)
        nx = (px - qx) / dist
        ny = (py - qy) / dist
        fmag = -kappa * b1  # > 0: pushes the robot away from the wall
        p = wpiece[w]
        centre = piece_centre(p, pc0, u)
        apply_force(acc_f, acc_m, acc_fx, tip, grad, k, s, (px, py, qx, qy), (fmag * nx, fmag * ny), p, centre, e_tip)
        if not want_hess:
            continue
        wall = (centre[0], centre[1], qx, qy)
        rank1(smat, hjp, hpp, rec, nrec, nodes, k, (px, py, nx, ny), p, wall, kappa * b2)
        if wvertex[w] and 0.0 < s < 1.0:
            _vertex_side(acc_fx, va, vf, hjp, hpp, rec, nrec, k, (px, py, qx, qy), (nx, ny, fmag, dist), p, centre)
        elif point_point(s, (qx, qy), (cx, cy, dx, dy), wvertex[w]):  # the normal turns as p moves across
            rank1(smat, hjp, hpp, rec, nrec, nodes, k, (px, py, -ny, nx), p, wall, kappa * b1 / dist)
            if p >= 0:  # the wall point turns with its piece
                hpp[p, 2, 2] -= fmag * (nx * (qx - centre[0]) + ny * (qy - centre[1]))
        elif p >= 0:
            _piece_side(hjp, hpp, rec, nrec, nodes, k, (px, py), (nx, ny), fmag, p, centre)


@nb.njit(cache=True, nogil=True)
def friction_forces(acc: Accumulators, nodes: np.ndarray, fr: Friction, wpiece: np.ndarray, pose: np.ndarray, pc0: np.ndarray,
                    u: np.ndarray, eps_v: float, e_tip: tuple[float, float], want_hess: bool) -> None:
    """The lagged friction's forces into ``acc``, and if ``want_hess`` the rank-one ``f1'`` term of
    each entry's 1-D tangent."""
    grad, acc_f, acc_m, acc_fx, tip, smat, _, _, hjp, hpp, rec, nrec = acc
    fk, fs, fw, fwl, ft, fmulam, fxr0, fxw0 = fr
    for c in range(fk.shape[0]):
        k, s, xr, yr, xw, yw, ut = slip_at(c, nodes, fk, fs, fw, fwl, ft, fxr0, fxw0, wpiece, pose)
        tx = ft[c, 0]
        ty = ft[c, 1]
        _, f1y, df1 = f0(abs(ut), eps_v)
        ff = -fmulam[c] * f1y * ut  # tangential force on the robot (along t)
        p = wpiece[fw[c]]
        centre = piece_centre(p, pc0, u)
        apply_force(acc_f, acc_m, acc_fx, tip, grad, k, s, (xr, yr, xw, yw), (ff * tx, ff * ty), p, centre, e_tip)
        if want_hess:
            rank1(smat, hjp, hpp, rec, nrec, nodes, k, (xr, yr, tx, ty), p, (centre[0], centre[1], xw, yw), fmulam[c] * df1)
            if p >= 0:  # the wall point turns with its piece
                hpp[p, 2, 2] -= ff * (tx * (xw - centre[0]) + ty * (yw - centre[1]))
