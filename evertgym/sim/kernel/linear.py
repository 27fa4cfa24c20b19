"""Linear solves of a Newton step: ``(H + mu I) x = rhs`` with the smallest Levenberg shift ``mu``
that makes the matrix positive definite (a collapse plateau under compression makes ``H``
indefinite).  Two solvers of the same system (``SimConfig.linear_solver``):

* dense: the joints' block as an (m, m) matrix, Cholesky; the wall pieces (block diagonal, each an
  independent spring) eliminated by a Schur complement on the joints (:func:`schur_solve`);
* semiseparable: the joints' block in generators (diagonal plus rank 3, ``H_ij = d_j [i = j] +
  a_i . p_j`` for ``i <= j``), factored in O(m) (:func:`semi_factor`); the pieces' couplings as records
  eliminated into the generators where they allow it (:func:`semi_schur_solve`).
"""

# (no ``from __future__ import annotations``: the NamedTuples' fields keep their types as objects, which
# the API reference resolves)
import math
from typing import NamedTuple

import numba as nb
import numpy as np

#: Shifts tried (growing tenfold) before a solve gives up (those below the first non-zero one not counted).
MAX_SHIFTS = 40
#: The first non-zero shift, as a fraction of the largest diagonal term ...
FIRST_SHIFT_FRACTION = 1e-8
#: ... and at least this (a zero Hessian).
MIN_SHIFT = 1e-12
#: The growth of the shift after a failed factorisation.
SHIFT_GROWTH = 10.0


@nb.njit(cache=True, nogil=True)
def try_cholesky(a: np.ndarray) -> tuple[np.ndarray, bool]:
    """The Cholesky factor of ``a`` and True, or ``a`` and False if it is not positive definite."""
    try:
        return np.linalg.cholesky(a), True
    except Exception:  # not positive definite
        return a, False


@nb.njit(cache=True, nogil=True)
def next_shift(mu: float, diag_max: float) -> float:
    """The Levenberg shift tried after ``mu`` failed: 1e-8 of the largest diagonal term (at least
    1e-12) after zero, else ten times ``mu``."""
    return max(FIRST_SHIFT_FRACTION * diag_max, MIN_SHIFT) if mu == 0.0 else mu * SHIFT_GROWTH


@nb.njit(cache=True, nogil=True)
def counted(mu: float, diag_max: float) -> bool:
    """Whether a failed shift ``mu`` counts among the :data:`MAX_SHIFTS` tries: zero and every shift from
    1e-8 of the largest diagonal term do; one below that does not.  The Newton driver warm-starts the
    shift from a tenth of the last one, which decays while the Hessian stays positive definite (to 1e-67
    at one U-bend stall); from there forty tenfold tries would end near 1e-27, and the step would fail on
    a Hessian that a shift of the usual size makes positive definite."""
    return mu == 0.0 or mu >= max(FIRST_SHIFT_FRACTION * diag_max, MIN_SHIFT)


@nb.njit(cache=True, nogil=True)
def cholesky_solve(hess: np.ndarray, rhs: np.ndarray, mu0: float = 0.0) -> tuple[np.ndarray, float]:
    """Solve ``(H + mu I) x = rhs`` with the smallest shift ``mu`` (0, then growing tenfold from
    1e-8 of the largest diagonal term) that makes the matrix positive definite (a Levenberg
    step where the collapse plateau under compression makes ``H`` indefinite); returns ``(x, mu)``,
    ``mu < 0`` if no shift did."""
    n = hess.shape[0]
    diag_max = 0.0
    for i in range(n):
        diag_max = max(diag_max, abs(hess[i, i]))
    mu = mu0
    tries = 0
    while tries < MAX_SHIFTS:
        a = hess.copy()
        for i in range(n):
            a[i, i] += mu
        low, ok = try_cholesky(a)
        if ok:
            return substitute(low, rhs), mu
        tries += counted(mu, diag_max)
        mu = next_shift(mu, diag_max)
    return np.zeros(n), -1.0


