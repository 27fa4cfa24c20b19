"""The incremental potential of a window and its gradient and Hessian: the four terms of
:mod:`evertgym.sim.kernel.terms` summed, and the contact and friction forces (which act at points
of the chain) carried onto the joints.

The unknowns are ``z = [phi, u.ravel()]``: the window's joint rotations (rad) and the wall pieces'
displacements ``(dx, dy, dtheta)``.  A force ``f`` at a point ``p`` of segment ``k`` has the
generalised force ``(p - n_j) x f`` on every joint ``j <= k`` (suffix sums from the tip), and the
joints' block of the Hessian is diagonal plus semiseparable of rank 3:
``H_ij = d_j [i = j] + a_i . p_j`` for ``i <= j`` with ``a_i = (1, x_i, y_i)`` of node ``i``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Accumulators, Friction, Hessian, Problem
from evertgym.sim.kernel.geometry import pair_at, poses
from evertgym.sim.kernel.terms import (
    barrier_energy,
    barrier_forces,
    friction_energy,
    friction_forces,
    joint_energy,
    joint_grad_hess,
    piece_energy,
    piece_grad_hess,
)

#: Columns of a pair's geometry row (:func:`evertgym.sim.kernel.geometry.pair_at`).
GEO_COLUMNS = 11


@nb.njit(cache=True, nogil=True)
def pair_geometry(nodes: np.ndarray, pairs: np.ndarray, problem: Problem, pose: np.ndarray, geo: np.ndarray) -> None:
    """Each pair's :func:`~evertgym.sim.kernel.geometry.pair_at` into row ``c`` of ``geo``."""
    seg_rad = problem.chain.seg_rad
    wa, wb, wpiece, wvertex, wradius = problem.walls
    for c in range(pairs.shape[0]):
        g = pair_at(nodes, pairs[c, 0], pairs[c, 1], seg_rad, wa, wb, wpiece, wvertex, wradius, pose)
        for i in range(GEO_COLUMNS):
            geo[c, i] = g[i]


@nb.njit(cache=True, nogil=True)
def energy(problem: Problem, phi: np.ndarray, u: np.ndarray, nodes: np.ndarray, pairs: np.ndarray, fr: Friction,
           geo: np.ndarray) -> float:
    """The incremental potential (J) at ``phi``, ``u`` (``nodes`` those of ``phi``); ``inf`` where any
    robot-wall gap is not positive.  Each pair's geometry goes into row ``c`` of ``geo`` (at least
    as many rows as ``pairs``): :func:`grad_hess` at the same configuration reads it there."""
    e = joint_energy(0.0, phi, problem.joints, problem.law)
    pose = poses(problem.pieces.pc0, u)
    pair_geometry(nodes, pairs, problem, pose, geo)
    e = barrier_energy(e, geo, pairs.shape[0], problem.contact)
    if e == np.inf:
        return e
    e = friction_energy(e, nodes, fr, problem.walls.piece, pose, problem.contact.eps_v)
    if u.shape[0] > 0:
        e = piece_energy(e, u, problem.pieces)
    return e


@nb.njit(cache=True, nogil=True)
def new_accumulators(m: int, npc: int, hess_jp: np.ndarray, hpp: np.ndarray, rec: np.ndarray) -> Accumulators:
    """Zeroed per-segment sums for a window of ``m`` segments and ``npc`` pieces, adding into the given
    joints-pieces block ``hess_jp``, pieces' blocks ``hpp`` and records ``rec``."""
    tip = np.zeros(4)
    tip[3] = np.inf
    return Accumulators(np.zeros(m + 3 * npc), np.zeros((m, 2)), np.zeros(m), np.zeros(m), tip, np.zeros((m, 3, 3)),
                        np.zeros(m), np.zeros((m, 2)), hess_jp, hpp, rec, np.zeros(1, np.int64))


@nb.njit(cache=True, nogil=True)
def contact_forces(acc: Accumulators, problem: Problem, u: np.ndarray, nodes: np.ndarray, pairs: np.ndarray, fr: Friction,
                   geo: np.ndarray, want_hess: bool) -> None:
    """The barrier's and the lagged friction's forces (and Hessian parts) of the window into ``acc``."""
    m = nodes.shape[0] - 1
    seg_len = problem.chain.seg_len
    e_tip = ((nodes[m, 0] - nodes[m - 1, 0]) / seg_len[m - 1], (nodes[m, 1] - nodes[m - 1, 1]) / seg_len[m - 1])
    pc0 = problem.pieces.pc0
    pose = poses(pc0, u)
    barrier_forces(acc, nodes, pairs, geo, problem.walls, pc0, u, problem.contact, e_tip, want_hess)
    friction_forces(acc, nodes, fr, problem.walls.piece, pose, pc0, u, problem.contact.eps_v, e_tip, want_hess)


@nb.njit(cache=True, nogil=True)
def chain_gradient(acc: Accumulators, nodes: np.ndarray) -> np.ndarray:
    """The contact and friction forces' generalised forces on the joints into ``acc.grad[:m]``
    (``dE/dphi_j = -sum (p - n_j) x f`` over the segments from ``j`` to the tip, suffix sums); returns
    ``G(j) = sum_{k >= j} f . (p - n_j)``, the chain's geometric stiffness under those forces."""
    m = acc.acc_m.shape[0]
    grad = acc.grad
    sfx = 0.0
    sfy = 0.0
    sm = 0.0
    sfp = 0.0
    gsum = np.zeros(m)
    for j in range(m - 1, -1, -1):
        sfx += acc.acc_f[j, 0]
        sfy += acc.acc_f[j, 1]
        sm += acc.acc_m[j]
        sfp += acc.acc_fx[j]
        grad[j] -= sm - (nodes[j, 0] * sfy - nodes[j, 1] * sfx)
        gsum[j] = sfp - (nodes[j, 0] * sfx + nodes[j, 1] * sfy)
    return gsum


