"""Each term of the quasi-static kernel's incremental potential against central finite differences.

The joint law, the barrier, the lagged friction and the wall-piece springs, one at a time (the others
switched off: zero joint stiffness, no pairs, no friction entries, zero piece springs), on random
states of a 12-segment window: free joints in the linear and the wrinkled range, kinked joints on the
collapse plateau, joints at a band (a lower wrinkling moment); the barrier on every kind of pair
(a wall vertex against a segment's side, a robot node against a wall's side, two points), static and
on a compliant piece.  The gradient is checked against differences of the energy, the Hessian (dense
and semiseparable) against differences of the gradient."""

from __future__ import annotations

import numpy as np
import pytest

from evertgym.sim import kernel as qk
from evertgym.sim.kernel import potential
from evertgym.sim.kernel.bundles import Friction, Hessian
from evertgym.sim.kernel.contacts import rows_to_pairs
from evertgym.sim.quasistatic import law_table

_LAW_TABLE = law_table(0.0)  # the joint law without softening

M = 12
SEG_M = 0.0075
RAD_M = 0.005
DHAT_M = 1e-3
EPS_V_M = 1e-5
KAPPA = qk.barrier_stiffness(0.02, DHAT_M)
#: Central-difference steps: rad for the joints, m and rad for the pieces.
H_PHI = 1e-7
H_U = 1e-9


class State:
    """A window, its unknowns, its pairs and friction: what the energy and its derivatives need."""

    def __init__(self, problem: qk.Problem, phi: np.ndarray, u: np.ndarray, pairs: np.ndarray, fr: Friction):
        self.problem, self.phi, self.u, self.pairs, self.fr = problem, phi, u, pairs, fr
        self.m, self.npc = len(phi), len(u)

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return z[: self.m].copy(), z[self.m :].reshape(-1, 3).copy()

    def energy(self, z: np.ndarray) -> float:
        phi, u = self.split(z)
        nodes = qk.chain_nodes(self.problem.chain.theta0, self.problem.chain.n0, phi, self.problem.chain.seg_len)[0]
        return potential.energy(self.problem, phi, u, nodes, self.pairs, self.fr, np.empty((len(self.pairs), 11)))

    def derivatives(self, z: np.ndarray, semi: bool = False) -> tuple[np.ndarray, Hessian]:
        phi, u = self.split(z)
        nodes = qk.chain_nodes(self.problem.chain.theta0, self.problem.chain.n0, phi, self.problem.chain.seg_len)[0]
        geo = np.empty((len(self.pairs), 11))
        assert np.isfinite(potential.energy(self.problem, phi, u, nodes, self.pairs, self.fr, geo))
        return potential.grad_hess(self.problem, phi, u, nodes, self.pairs, self.fr, geo, True, semi)

    def z(self) -> np.ndarray:
        return np.concatenate([self.phi, self.u.ravel()])

    def steps(self) -> np.ndarray:
        return np.concatenate([np.full(self.m, H_PHI), np.tile([H_U, H_U, H_U / 0.01], self.npc)])


def _dense(hs: Hessian, m: int, npc: int) -> np.ndarray:
    """The full Hessian from the dense solver's blocks."""
    n = m + 3 * npc
    out = np.zeros((n, n))
    out[:m, :m] = hs.hess
    if npc:
        out[:m, m:] = hs.hjp
        out[m:, :m] = hs.hjp.T
        for p in range(npc):
            out[m + 3 * p : m + 3 * p + 3, m + 3 * p : m + 3 * p + 3] = hs.hpp[p]
    return out


def _semi_dense(hs: Hessian, nodes: np.ndarray, m: int, npc: int) -> np.ndarray:
    """The full Hessian from the semiseparable solver's generators and records."""
    gen = hs.gen
    n = m + 3 * npc
    out = np.zeros((n, n))
    joints = np.triu(gen[:, 1:4] @ gen[:, 4:7].T)
    out[:m, :m] = joints + np.triu(joints, 1).T + np.diag(gen[:, 0])
    a = np.stack([np.ones(m), nodes[:m, 0], nodes[:m, 1]], axis=1)
    for r in hs.hjp if npc else ():
        p, k = int(r[0]), int(r[1])
        block = np.outer(a[: k + 1] @ r[2:5], r[5:8])
        out[: k + 1, m + 3 * p : m + 3 * p + 3] += block
        out[m + 3 * p : m + 3 * p + 3, : k + 1] += block.T
    for p in range(npc):
        out[m + 3 * p : m + 3 * p + 3, m + 3 * p : m + 3 * p + 3] = hs.hpp[p]
    return out


