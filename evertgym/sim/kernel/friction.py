"""Lagged friction entries: resolving them on a window's segments, new ones from the contacts at a
solution, and whether two sets are the same (the friction lag's stop)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import ContactLaw, Entries, Friction, Walls
from evertgym.sim.kernel.geometry import poses, wall_point
from evertgym.sim.kernel.terms import barrier

#: A material coordinate this close (m) below a node's counts as that node's segment.
NODE_TOLERANCE_M = 1e-12
#: A contact on the tip segment beyond this parameter is on the tip's cap (always the newest material).
CAP_PARAMETER = 0.999
#: Two entries at the same material coordinate within this (m) are the same contact.
SAME_POINT_M = 1e-9


@nb.njit(cache=True, nogil=True)
def empty_entries(n: int) -> Entries:
    """``n`` lagged friction entries, unset."""
    return Entries(np.empty(n), np.empty(n, np.int64), np.empty((n, 2)), np.empty((n, 2)), np.empty(n))


@nb.njit(cache=True, nogil=True)
def resolve(entries: Entries, start_nodes: np.ndarray, s_nodes: np.ndarray, seg_len: np.ndarray, wpiece: np.ndarray,
            pc0: np.ndarray, u0: np.ndarray) -> Friction:
    """The entries on the window's segments (:class:`~evertgym.sim.kernel.bundles.Friction`): each one's
    segment and parameter, and its robot and wall points at the start (``start_nodes``, ``u0``)."""
    e_s = entries.s
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
            while k < m - 1 and e_s[i] >= s_nodes[k + 1] - NODE_TOLERANCE_M:
                k += 1
            s = min(max((e_s[i] - s_nodes[k]) / seg_len[k], 0.0), 1.0)
        fr_k[i] = k
        fr_s[i] = s
        fr_xr0[i, 0] = start_nodes[k, 0] * (1 - s) + start_nodes[k + 1, 0] * s
        fr_xr0[i, 1] = start_nodes[k, 1] * (1 - s) + start_nodes[k + 1, 1] * s
        x, y = wall_point(entries.w[i], entries.wl[i, 0], entries.wl[i, 1], wpiece, pose)
        fr_xw0[i, 0] = x
        fr_xw0[i, 1] = y
    return Friction(fr_k, fr_s, entries.w, entries.wl, entries.t, entries.ml, fr_xr0, fr_xw0)


@nb.njit(cache=True, nogil=True)
def new_entries(rows: np.ndarray, s_nodes: np.ndarray, seg_len: np.ndarray, robot_mu: np.ndarray, wall_mu: np.ndarray,
                walls: Walls, pc0: np.ndarray, u: np.ndarray, contact: ContactLaw) -> Entries:
    """Lagged friction entries of the contacts ``rows``: the wall point in its feature's frame, the
    tangent and ``mu lambda`` (the barrier's normal force times the product of the robot's and the
    wall's coefficients, as pymunk combines them)."""
    nr = rows.shape[0]
    m = seg_len.shape[0]
    e = empty_entries(nr)
    cnt = 0
    for i in range(nr):
        k = int(rows[i, 0])
        w = int(rows[i, 1])
        s = rows[i, 2]
        _, b1, _ = barrier(rows[i, 10], contact.dhat)
        lam = -contact.kappa * b1
        mu = robot_mu[k] * wall_mu[w]
        if lam <= 0.0 or mu <= 0.0:
            continue
        e.s[cnt] = -1.0 if (k == m - 1 and s > CAP_PARAMETER) else s_nodes[k] + s * seg_len[k]
        e.w[cnt] = w
        qx = rows[i, 6]
        qy = rows[i, 7]
        p = walls.piece[w]
        if p >= 0:
            c = math.cos(u[p, 2])
            sn = math.sin(u[p, 2])
            dx = qx - pc0[p, 0] - u[p, 0]
            dy = qy - pc0[p, 1] - u[p, 1]
            qx = c * dx + sn * dy
            qy = -sn * dx + c * dy
        e.wl[cnt, 0] = qx
        e.wl[cnt, 1] = qy
        e.t[cnt, 0] = -rows[i, 9]
        e.t[cnt, 1] = rows[i, 8]
        e.ml[cnt] = mu * lam
        cnt += 1
    return Entries(e.s[:cnt], e.w[:cnt], e.wl[:cnt], e.t[:cnt], e.ml[:cnt])


@nb.njit(cache=True, nogil=True)
def same_entries(a: Entries, b: Entries, tol_f: float) -> bool:
    """Whether two entry sets hold the same contacts with normal forces within ``tol_f``."""
    if a.s.shape[0] != b.s.shape[0]:
        return False
    for i in range(a.s.shape[0]):
        found = False
        for j in range(b.s.shape[0]):
            if a.w[i] == b.w[j] and abs(a.s[i] - b.s[j]) <= SAME_POINT_M:
                found = abs(a.ml[i] - b.ml[j]) <= tol_f
                break
        if not found:
            return False
    return True
