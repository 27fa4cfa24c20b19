"""The pymunk simulator against the rod model, and its growth behaviour."""

import math
import re

import numpy as np
import pymunk
import pytest

from evertgym.design import Band, TubeDesign
from evertgym.model.section import TubeSection
from evertgym.model.stiffness import paper_prototype, paper_rows, virtual_tensile_test
from evertgym.sim import EversionSim, NumericalInstabilityError, SimConfig
from evertgym.sim.discretize import hat_compliance, joint_moment
from evertgym.sim.tensile import sim_tensile_test

CONFIGS = sorted({(r.bands_from_tip_mm, r.reduction) for r in paper_rows()})


@pytest.mark.parametrize("displacement_m, rel", [(0.02, 0.03), (0.06, 0.05)], ids=["20mm_within_3pct", "60mm_within_5pct"])
@pytest.mark.parametrize("bands, reduction", CONFIGS)
def test_sim_tip_stiffness_matches_the_rod(bands, reduction, displacement_m, rel):
    design = paper_prototype(bands, reduction)
    k_rod = virtual_tensile_test(design, displacement_m).force[1] / displacement_m
    res = sim_tensile_test(design, displacement_m)
    assert res.converged
    assert res.n_per_m == pytest.approx(k_rod, rel=rel)


def test_hat_lumping_is_exact_for_a_uniform_rod():
    design = TubeDesign()
    sec = TubeSection(design, 6900.0)
    ds = 0.005
    nodes = np.arange(0, 0.2, ds)
    c = hat_compliance(sec, nodes, 0.2)
    ei = sec.bare_bending_stiffness
    assert c[0] == pytest.approx(ds / (2 * ei), rel=1e-9)  # the clamp: 2 EI / ds
    assert np.allclose(c[1:], ds / ei, rtol=1e-9)


def _hat_one_at_a_time(sec, nodes, s_end, shear):
    """The hat integrals node by node and half by half (how they were computed before 2026-12-04)."""
    stiffness = sec.shear_stiffness if shear else sec.bending_stiffness
    comp = np.zeros(len(nodes))
    for j in range(len(nodes)):
        lo = nodes[j - 1] if j > 0 else nodes[0]
        hi = nodes[j + 1] if j + 1 < len(nodes) else min(s_end, nodes[j] + (nodes[j] - nodes[j - 1] if j > 0 else 0.0))
        for a, b in ((lo, nodes[j]), (nodes[j], hi)):
            if b - a > 0:
                s = np.linspace(a, b, 65)
                comp[j] += np.trapezoid((1.0 - np.abs(s - nodes[j]) / (b - a)) / stiffness(s), s)
    return comp


@pytest.mark.parametrize("shear", [False, True])
@pytest.mark.parametrize("s_end_fraction", [1.0, 0.37])
def test_hat_integrals_in_one_array_give_the_same_bits_as_one_at_a_time(shear, s_end_fraction):
    """The shipped policies retrain exactly from their configs only if the joint law's bits do not move."""
    bands = (Band(0.2, 0.1), Band(0.2531, 0.3, width_m=0.01), Band(0.31, 0.5))
    sec = TubeSection(TubeDesign(length_m=0.9, bands=bands), 6900.0)
    ds = 0.0075
    nodes = np.arange(int(0.9 / ds)) * ds
    s_end = nodes[-1] + s_end_fraction * ds
    assert np.array_equal(hat_compliance(sec, nodes, s_end, shear), _hat_one_at_a_time(sec, nodes, s_end, shear))
    assert np.array_equal(hat_compliance(sec, nodes[:1], s_end, shear), _hat_one_at_a_time(sec, nodes[:1], s_end, shear))


@pytest.mark.parametrize(
    "cfg",
    [
        SimConfig(engine="dynamic", inertia_factor=16.0),
        SimConfig(engine="dynamic", mass_ratio=0.05),
        SimConfig(engine="dynamic", damping=1e-6),
        SimConfig(dt_s=0.0005),
    ],
)
def test_static_answer_does_not_depend_on_mass_scaling_damping_or_step(cfg):
    design = paper_prototype((50, 100), 0.5)
    ref = sim_tensile_test(design, 0.02)
    alt = sim_tensile_test(design, 0.02, config=cfg)
    assert alt.converged
    assert alt.n_per_m == pytest.approx(ref.n_per_m, rel=3e-3)