@nb.njit(cache=True, nogil=True)
def substitute(low: np.ndarray, rhs: np.ndarray) -> np.ndarray:
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
def semi_factor(gen: np.ndarray, mu: float, q: np.ndarray, low: np.ndarray) -> bool:
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
def semi_diag_max(gen: np.ndarray, hpp: np.ndarray) -> float:
    """Largest absolute diagonal term of the Hessian: its joints' block in generators, its pieces' ``hpp``."""
    out = 0.0
    for j in range(gen.shape[0]):
        out = max(out, abs(gen[j, 0] + gen[j, 1] * gen[j, 4] + gen[j, 2] * gen[j, 5] + gen[j, 3] * gen[j, 6]))
    for p in range(hpp.shape[0]):
        for i in range(3):
            out = max(out, abs(hpp[p, i, i]))
    return out


@nb.njit(cache=True, nogil=True)
def semi_solve(gen: np.ndarray, rhs: np.ndarray, mu0: float) -> tuple[np.ndarray, float]:
    """:func:`cholesky_solve` for the joints' block in generators (:func:`grad_hess` with ``semi``):
    the same Levenberg shifts, each factor :func:`semi_factor` in O(m), and the two substitutions in
    O(m) (``L_ik = p_i . q_k``: the sums over ``k`` are running sums of ``q_k y_k`` and ``p_k x_k``)."""
    m = gen.shape[0]
    diag_max = semi_diag_max(gen, np.zeros((0, 3, 3)))
    q = np.empty((m, 3))
    low = np.empty(m)
    mu = mu0
    tries = 0
    while tries < MAX_SHIFTS:
        if semi_factor(gen, mu, q, low):
            return semi_substitute(gen, q, low, rhs), mu
        tries += counted(mu, diag_max)
        mu = next_shift(mu, diag_max)
    return np.zeros(m), -1.0