@nb.njit(cache=True, nogil=True)
def chain_columns(acc: Accumulators, nodes: np.ndarray, gsum: np.ndarray) -> np.ndarray:
    """The parts of the joints' Hessian that depend on the later joint alone: with the contacts' sums
    taken from the tip, ``H_ij (j >= i) = w_i^T smat[j] w_j + gsum_j + va_j + vf_j . (n_i + n_j)`` with
    ``w = (1, -n_x, n_y)``; returns ``cj`` (m, 4) = ``[smat[j] w_j, gsum_j + va_j + vf_j . n_j]``.

    ``vf_j``, the forces of wall vertices on the sides of segments ``>= j``, act at points that slide
    along their segments: the curvature of such a distance is ``n . (p - n_min(i,j)) - D``
    (:func:`~evertgym.sim.kernel.terms.barrier_forces`), and ``vf_j . n_j`` takes back the ``-f . n_j``
    that ``gsum_j``, the geometric stiffness of forces at material points, holds for them."""
    smat = acc.smat
    va = acc.va
    vf = acc.vf
    m = gsum.shape[0]
    for k in range(m - 2, -1, -1):  # suffix sums: the contacts on segments >= k
        for r in range(3):
            for c in range(3):
                smat[k, r, c] += smat[k + 1, r, c]
        va[k] += va[k + 1]
        vf[k, 0] += vf[k + 1, 0]
        vf[k, 1] += vf[k + 1, 1]
    cj = np.empty((m, 4))
    for j in range(m):
        wj1 = -nodes[j, 0]
        wj2 = nodes[j, 1]
        cj[j, 0] = smat[j, 0, 0] + smat[j, 0, 1] * wj1 + smat[j, 0, 2] * wj2
        cj[j, 1] = smat[j, 1, 0] + smat[j, 1, 1] * wj1 + smat[j, 1, 2] * wj2
        cj[j, 2] = smat[j, 2, 0] + smat[j, 2, 1] * wj1 + smat[j, 2, 2] * wj2
        cj[j, 3] = gsum[j] + va[j] + (vf[j, 0] * nodes[j, 0] + vf[j, 1] * nodes[j, 1])
    return cj


@nb.njit(cache=True, nogil=True)
def semi_generators(gen: np.ndarray, nodes: np.ndarray, cj: np.ndarray, vf: np.ndarray) -> None:
    """The joints' block as generators ``gen[:, 1:]`` = ``[a, p]`` (``gen[:, 0]``, the diagonal ``d``,
    holds the joints' own stiffness)."""
    for j in range(gen.shape[0]):
        gen[j, 1] = 1.0
        gen[j, 2] = nodes[j, 0]
        gen[j, 3] = nodes[j, 1]
        gen[j, 4] = cj[j, 0] + cj[j, 3]
        gen[j, 5] = vf[j, 0] - cj[j, 1]
        gen[j, 6] = cj[j, 2] + vf[j, 1]


@nb.njit(cache=True, nogil=True)
def dense_joints(hess: np.ndarray, nodes: np.ndarray, cj: np.ndarray, vf: np.ndarray) -> None:
    """The joints' block expanded into ``hess`` (m, m) in O(m^2)."""
    m = hess.shape[0]
    for i in range(m):
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


@nb.njit(cache=True, nogil=True)
def grad_hess(problem: Problem, phi: np.ndarray, u: np.ndarray, nodes: np.ndarray, pairs: np.ndarray, fr: Friction,
              geo: np.ndarray, want_hess: bool, semi: bool) -> tuple[np.ndarray, Hessian]:
    """Gradient (n,) and Hessian (:class:`~evertgym.sim.kernel.bundles.Hessian`) of :func:`energy` at
    ``phi``, ``u`` (``nodes`` those of ``phi``; ``geo`` the pairs' geometry as :func:`energy` left it
    at this configuration).  With ``semi`` the joints' block comes as generators and the
    joints-pieces couplings as records (every coupling is ``a_j``-linear on the joints ``j <= k``
    proximal to its contact's segment ``k``), else both dense."""
    m = phi.shape[0]
    npc = u.shape[0]
    dense = want_hess and not semi
    hess = np.zeros((m, m)) if dense else np.zeros((1, 1))
    gen = np.zeros((m, 7)) if want_hess and semi else np.zeros((1, 7))
    hjp = np.zeros((m, 3 * npc)) if dense else np.zeros((1, 1))
    records = want_hess and semi and npc > 0
    rec = np.empty((2 * pairs.shape[0] + fr.k.shape[0], 8)) if records else np.zeros((0, 8))
    hpp = np.zeros((npc, 3, 3)) if want_hess else np.zeros((1, 3, 3))
    acc = new_accumulators(m, npc, hjp, hpp, rec)
    diag = np.zeros(m)
    joint_grad_hess(acc.grad, diag, phi, problem.joints, problem.law, want_hess)
    if want_hess:
        for j in range(m):
            if semi:
                gen[j, 0] += diag[j]
            if dense:
                hess[j, j] += diag[j]
    contact_forces(acc, problem, u, nodes, pairs, fr, geo, want_hess)
    if records:
        hjp = rec[:acc.nrec[0]]
    gsum = chain_gradient(acc, nodes)
    if want_hess:
        cj = chain_columns(acc, nodes, gsum)
        if semi:
            semi_generators(gen, nodes, cj, acc.vf)
        if dense:
            dense_joints(hess, nodes, cj, acc.vf)
    if npc > 0:
        piece_grad_hess(acc.grad, hpp, m, u, problem.pieces, want_hess)
    return acc.grad, Hessian(hess, gen, hjp, hpp)