def test_band_kinks_before_the_bare_tube_under_the_same_moment():
    p = 3000.0
    sec_bare = TubeSection(TubeDesign(), p)
    sec_band = TubeSection(TubeDesign(bands=(Band(0.3, 0.3),)), p)
    nodes = np.array([0.3])
    mw_bare = float(sec_bare.wrinkling_moment(0.3))
    mw_band = float(sec_band.wrinkling_moment(0.3))
    k_bare = 1 / float(hat_compliance(sec_bare, np.array([0.295, 0.3, 0.305]), 0.4)[1])
    k_band = 1 / float(hat_compliance(sec_band, np.array([0.295, 0.3, 0.305]), 0.4)[1])
    del nodes
    # drive both joints to the same moment: 95% of the band's collapse moment
    target = 0.95 * 2 * mw_band
    phis = np.linspace(0, 2.0, 200001)
    m_band = joint_moment(phis, np.full_like(phis, k_band), np.full_like(phis, mw_band))
    m_bare = joint_moment(phis, np.full_like(phis, k_bare), np.full_like(phis, mw_bare))
    assert m_band.max() >= target  # the band reaches its kink...
    phi_bare = phis[np.argmax(m_bare >= target)]
    assert abs(k_bare * phi_bare) <= mw_bare  # ...while the bare tube is still linear there


def test_band_kinks_first_in_the_simulator():
    """A tube with a 30% band, loaded by a growing tip moment: the first kink is at the band."""
    design = TubeDesign(length_m=0.2, bands=(Band(0.1, 0.3),))
    sim = EversionSim(design, config=SimConfig(engine="dynamic", initial_length_m=0.2))  # pushes a body
    sim.set_pressure_command(3000.0)
    sim.run(1.0)
    tip = sim.bodies[-1]
    for torque in np.linspace(0.0, 0.06, 61):
        tip.torque = float(torque)
        for _ in range(60):
            tip.torque = float(torque)
            sim.step(1)
        if sim.kinked_joints:
            break
    assert sim.kinked_joints, "no joint kinked"
    first = [e for e in sim.events if e.kind == "kink"][0]
    assert first.detail["at_band"]
    assert abs(first.detail["joint_mm"] - 100.0) <= 10.0


def test_free_growth_in_open_space_stays_straight():
    sim = EversionSim(TubeDesign(length_m=0.4, bands=(Band(0.2, 0.2),)))
    sim.set_pressure_command(3000.0)
    sim.run(5.0)
    assert sim.length == pytest.approx(0.4)
    line = sim.centreline()
    assert np.max(np.abs(line[:, 1])) < 1e-6
    assert line[-1, 0] == pytest.approx(0.4, abs=1e-4)
    assert [e.kind for e in sim.events] == ["band_at_tip"]


def test_growth_speed_follows_the_law():
    cfg = SimConfig()
    sim = EversionSim(TubeDesign(length_m=0.6), config=cfg)
    p = float(sim.threshold(0.0)) + 15.0  # just above the bare threshold
    sim.set_pressure_command(p)
    sim.run(2.0)
    # straight and free: no capstan loss on the tail, no wall force, so p_req is the threshold
    expected = cfg.growth_gain_m_per_s_per_pa * (p - sim.required_pressure())
    assert sim.required_pressure() == pytest.approx(float(sim.threshold(0.0)), rel=1e-3)
    assert 0 < expected < cfg.max_growth_speed_m_per_s
    assert sim.growth_speed == pytest.approx(expected, rel=0.02)
    sim.set_pressure_command(300.0)  # below it: no growth
    sim.run(2.0)
    assert sim.growth_speed == 0.0 and sim.stalled


class _Wall:
    """A static wall segment: the minimal scene interface (``build(space, dt)``)."""

    def __init__(self, a, b):
        self.a, self.b = a, b

    def build(self, space, dt=None):
        seg = pymunk.Segment(space.static_body, self.a, self.b, 0.002)
        seg.friction = 1.0
        space.add(seg)
        return seg


def test_growth_into_an_inclined_wall_bends_the_tube_and_stays_out_of_it():
    wall = _Wall((0.15, -0.3), (0.75, 0.3))  # 45 degrees across the growth direction
    sim = EversionSim(TubeDesign(length_m=0.5), scene=wall, config=SimConfig(tip_friction=0.1))
    sim.set_pressure_command(3000.0)
    sim.run(8.0)
    line = sim.centreline()
    assert line[-1, 1] > 0.05  # deflected up along the wall
    assert any(e.kind == "contact" for e in sim.events)
    # no node crossed the wall line (signed distance keeps the robot's side)
    a, b = np.array(wall.a), np.array(wall.b)
    n = np.array([-(b - a)[1], (b - a)[0]])
    side = (line - a) @ n
    assert np.all(side >= -1e-3)