@nb.njit(cache=True, nogil=True)
def semi_substitute(gen: np.ndarray, q: np.ndarray, low: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``L L^T x = rhs`` for the factor of :func:`semi_factor` (``L_ik = p_i . q_k`` below the
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
def mul3(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a b`` for 3 x 3 matrices."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@nb.njit(cache=True, nogil=True)
def abt3(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a b^T`` for 3 x 3 matrices."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


class PieceCouplings(NamedTuple):
    """How the semiseparable solver eliminates each wall piece (:func:`piece_couplings`): the
    segments its records lie on (``klo``..``khi``; ``khi < 0``: none), its slot among the pieces kept
    as unknowns (``slot``, -1: eliminated into the generators; ``n_kept`` of them), its couplings
    summed over all its segments (``ctot``) and over the second (``chi``), and the kept pieces'
    coupling columns ``bm`` (m, 3 n_kept)."""

    klo: np.ndarray
    khi: np.ndarray
    slot: np.ndarray
    n_kept: int
    ctot: np.ndarray
    chi: np.ndarray
    bm: np.ndarray


@nb.njit(cache=True, nogil=True)
def piece_couplings(gen: np.ndarray, rec: np.ndarray, m: int, npc: int) -> PieceCouplings:
    """Sort the pieces' coupling records (:func:`evertgym.sim.kernel.terms.record`): a piece on at
    most two adjacent segments is eliminated into the generators (its ``C`` on all of them and on the
    last); any other keeps its unknowns, a column block of ``B`` (its couplings, m x 3)."""
    nrec = rec.shape[0]
    klo = np.full(npc, m, np.int64)
    khi = np.full(npc, -1, np.int64)
    for r in range(nrec):
        p = int(rec[r, 0])
        k = int(rec[r, 1])
        klo[p] = min(klo[p], k)
        khi[p] = max(khi[p], k)
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
    return PieceCouplings(klo, khi, slot, nb_, ctot, chi, bm)


@nb.njit(cache=True, nogil=True)
def _second_segment(gen: np.ndarray, gen2: np.ndarray, r: np.ndarray, mhi: np.ndarray, rhs: np.ndarray, cp: PieceCouplings,
                    p: int, m: int, cd: np.ndarray, dv: np.ndarray) -> None:
    """A piece eliminated from two segments: the second's row against the joints before it (into
    ``mhi``), its diagonal (into ``gen2``) and right-hand side (``r``)."""
    kh = cp.khi[p]
    o = m + 3 * p
    t33 = np.empty((3, 3))
    chd = np.empty((3, 3))
    a0, a1, a2 = 1.0, gen[kh, 2], gen[kh, 3]
    ch = cp.chi[p]
    abt3(cd, ch, t33)
    h0 = t33[0, 0] * a0 + t33[0, 1] * a1 + t33[0, 2] * a2
    h1 = t33[1, 0] * a0 + t33[1, 1] * a1 + t33[1, 2] * a2
    h2 = t33[2, 0] * a0 + t33[2, 1] * a1 + t33[2, 2] * a2
    mhi[kh, 0] += h0
    mhi[kh, 1] += h1
    mhi[kh, 2] += h2
    # its diagonal is -a^T C_hi D^-1 C_hi^T a, of which p gives -a^T C D^-1 C_hi^T a: d takes the rest
    mul3(ch, dv, chd)
    abt3(chd, ch, t33)
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


@nb.njit(cache=True, nogil=True)
def eliminate_pieces(gen: np.ndarray, rhs: np.ndarray, cp: PieceCouplings, dinv: np.ndarray, m: int,
                     npc: int) -> tuple[np.ndarray, np.ndarray]:
    """The generators ``gen2`` and right-hand side ``r`` of the joints once the pieces on at most two
    segments are eliminated (their own blocks inverted in ``dinv``)."""
    gen2 = gen.copy()
    r = rhs[:m].copy()
    msum = np.zeros((m, 3, 3))  # C D^-1 C^T of the pieces ending at each segment (then summed from the tip)
    mhi = np.zeros((m, 3))  # the second segment's own p term, C D^-1 C_hi^T a
    vsum = np.zeros((m, 3))  # C D^-1 rhs_p likewise
    cd = np.empty((3, 3))
    t33 = np.empty((3, 3))
    for p in range(npc):
        if cp.khi[p] < 0 or cp.slot[p] >= 0:
            continue
        kl = cp.klo[p]
        c = cp.ctot[p]
        dv = dinv[p]
        mul3(c, dv, cd)
        abt3(cd, c, t33)
        o = m + 3 * p
        for i in range(3):
            vsum[kl, i] += cd[i, 0] * rhs[o] + cd[i, 1] * rhs[o + 1] + cd[i, 2] * rhs[o + 2]
            for j in range(3):
                msum[kl, i, j] += t33[i, j]
        if cp.khi[p] > kl:  # on two segments
            _second_segment(gen, gen2, r, mhi, rhs, cp, p, m, cd, dv)
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
    return gen2, r


@nb.njit(cache=True, nogil=True)
def solve_kept(gen2: np.ndarray, q: np.ndarray, low: np.ndarray, z: np.ndarray, cp: PieceCouplings, hpp: np.ndarray,
               rhs: np.ndarray, mu: float, m: int) -> tuple[np.ndarray, bool]:
    """The pieces kept as unknowns: their Schur complement ``T = D + mu I - B^T S^-1 B`` solved, and
    ``z`` (the joints' solution without them) corrected in place; returns their solution and whether
    ``T`` is positive definite."""
    nb_ = cp.n_kept
    bm = cp.bm
    xb = np.zeros(3 * nb_)
    if nb_ == 0:
        return xb, True
    y = np.empty((m, 3 * nb_))
    for c in range(3 * nb_):
        y[:, c] = semi_substitute(gen2, q, low, np.ascontiguousarray(bm[:, c]))
    t = np.zeros((3 * nb_, 3 * nb_))
    rb = np.empty(3 * nb_)
    for p in range(hpp.shape[0]):
        c = cp.slot[p]
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
    lt, spd = try_cholesky(t)
    if spd:
        xb = substitute(lt, rb)
        z -= y @ xb
    return xb, spd


@nb.njit(cache=True, nogil=True)
def piece_solution(x: np.ndarray, z: np.ndarray, xb: np.ndarray, gen: np.ndarray, cp: PieceCouplings, dinv: np.ndarray,
                   rhs: np.ndarray, m: int) -> None:
    """The pieces' part of the solution into ``x[m:]``: a kept piece's from ``xb``, an eliminated one's
    ``x_p = D^-1 (rhs_p - B_p^T z)``, ``B_p^T z = C^T sum_{i <= k_lo} a_i z_i`` (``+ C_hi^T a_kh z_kh``
    on a second segment)."""
    pre = np.empty((m, 3))
    s0 = s1 = s2 = 0.0
    for i in range(m):
        s0 += z[i]
        s1 += gen[i, 2] * z[i]
        s2 += gen[i, 3] * z[i]
        pre[i, 0] = s0
        pre[i, 1] = s1
        pre[i, 2] = s2
    for p in range(dinv.shape[0]):
        o = m + 3 * p
        if cp.slot[p] >= 0:
            for i in range(3):
                x[o + i] = xb[3 * cp.slot[p] + i]
            continue
        v0 = rhs[o]
        v1 = rhs[o + 1]
        v2 = rhs[o + 2]
        if cp.khi[p] >= 0:
            kl = cp.klo[p]
            c = cp.ctot[p]
            v0 -= c[0, 0] * pre[kl, 0] + c[1, 0] * pre[kl, 1] + c[2, 0] * pre[kl, 2]
            v1 -= c[0, 1] * pre[kl, 0] + c[1, 1] * pre[kl, 1] + c[2, 1] * pre[kl, 2]
            v2 -= c[0, 2] * pre[kl, 0] + c[1, 2] * pre[kl, 1] + c[2, 2] * pre[kl, 2]
            kh = cp.khi[p]
            if kh > kl:
                ch = cp.chi[p]
                w0 = z[kh]
                w1 = gen[kh, 2] * z[kh]
                w2 = gen[kh, 3] * z[kh]
                v0 -= ch[0, 0] * w0 + ch[1, 0] * w1 + ch[2, 0] * w2
                v1 -= ch[0, 1] * w0 + ch[1, 1] * w1 + ch[2, 1] * w2
                v2 -= ch[0, 2] * w0 + ch[1, 2] * w1 + ch[2, 2] * w2
        for i in range(3):
            x[o + i] = dinv[p, i, 0] * v0 + dinv[p, i, 1] * v1 + dinv[p, i, 2] * v2


@nb.njit(cache=True, nogil=True)
def semi_schur_solve(gen: np.ndarray, rec: np.ndarray, hpp: np.ndarray, rhs: np.ndarray, m: int, npc: int,
                     mu0: float) -> tuple[np.ndarray, float]:
    """:func:`schur_solve` with the joints' block in generators and the joints-pieces couplings as
    records (:func:`evertgym.sim.kernel.potential.grad_hess` with ``semi``), in O(m + pieces) per
    shift instead of O(m^2 pieces + m^3).

    A piece's coupling to joint ``i`` is ``a_i^T C(i)``, ``C(i)`` the sum of its records' ``c g^T`` on
    segments ``>= i``.  Eliminating the piece (its own block ``D``) adds ``-a_i^T C(i) D^-1 C(j)^T a_j``;
    for ``i < j`` that is of the generators' form ``a_i . p_j`` when ``C(i)`` is the same for every
    ``i < j`` where ``C(j) != 0``: when the piece's contacts lie on one segment or two adjacent ones
    (every piece of the colon's windows measured).  Those are eliminated into ``p`` (and the last
    segment's diagonal ``d``); any other stays an unknown beside the joints and is eliminated after
    them (its own Schur complement, one O(m) solve per column).  The same shifts are tried in the same
    order; a shift is taken when every factor is positive definite, the condition of :func:`schur_solve`
    (the shifted Hessian positive definite).  Returns ``(x, mu)``, ``mu < 0`` if no shift did."""
    if npc == 0:
        return semi_solve(gen, rhs, mu0)
    n = m + 3 * npc
    diag_max = semi_diag_max(gen, hpp)
    cp = piece_couplings(gen, rec, m, npc)
    q = np.empty((m, 3))
    low = np.empty(m)
    d = np.empty((3, 3))
    dinv = np.empty((npc, 3, 3))
    mu = mu0
    tries = 0
    while tries < MAX_SHIFTS:
        if pieces_inverse(hpp, mu, d, dinv):
            gen2, r = eliminate_pieces(gen, rhs, cp, dinv, m, npc)
            if semi_factor(gen2, mu, q, low):
                z = semi_substitute(gen2, q, low, r)
                xb, spd = solve_kept(gen2, q, low, z, cp, hpp, rhs, mu, m)
                if spd:
                    x = np.empty(n)
                    x[:m] = z
                    piece_solution(x, z, xb, gen, cp, dinv, rhs, m)
                    return x, mu
        tries += counted(mu, diag_max)
        mu = next_shift(mu, diag_max)
    return np.zeros(n), -1.0


@nb.njit(cache=True, nogil=True)
def inv3_spd(d: np.ndarray, out: np.ndarray) -> bool:
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
def pieces_inverse(hpp: np.ndarray, mu: float, d: np.ndarray, dinv: np.ndarray) -> bool:
    """Each wall piece's own block shifted by ``mu``, inverted into ``dinv`` (``d``: a 3 x 3 scratch);
    whether every one is positive definite (stops at the first that is not)."""
    for p in range(hpp.shape[0]):
        for i in range(3):
            for j in range(3):
                d[i, j] = hpp[p, i, j]
            d[i, i] += mu
        if not inv3_spd(d, dinv[p]):
            return False
    return True


@nb.njit(cache=True, nogil=True)
def dense_diag_max(hess: np.ndarray, hpp: np.ndarray) -> float:
    """Largest absolute diagonal term of the Hessian (its joint block ``hess``, its pieces' ``hpp``)."""
    out = 0.0
    for i in range(hess.shape[0]):
        out = max(out, abs(hess[i, i]))
    for p in range(hpp.shape[0]):
        for i in range(3):
            out = max(out, abs(hpp[p, i, i]))
    return out


@nb.njit(cache=True, nogil=True)
def schur_solve(hess: np.ndarray, hjp: np.ndarray, hpp: np.ndarray, rhs: np.ndarray, m: int, npc: int,
                mu0: float) -> tuple[np.ndarray, float]:
    """Solve ``(H + mu I) x = rhs`` for the Hessian in :func:`grad_hess`'s blocks (``hess``, ``hjp``,
    ``hpp``; the wall pieces' block is block diagonal, each piece an independent spring): the pieces
    are eliminated (Schur complement on the joints), so the cost grows with the joints, not the pieces.
    The shift ``mu`` is the smallest (``mu0``, then growing tenfold) that makes every factor positive
    definite; returns ``(x, mu)``, ``mu < 0`` if none did."""
    if npc == 0:
        return cholesky_solve(hess, rhs, mu0)
    n = m + 3 * npc
    diag_max = dense_diag_max(hess, hpp)
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
    tries = 0
    while tries < MAX_SHIFTS:
        if pieces_inverse(hpp, mu, d, dinv):
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
            low, spd = try_cholesky(schur)  # else a larger shift for every factor
            if spd:
                xs = substitute(low, r)
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
        tries += counted(mu, diag_max)
        mu = next_shift(mu, diag_max)
    return np.zeros(n), -1.0

