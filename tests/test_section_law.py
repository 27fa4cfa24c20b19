"""The section law (closed-tube statics) and the force cap it puts on every contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evertgym.design import TubeDesign
from evertgym.experiments.capacity import CASES, max_tip_force
from evertgym.model.section_law import (
    collapse_moment,
    compression_capacity,
    distal_compression,
    tail_tension,
    wall_tension,
    wrinkling_moment,
)
from evertgym.sim import EversionSim, SimConfig

LAW = SimConfig(engine="dynamic", section_law=True)


def test_unloaded_section_has_the_classical_moments():
    p, r = 3000.0, 0.02
    t = wall_tension(p, np.array([r]), 0.0, 0.0)
    assert t[0] == pytest.approx(p * math.pi * r**2)
    assert wrinkling_moment(t, r)[0] == pytest.approx(p * math.pi * r**3 / 2)
    assert collapse_moment(t, r)[0] == pytest.approx(p * math.pi * r**3)


def test_axial_load_lowers_the_moments_and_a_slack_wall_carries_none():
    """The note's table at 3 kPa with C = 3 N (closed-tube statics), no tail."""
    p, c = 3000.0, 3.0
    r = 0.02 * (1 - np.array([0.0, 0.1, 0.2, 0.3]))
    t = wall_tension(p, r, 0.0, c)
    np.testing.assert_allclose(p * math.pi * r**2, [3.77, 3.05, 2.41, 1.85], atol=0.01)
    np.testing.assert_allclose(t[:2], [0.77, 0.05], atol=0.01)
    assert np.all(t[2:] < 0)
    mc = collapse_moment(t, r)
    assert mc[0] / (p * math.pi * 0.02**3) == pytest.approx(0.77 / 3.77, rel=1e-2)
    assert np.all(mc[2:] == 0.0)
    np.testing.assert_allclose(compression_capacity(p, r, 0.5), np.maximum(p * math.pi * r**2 - 0.5, 0))
    assert compression_capacity(0.0, r, 0.5).max() == 0.0  # deflated: no compression at all


def test_distal_compression_sums_the_forces_ahead_along_each_axis():
    forces = np.array([[0.0, 1.0], [0.0, 0.0], [-2.0, 0.5]])  # N, base to tip
    axes = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])
    np.testing.assert_allclose(distal_compression(forces, axes), [2.0, -0.5, 2.0])


def test_tail_tension_grows_by_the_capstan_law():
    t = tail_tension(0.5, np.array([0.0, math.pi]), 0.3)
    np.testing.assert_allclose(t, [0.5, 0.5 * math.exp(0.3 * math.pi)])


@pytest.mark.parametrize("case", sorted(CASES))
def test_no_wall_pushes_the_tip_harder_than_the_tube_can_carry(case):
    """Grown at 8 kPa into each scene family under the section law, the largest wall force on
    the tip stays within 1.5 p pi r_tip^2: the tube folds axially rather than carry more."""
    r = max_tip_force(case, section_law=True)
    assert r["ratio"] > 0.2, "the tip never met a wall: the case tests nothing"
    assert r["ratio"] <= 1.5


@pytest.mark.parametrize("wall_deg, deflects", [(45.0, True), (60.0, True), (70.0, True), (80.0, False)])
def test_tip_slides_outside_the_friction_cone_and_buckles_inside_it(wall_deg, deflects):
    """The 40 mm robot at 3 kPa meets a wall 100 mm ahead at incidence 90 - wall_deg from the
    wall's normal (tests/test_sim.py's inclined wall).  Under the section law, whose growth
    increments are relaxed to rest, it slides along walls of 45, 30 and 20 degrees incidence,
    outside the tip friction's cone (0.2: 11 degrees).  Nearly head-on (10 degrees, inside the
    cone) the wall takes the push, the wall tension behind the tip falls, the body loses its
    bending capacity and buckles sideways, away from the wall (vine bodies buckle under axial
    load: Coad et al., RA-L 2020); the tip never takes more than the tube can carry."""
    from test_sim import grow_into_inclined_wall  # the rigid-column model's test, with the section law

    sim, heading = grow_into_inclined_wall(wall_deg, LAW)
    if deflects:
        assert sim.length == pytest.approx(0.3) and heading == pytest.approx(wall_deg, abs=10.0)
    else:
        assert abs(heading - wall_deg) > 45.0  # it did not turn along the wall
        assert sim.tip_position[0] < 0.1  # nor go through it
    assert sim.max_contact_force <= 1.5 * 3000.0 * math.pi * 0.02**2


@pytest.mark.parametrize("field, value", [("relax_force_n", -1.0), ("relax_speed_m_per_s", -0.1), ("max_relax_steps", -5),
                                          ("force_window_s", 0.0), ("tail_drag_fraction", 1.5)])
def test_section_law_settings_are_range_checked(field, value):
    with pytest.raises(ValueError, match=f"{field} = .* is out of range"):
        SimConfig(engine="dynamic", section_law=True, **{field: value})


def test_force_criterion_relaxes_the_tip_region_to_the_tolerance():
    """After a growth step under ``relax_force_n`` the tip region's implied unbalanced force is
    below the tolerance, unless the step cap was reached."""
    cfg = SimConfig(engine="dynamic", section_law=True, relax_force_n=0.05, max_relax_steps=1000)
    from test_sim import _InclinedWall

    sim = EversionSim(TubeDesign(length_m=0.3), scene=_InclinedWall(0.1, 60.0), config=cfg)
    sim.set_pressure_command(3000.0)
    for _ in range(1500):
        sim.step(1)
        if sim.growth_speed > 0:
            assert sim._tip_region_residual() <= 0.05
    assert sim.relax_steps > 0