def _scaling(hess: np.ndarray, m: int, npc: int) -> np.ndarray:
    """Per unknown, one over the square root of its kind's largest diagonal term (joints, piece
    translations, piece rotations): the Hessian ``D H D`` compares entries of different units."""
    d = np.abs(np.diag(hess))
    kinds = [np.arange(m)] + [m + np.arange(i, 3 * npc, 3) for i in (0, 1, 2)]
    out = np.ones(len(d))
    for idx in kinds:
        if len(idx) and np.max(d[idx]) > 0:
            out[idx] = 1.0 / np.sqrt(np.max(d[idx]))
    return out


def _check(state: State, rtol: float = 1e-5, rtol_hess: float = 1e-5) -> None:
    """The gradient against central differences of the energy (to ``rtol``), the Hessian (dense and
    semiseparable) against central differences of the gradient (to ``rtol_hess``), each relative to its
    largest (scaled) entry."""
    z = state.z()
    h = state.steps()
    grad, hs = state.derivatives(z)
    n = len(z)
    fd_grad = np.empty(n)
    fd_hess = np.empty((n, n))
    for i in range(n):
        zp, zm = z.copy(), z.copy()
        zp[i] += h[i]
        zm[i] -= h[i]
        fd_grad[i] = (state.energy(zp) - state.energy(zm)) / (2 * h[i])
        fd_hess[:, i] = (state.derivatives(zp)[0] - state.derivatives(zm)[0]) / (2 * h[i])
    dense = _dense(hs, state.m, state.npc)
    d = _scaling(dense, state.m, state.npc)
    scale_g = np.max(np.abs(grad * d))
    assert scale_g > 0
    assert np.max(np.abs((fd_grad - grad) * d)) <= rtol * scale_g
    scaled = d[:, None] * dense * d[None, :]
    err = d[:, None] * (fd_hess - dense) * d[None, :]
    assert np.max(np.abs(err)) <= rtol_hess * np.max(np.abs(scaled)), np.unravel_index(np.argmax(np.abs(err)), err.shape)
    nodes = qk.chain_nodes(state.problem.chain.theta0, state.problem.chain.n0, state.phi, state.problem.chain.seg_len)[0]
    semi_grad, semi = state.derivatives(z, semi=True)
    assert np.array_equal(semi_grad, grad)
    semi_err = d[:, None] * (_semi_dense(semi, nodes, state.m, state.npc) - dense) * d[None, :]
    assert np.max(np.abs(semi_err)) <= 1e-9 * np.max(np.abs(scaled))


# ---- states --------------------------------------------------------------------------------------
def _chain(rng: np.random.Generator) -> tuple[qk.Chain, np.ndarray]:
    return qk.Chain(0.3, np.array([0.01, -0.02]), np.full(M, SEG_M), np.full(M, RAD_M)), rng.normal(scale=0.08, size=M)


def _no_walls() -> qk.Walls:
    return qk.Walls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.bool_), np.zeros(0))


def _no_friction() -> Friction:
    z2 = np.zeros((0, 2))
    return Friction(np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64), z2, z2, np.zeros(0), z2, z2)


def _soft_joints() -> qk.Joints:
    """No joint energy (zero stiffness, no wrinkling): the other terms alone."""
    return qk.Joints(np.zeros(M), np.zeros(M))


def _pieces(npc: int, kaa: np.ndarray | None = None, travel: float = 1.0) -> qk.Pieces:
    pc0 = np.array([[0.05 + 0.01 * p, 0.04] for p in range(npc)]).reshape(-1, 2)
    return qk.Pieces(pc0, np.zeros((npc, 3, 3)) if kaa is None else kaa, np.full(npc, travel), np.full(npc, 1e4))


def _to_frame(world: np.ndarray, pc0: np.ndarray, u: np.ndarray) -> np.ndarray:
    """A world point in a piece's frame (origin ``pc0 + u[:2]``, turned by ``u[2]``)."""
    c, s = np.cos(u[2]), np.sin(u[2])
    d = world - pc0 - u[:2]
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


#: The kinds of point-edge pair: a wall vertex against a segment's side, a wall segment's side against
#: a robot node, a vertex ahead of the tip (two points), a wall segment's end at the tip (two points).
PAIR_KINDS = ("vertex-side", "node-side", "vertex-tip", "end-tip")


