"""The kernel's line search never accepts a configuration beyond a wall that its step passed through,
whatever the step's length: a collision-free step bound (continuous collision detection), not the
2 mm cap on a node's travel, keeps the body on its side of a wall thinner than the step."""

from __future__ import annotations

import numpy as np

from evertgym.sim import kernel as qk
from evertgym.sim.kernel import ccd, newton, potential
from evertgym.sim.kernel.contacts import pair_rows
from evertgym.sim.kernel.friction import resolve
from evertgym.sim.kernel.geometry import pair_at, point_edge
from evertgym.sim.quasistatic import law_table

_LAW_TABLE = law_table(0.0)  # the joint law without softening

SEG_M = 0.0075
RAD_M = 0.001  # a thin robot ...
WALL_Y_M = 0.0025  # ... and a wall of no thickness, 2.5 mm above the straight chain's axis
WALL = qk.Walls(np.array([[0.050, WALL_Y_M]]), np.array([[0.080, WALL_Y_M]]), np.full(1, -1, np.int64), np.zeros(1, np.bool_), np.zeros(1))
NO_STEP_CAP_M = 1.0  # a node may travel a metre in one Newton step


def _released(start_rad: float = 0.4, m: int = 10) -> tuple[qk.Problem, np.ndarray]:
    """Ten linear joints turned up by ``start_rad`` at the base: their equilibrium, the straight chain,
    lies below the wall (clear of it: 1.5 mm), which is in the way of the swing down."""
    phi = np.zeros(m)
    phi[0] = start_rad
    z2, z0 = np.zeros((0, 2)), np.zeros(0)
    problem = qk.Problem(qk.Chain(0.0, np.zeros(2), np.full(m, SEG_M), np.full(m, RAD_M)), qk.Joints(np.full(m, 0.05), np.full(m, 10.0)),
                         _LAW_TABLE, WALL, qk.Pieces(z2, np.zeros((0, 3, 3)), z0, z0), qk.ContactLaw(1e-3, qk.barrier_stiffness(0.02, 1e-3), 1e-5))
    return problem, phi


def _gaps(problem: qk.Problem, phi: np.ndarray) -> np.ndarray:
    nodes = qk.chain_nodes(0.0, np.zeros(2), phi, problem.chain.seg_len)[0]
    return np.array([pair_at(nodes, k, 0, problem.chain.seg_rad, *WALL, np.zeros((0, 4)))[10] for k in range(len(phi))])


def _no_friction() -> qk.Entries:
    return qk.Entries(np.zeros(0), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))


def test_a_point_moving_through_a_segment_is_stopped_before_it_and_one_moving_past_is_not():
    seg = (0.0, 0.0, 1.0, 0.0)
    through = ccd.pair_toi((0.5, 0.3, 0.5, 0.3), (0.5, -0.3, 0.5, -0.3), seg, seg, False, 0.01)  # a robot node, a wall segment
    assert 0.0 < through < 1.0
    at = 0.3 - through * 0.6
    assert point_edge((0.5, at, 0.5, at), seg, False)[5] - 0.01 > 0.0  # still clear where it stops ...
    assert at - 0.01 < 1e-3  # ... and close to the wall (advanced, not stopped at the start)
    assert ccd.pair_toi((0.5, 0.3, 0.5, 0.3), (0.9, 0.3, 0.9, 0.3), seg, seg, False, 0.01) == 1.0  # alongside
    assert ccd.pair_toi((1.5, 0.3, 1.5, 0.3), (1.5, -0.3, 1.5, -0.3), seg, seg, False, 0.01) == 1.0  # beyond its end
    # a wall vertex that a robot segment sweeps over
    assert ccd.pair_toi((0.0, 0.3, 1.0, 0.3), (0.0, -0.3, 1.0, -0.3), (0.5, 0.0, 0.5, 0.0), (0.5, 0.0, 0.5, 0.0), True, 0.01) < 1.0
    # a moving wall segment sweeping over a resting point
    assert ccd.pair_toi((0.5, 0.0, 0.5, 0.0), (0.5, 0.0, 0.5, 0.0), (0.0, 0.4, 1.0, 0.4), (0.0, -0.4, 1.0, -0.4), False, 0.01) < 1.0


def test_the_first_newton_step_would_pass_through_the_wall_with_every_gap_positive():
    """Why the bound is needed: the whole Newton step lands the chain below the wall, clear of it (the
    barrier's energy finite, Armijo satisfied), though the chain went through it on the way."""
    problem, phi = _released()
    before = _gaps(problem, phi)
    assert before.min() > 0.0
    assert _gaps(problem, np.zeros_like(phi)).min() > 0.0
    nodes0 = qk.chain_nodes(0.0, np.zeros(2), phi, problem.chain.seg_len)[0]
    nodes1 = qk.chain_nodes(0.0, np.zeros(2), np.zeros_like(phi), problem.chain.seg_len)[0]
    assert nodes0[-1, 1] > WALL_Y_M > nodes1[-1, 1]  # the tip starts above the wall and would end below it
    free = ccd.step_bound(nodes0, nodes1, np.zeros((0, 3)), np.zeros((0, 3)), np.array([[k, 0] for k in range(len(phi))], np.int64),
                          problem.chain.seg_rad, WALL, problem.pieces.pc0)
    assert 0.0 < free < 1.0


def test_a_released_body_with_no_step_cap_rests_on_a_thin_wall_instead_of_passing_through():
    problem, phi = _released()
    settings = qk.SolveSettings(1e-7, 1e-7, 200, NO_STEP_CAP_M, 1, True)
    out = qk.solve_increment(problem, phi, phi.copy(), np.zeros((0, 3)), np.zeros((0, 3)), np.arange(len(phi) + 1) * SEG_M, np.zeros(len(phi)),
                             np.zeros(1), _no_friction(), settings)
    assert out.status == qk.CONVERGED
    nodes = qk.chain_nodes(0.0, np.zeros(2), phi, problem.chain.seg_len)[0]
    gaps = _gaps(problem, phi)
    assert gaps.min() > 0.0
    assert gaps.min() < 1e-3  # within the barrier's reach: the wall holds it
    assert nodes[-1, 1] > WALL_Y_M  # above the wall, where it started


def test_a_line_search_step_is_cut_where_it_would_meet_the_wall():
    """The line search alone: from the released chain along the step to the straight one, the trial it
    takes is collision-free along the step (its tip still above the wall)."""
    problem, phi = _released()
    m = len(phi)
    u = np.zeros((0, 3))
    nodes = qk.chain_nodes(0.0, np.zeros(2), phi, problem.chain.seg_len)[0]
    rows = pair_rows(problem.chain, phi, WALL, problem.pieces.pc0, u, np.array([[k, 0] for k in range(m)], np.int64), 1e-3, 1.0)
    lst = newton.listing_at(rows, nodes, u, 1e-3)
    fr = resolve(_no_friction(), nodes, np.arange(m + 1) * SEG_M, problem.chain.seg_len, WALL.piece, problem.pieces.pc0, u)
    e0 = potential.energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
    step = -phi.copy()  # the Newton step of linear joints with no contact: to the straight chain
    grad = problem.joints.k * phi
    trial = newton.line_search(problem, fr, phi, u, nodes, e0, step, float(grad @ step), 1.0, np.empty((0, 2)), lst, np.zeros(0))
    assert trial.accepted
    assert 0.0 < trial.alpha < 1.0
    assert trial.nodes[-1, 1] > WALL_Y_M
    assert _gaps(problem, trial.phi).min() > 0.0
