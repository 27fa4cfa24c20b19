"""A quasi-static solve never passes through a wall: a solve that moves the body by more
than its first contact candidates reach lists its contacts again from every wall it was given, and
one that moves it farther than the walls it was given runs again seeing farther."""

from __future__ import annotations

import numpy as np
import pytest

from evertgym.sim import kernel as qk
from evertgym.sim.kernel.geometry import pair_at
from evertgym.sim.quasistatic import law_table

_LAW_TABLE = law_table(0.0)  # the joint law without softening

SEG_M = 0.0075
RAD_M = 0.005
WALL_Y_M = 0.003  # a wall line above the straight chain's axis, closer than its radius
WALL_X0_M = 0.050
WALL_A = np.array([[WALL_X0_M, WALL_Y_M]])
WALL_B = np.array([[0.080, WALL_Y_M]])
WALL = qk.Walls(WALL_A, WALL_B, np.full(1, -1, np.int64), np.zeros(1, np.bool_), np.zeros(1))


def _swing_back(start_rad: float, semi: bool = False) -> tuple[np.ndarray, np.ndarray, qk.SolveResult]:
    """Ten segments from the origin, turned up by ``start_rad`` at the base joint and released: the
    joints' equilibrium is the straight chain along x, which the wall (y = 3 mm, x = 50-80 mm) is
    in the way of.  Returns the nodes before and after one solve, and the kernel's status; ``semi``:
    the O(m) linear solver (``SimConfig.linear_solver = "semiseparable"``)."""
    m = 10
    phi = np.zeros(m)
    phi[0] = start_rad
    seg_len = np.full(m, SEG_M)
    seg_rad = np.full(m, RAD_M)
    z2, z0 = np.zeros((0, 2)), np.zeros(0)
    n0 = np.zeros(2)
    before, _ = qk.chain_nodes(0.0, n0, phi, seg_len)
    problem = qk.Problem(qk.Chain(0.0, n0, seg_len, seg_rad), qk.Joints(np.full(m, 0.05), np.full(m, 10.0)), _LAW_TABLE, WALL,
                         qk.Pieces(z2, np.zeros((0, 3, 3)), z0, z0), qk.ContactLaw(1e-3, qk.barrier_stiffness(0.02, 1e-3), 1e-5))
    no_friction = qk.Entries(z0, np.zeros(0, np.int64), z2, z2, z0)
    out = qk.solve_increment(problem, phi, phi.copy(), np.zeros((0, 3)), np.zeros((0, 3)), np.arange(m + 1) * SEG_M, np.zeros(m), np.zeros(1),
                             no_friction, qk.SolveSettings(1e-7, 1e-7, 200, 0.002, 1, semi))
    after, _ = qk.chain_nodes(0.0, n0, phi, seg_len)
    return before, after, out


def _gaps(nodes: np.ndarray) -> np.ndarray:
    """Gap (m) between each segment's surface and the wall line (its end points included)."""
    out = []
    for k in range(len(nodes) - 1):
        gap = pair_at(nodes, k, 0, np.full(len(nodes) - 1, RAD_M), *WALL, np.zeros((0, 4)))[10]
        out.append(gap)
    return np.array(out)


@pytest.mark.parametrize("semi", [False, True])
def test_a_body_released_far_from_a_wall_stops_on_it_instead_of_passing_through(semi):
    before, after, out = _swing_back(0.4, semi)
    assert _gaps(before).min() > 0.008  # the wall is far beyond the solve's first candidates (6 mm)
    assert out.status == qk.CONVERGED
    gaps = _gaps(after)
    assert gaps.min() > 0.0  # it rests on the wall; before the fix it passed through it (gap -2 mm)
    assert gaps.min() < 1e-3  # within the barrier's reach: the wall holds it
    assert after[-1, 1] > WALL_Y_M + RAD_M - 1e-3  # the tip stays above the wall


@pytest.mark.parametrize("semi", [False, True])
@pytest.mark.parametrize("start_rad", [0.2, 0.3])
def test_where_it_rests_does_not_depend_on_how_far_from_the_wall_it_started(start_rad, semi):
    """Released nearer the wall (at 0.2 rad the wall is among the first candidates), it comes to
    rest where it does when released far from it."""
    _, after, out = _swing_back(start_rad, semi)
    _, ref, _ = _swing_back(0.4, semi)
    assert out.status == qk.CONVERGED
    assert _gaps(after).min() > 0.0
    assert np.max(np.abs(after - ref)) < 1e-4


def test_a_solve_that_goes_beyond_the_walls_it_sees_runs_again_seeing_farther(monkeypatch):
    """With the walls given to a solve cut to those within 0.5 mm of the window (the default
    reach is 12 mm), the robot sliding along an oblique wall moves past them in many solves; each
    of those runs again seeing as far as it went, and the answer is the default's."""
    from test_sim import grow_into_inclined_wall

    from evertgym.sim import SimConfig, quasistatic

    qs = SimConfig(engine="quasistatic", growth_increment_m=0.001)  # 1 mm increments: solves that move past 0.5 mm
    ref, ref_heading = grow_into_inclined_wall(45.0, qs)
    assert ref.solve_stats["solve_reselections"] == 0
    monkeypatch.setattr(quasistatic, "_QUERY_MARGIN_M", 0.0005)
    sim, heading = grow_into_inclined_wall(45.0, qs)
    assert sim.solve_stats["solve_reselections"] > 0 and sim.solve_stats["solve_failures"] == 0
    assert heading == pytest.approx(ref_heading, abs=1e-6)
    assert np.max(np.abs(sim.centreline() - ref.centreline())) < 1e-6


def test_a_state_that_overlaps_a_wall_is_counted_as_failed_not_silently_frozen():
    """Should a committed state ever overlap a wall, every pressure re-solve from it is refused;
    each one is counted (``solve_failures``) and recorded as a ``solve_failed`` event."""
    from test_sim import grow_into_inclined_wall

    from evertgym.sim import SimConfig

    sim, _ = grow_into_inclined_wall(80.0, SimConfig(engine="quasistatic"))  # stalled head-on against the wall
    assert sim.solve_stats["solve_failures"] == 0
    sim.seg_rad[-2] += 0.02  # the segment behind the tip now reaches 9 mm into the wall
    sim.set_pressure_command(6000.0)
    sim.run(0.5)
    failed = [e for e in sim.events if e.kind == "solve_failed"]
    assert sim.solve_stats["solve_failures"] > 0 and len(failed) == sim.solve_stats["solve_failures"]
    assert failed[0].detail["status"] == qk.INFEASIBLE_START