def _contact_walls(rng: np.random.Generator, chain: qk.Chain, phi: np.ndarray, pieces: qk.Pieces, u: np.ndarray, kinds: tuple[str, ...],
                   on_piece: bool) -> qk.Walls:
    """Wall features at gaps inside the barrier's reach, one pair or two of each of ``kinds``; on the
    pieces (``on_piece``: one feature each, in turn) or static."""
    nodes = qk.chain_nodes(chain.theta0, chain.n0, phi, chain.seg_len)[0]
    a, b, piece, vertex = [], [], [], []

    def gap() -> float:
        return float(rng.uniform(0.15, 0.85) * DHAT_M)

    def add(c: np.ndarray, d: np.ndarray, is_vertex: bool) -> None:
        p = len(a) % len(u) if on_piece and len(u) else -1
        if p >= 0:
            c, d = _to_frame(c, pieces.pc0[p], u[p]), _to_frame(d, pieces.pc0[p], u[p])
        a.append(c)
        b.append(d)
        piece.append(p)
        vertex.append(is_vertex)

    def frame(k: int) -> tuple[np.ndarray, np.ndarray]:
        e = (nodes[k + 1] - nodes[k]) / SEG_M
        return e, np.array([-e[1], e[0]])

    turn = np.array([[np.cos(0.5), -np.sin(0.5)], [np.sin(0.5), np.cos(0.5)]])
    if "vertex-side" in kinds:
        for k, side in ((2, 1.0), (6, -1.0)):
            e, nrm = frame(k)
            v = nodes[k] + 0.45 * (nodes[k + 1] - nodes[k]) + side * nrm * (RAD_M + gap())
            add(v, v, True)
    if "node-side" in kinds:
        e, nrm = frame(8)
        q = nodes[9] + nrm * (RAD_M + gap())
        t = np.array([np.cos(0.2), np.sin(0.2)]) @ np.array([[e[0], e[1]], [-e[1], e[0]]])
        add(q - 0.002 * t, q + 0.002 * t, False)
    e, _ = frame(M - 1)
    if "vertex-tip" in kinds:
        v = nodes[M] + turn @ e * (RAD_M + gap())
        add(v, v, True)
    if "end-tip" in kinds:
        c = nodes[M] + turn.T @ e * (RAD_M + gap())
        add(c, c + 0.003 * (turn.T @ turn.T @ e), False)
    return qk.Walls(np.array(a), np.array(b), np.array(piece, np.int64), np.array(vertex), np.zeros(len(a)))


def _pairs_within_reach(problem: qk.Problem, phi: np.ndarray, u: np.ndarray) -> np.ndarray:
    rows = qk.contacts(problem.chain, phi, problem.walls, problem.pieces.pc0, u, DHAT_M, 0.0)
    assert np.all(rows[:, 10] > 0)
    return rows_to_pairs(rows)


@pytest.mark.parametrize("case", ["linear", "wrinkled", "kinked", "band", "residual", "softening"])
def test_the_joint_laws_gradient_and_hessian_are_its_finite_differences(case):
    rng = np.random.default_rng(["linear", "wrinkled", "kinked", "band", "residual", "softening"].index(case))
    chain, _ = _chain(rng)
    k = rng.uniform(0.02, 0.08, M)
    mw = rng.uniform(2e-3, 6e-3, M) if case != "residual" else np.zeros(M)
    phiw = mw / k
    ratio = {"linear": (0.1, 0.9), "wrinkled": (1.1, 3.0), "kinked": (5.0, 60.0), "band": (1.2, 20.0), "residual": (0.5, 2.0),
             "softening": (3.0, 16.0)}[case]
    if case == "band":  # a band's joints wrinkle at a lower moment
        mw[3:7] *= 0.4
        phiw = mw / k
    phi = rng.choice([-1.0, 1.0], M) * rng.uniform(*ratio, M) * (phiw if case != "residual" else 0.05)
    law = law_table(0.3) if case == "softening" else _LAW_TABLE  # (candidate (b): a negative tangent past the peak)
    problem = qk.Problem(chain, qk.Joints(k, mw), law, _no_walls(), _pieces(0), qk.ContactLaw(DHAT_M, KAPPA, EPS_V_M))
    # past wrinkling the law is a table in ln(phi / phi_w): its moment interpolates linearly in ln x, its
    # stiffness is the cell's slope in x, the two consistent to the table's resolution (its step in ln x)
    table_step = float(_LAW_TABLE.u[1] - _LAW_TABLE.u[0])
    wrinkled = case in ("wrinkled", "kinked", "band", "softening")
    _check(State(problem, phi, np.zeros((0, 3)), np.zeros((0, 2), np.int64), _no_friction()),
           rtol_hess=table_step if wrinkled else 1e-5)


def _piece_state(rng: np.random.Generator, npc: int) -> np.ndarray:
    """Random piece displacements: a millimetre, a few degrees."""
    return np.column_stack([rng.normal(scale=1e-3, size=(npc, 2)), rng.normal(scale=0.05, size=npc)])