def test_same_inputs_same_trajectory_bit_for_bit():
    def run():
        wall = _Wall((0.12, -0.2), (0.3, 0.05))
        sim = EversionSim(TubeDesign(length_m=0.35, bands=(Band(0.1, 0.1),)), scene=wall)
        out = []
        for p in (2000.0, 5000.0, 3000.0):
            sim.set_pressure_command(p)
            sim.run(1.0)
            out.append(sim.centreline().copy())
        return np.concatenate(out), [e.to_dict() for e in sim.events]

    a, ea = run()
    b, eb = run()
    assert np.array_equal(a, b)
    assert ea == eb


def test_pressure_command_is_clipped_and_checked():
    sim = EversionSim(TubeDesign())
    assert sim.set_pressure_command(12000.0) == 8000.0
    assert sim.set_pressure_command(-5.0) == 0.0
    with pytest.raises(ValueError, match="not finite"):
        sim.set_pressure_command(float("nan"))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(segment_length_m=0.0), "segment_length_m"),
        (dict(dt_s=-1e-3), "dt_s"),
        (dict(dt_s=1e-9), r"dt_s = 1e-09 is out of range: allowed [1e-05, 0.01]"),  # would never finish
        (dict(damping=0.0), "damping"),
        (dict(wall_friction=float("nan")), "wall_friction"),
        (dict(engine="dynamic", max_growth_speed_m_per_s=5.0), "max_growth_speed_m_per_s * dt_s"),
    ],
)
def test_sim_config_rejects_bad_settings(kwargs, field):
    with pytest.raises(ValueError, match=re.escape(field)):
        SimConfig(**kwargs)


def test_instability_names_the_setting_to_change():
    sim = EversionSim(TubeDesign(), config=SimConfig(engine="dynamic", initial_length_m=0.1))
    sim.bodies[-1].angular_velocity = 1e6
    with pytest.raises(NumericalInstabilityError, match="dt_s"):
        sim.step(1)


class _InclinedWall:
    """A scene of one straight static wall through ``(x_m, 0)`` at ``angle_deg`` to +x."""

    def __init__(self, x_m: float, angle_deg: float):
        self.x, self.angle = x_m, math.radians(angle_deg)

    def build(self, space: pymunk.Space, dt: float | None = None) -> None:
        from evertgym.scenes.compliant import style_wall_shape

        d = np.array([math.cos(self.angle), math.sin(self.angle)])
        p0, p1 = np.array([self.x, 0.0]) - 0.3 * d, np.array([self.x, 0.0]) + 0.3 * d
        space.add(style_wall_shape(pymunk.Segment(space.static_body, tuple(p0), tuple(p1), 0.001)))


def grow_into_inclined_wall(wall_deg: float, config: SimConfig | None = None) -> tuple[EversionSim, float]:
    """The 40 mm, 300 mm robot grown 4 s at 3 kPa towards a wall 100 mm ahead at ``wall_deg``
    to its path; returns the simulator and the tip's heading (degrees)."""
    sim = EversionSim(TubeDesign(length_m=0.3), scene=_InclinedWall(0.1, wall_deg), config=config)
    sim.set_pressure_command(3000.0)
    sim.run(4.0)
    return sim, math.degrees(math.atan2(sim.tip_direction[1], sim.tip_direction[0]))


@pytest.mark.parametrize("wall_deg, deflects", [(45.0, True), (60.0, True), (70.0, False), (80.0, False)])
def test_tip_slides_along_an_oblique_wall_and_stalls_on_a_steep_one(wall_deg, deflects):
    """Tip deflection, the behaviour Greer et al. (IJRR 2020) report for vine robots: a tip
    meeting a wall obliquely turns and grows along it; one meeting it nearly head-on stalls.
    Here the 40 mm robot at 3 kPa meets a wall 100 mm ahead at incidence 90 - wall_deg from
    the wall's normal: it slides along walls of 45 and 30 degrees incidence (tip friction
    0.2, whose cone is 11 degrees) and stalls against 20 and 10 degrees (the dynamic engine's
    rigid-column model; tests/test_section_law.py has the section law's answer and
    tests/test_quasistatic.py the quasi-static engine's)."""
    sim, heading = grow_into_inclined_wall(wall_deg, SimConfig(engine="dynamic"))
    if deflects:
        assert sim.length == pytest.approx(0.3) and heading == pytest.approx(wall_deg, abs=10.0)
    else:
        assert sim.stalled and sim.length < 0.1 and abs(heading) < 10.0