@pytest.mark.parametrize("on_piece", [False, True])
@pytest.mark.parametrize("kind", PAIR_KINDS)
def test_the_barriers_gradient_and_hessian_are_its_finite_differences(kind, on_piece):
    for seed in range(3):
        rng = np.random.default_rng(10 * PAIR_KINDS.index(kind) + seed + 100 * on_piece)
        chain, phi = _chain(rng)
        npc = 2 if on_piece else 0
        u = _piece_state(rng, npc)
        pieces = _pieces(npc)
        walls = _contact_walls(rng, chain, phi, pieces, u, (kind,), on_piece)
        problem = qk.Problem(chain, _soft_joints(), _LAW_TABLE, walls, pieces, qk.ContactLaw(DHAT_M, KAPPA, EPS_V_M))
        pairs = _pairs_within_reach(problem, phi, u)
        assert len(pairs) == len(walls.a)
        _check(State(problem, phi, u, pairs, _no_friction()))


def _friction(rng: np.random.Generator, chain: qk.Chain, phi: np.ndarray, walls: qk.Walls, u: np.ndarray, pieces: qk.Pieces,
              sliding: bool) -> Friction:
    """Lagged friction entries on every wall feature: robot points on random segments, slip since the
    start below ``eps_v`` (sticking) or beyond it (``sliding``)."""
    from evertgym.sim.kernel.geometry import poses, wall_point

    nodes = qk.chain_nodes(chain.theta0, chain.n0, phi, chain.seg_len)[0]
    nf = len(walls.a)
    k = rng.integers(0, M, nf).astype(np.int64)
    s = rng.uniform(0.1, 0.9, nf)
    w = np.arange(nf, dtype=np.int64)
    wl = walls.a + rng.normal(scale=1e-4, size=(nf, 2))
    ang = rng.uniform(0, 2 * np.pi, nf)
    t = np.column_stack([np.cos(ang), np.sin(ang)])
    pose = poses(pieces.pc0, u)
    xr = nodes[k] * (1 - s)[:, None] + nodes[k + 1] * s[:, None]
    xw = np.array([wall_point(int(w[i]), wl[i, 0], wl[i, 1], walls.piece, pose) for i in range(nf)])
    slip = rng.uniform(2.0, 5.0, nf) * EPS_V_M if sliding else rng.uniform(0.1, 0.8, nf) * EPS_V_M
    xr0 = xr - slip[:, None] * t * rng.choice([-1.0, 1.0], nf)[:, None]
    return Friction(k, s, w, wl, t, rng.uniform(0.05, 0.5, nf), xr0, xw)


@pytest.mark.parametrize("on_piece", [False, True])
@pytest.mark.parametrize("sliding", [False, True])
def test_the_lagged_frictions_gradient_and_hessian_are_its_finite_differences(sliding, on_piece):
    for seed in range(3):
        rng = np.random.default_rng(200 + seed + 10 * sliding + 100 * on_piece)
        chain, phi = _chain(rng)
        npc = 2 if on_piece else 0
        u = _piece_state(rng, npc)
        pieces = _pieces(npc)
        walls = _contact_walls(rng, chain, phi, pieces, u, PAIR_KINDS, on_piece)
        problem = qk.Problem(chain, _soft_joints(), _LAW_TABLE, walls, pieces, qk.ContactLaw(DHAT_M, KAPPA, EPS_V_M))
        _check(State(problem, phi, u, np.zeros((0, 2), np.int64), _friction(rng, chain, phi, walls, u, pieces, sliding)))


@pytest.mark.parametrize("beyond_travel", [False, True])
def test_the_wall_piece_springs_gradient_and_hessian_are_their_finite_differences(beyond_travel):
    rng = np.random.default_rng(300 + beyond_travel)
    chain, phi = _chain(rng)
    npc = 4
    u = _piece_state(rng, npc)
    kaa = np.empty((npc, 3, 3))
    for p in range(npc):
        a = rng.normal(size=(3, 3)) * np.array([1e3, 1e3, 1.0])
        kaa[p] = a @ a.T + np.diag([1e2, 1e2, 1e-2])
    pieces = _pieces(npc, kaa, travel=0.3e-3 if beyond_travel else 1.0)
    problem = qk.Problem(chain, _soft_joints(), _LAW_TABLE, _no_walls(), pieces, qk.ContactLaw(DHAT_M, KAPPA, EPS_V_M))
    _check(State(problem, phi, u, np.zeros((0, 2), np.int64), _no_friction()))
