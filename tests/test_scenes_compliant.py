"""Compliant colon walls in pymunk: stiffness as specified, recovery, stability at dt = 1 ms."""

import math

import numpy as np
import pymunk
import pytest
import scipy.linalg

from evertgym.scenes import WALL_COLLISION_TYPE, make_scene, wall_shape_filter

MM = 1e-3
DT = 1e-3


def built(params=None):
    scene = make_scene({"family": "colon", "params": params or {}})
    space = pymunk.Space()
    return scene, space, scene.build(space)


def piece_near(scene, net, s_target, side=0):
    """Index of the piece of wall ``side`` (0 left, 1 right) whose centre is nearest arc length ``s_target``."""
    s, e = scene.project(net.position)
    on_side = (e > 0) if side == 0 else (e < 0)
    return int(np.argmin(np.where(on_side, np.abs(s - s_target), np.inf)))


def normal_displacement(handles, i):
    net = handles.network
    return float((np.array(tuple(handles.bodies[i].position)) - net.position[i]) @ net.normal[i])


def test_derived_wall_stiffness_is_ecoflex_ring_plus_mesocolon():
    scene = make_scene({"family": "colon", "params": {}})
    E, h, R, nu = 83e3, 3e-3, 14.5e-3, 0.49
    ring = E * h**3 / (12 * (1 - nu**2)) / ((math.pi / 4 - 2 / math.pi) * R**3)  # Roark, thin ring
    assert scene.derived["wall_ring_stiffness_n_per_m_per_mm"] == pytest.approx(ring * 1e-3, rel=1e-12)
    assert ring * 1e-3 == pytest.approx(0.542, abs=1e-3)
    assert scene.derived["wall_stiffness_n_per_m_per_mm"] == pytest.approx(ring * 1e-3 + 1.0)
    assert scene.derived["piece_stiffness_n_per_m"] == pytest.approx((ring * 1e-3 + 1.0) * 10)
    stiffer = make_scene({"family": "colon", "params": {"wall_modulus_kpa": 166.0}})
    assert stiffer.derived["wall_ring_stiffness_n_per_m_per_mm"] == pytest.approx(2 * ring * 1e-3)


def test_compliant_walls_are_bodies_on_springs_and_rest_in_equilibrium():
    scene, space, handles = built()
    net = handles.network
    n = net.n_pieces
    assert n == len(handles.bodies) == len(space.bodies) == 2 * 48  # (510 - 30) mm in 10 mm pieces, both walls
    assert np.allclose(net.length, 10 * MM, atol=1.01 * MM)
    assert len(handles.springs) == 4 * n  # two normal and one tangential suspension spring, one link each
    static = [s for s in handles.shapes if s.body is space.static_body and s not in handles.backstop]
    assert static and all(s.bb.left < 0.031 for s in static)  # only the funnel is rigid
    # the backstop lies behind the compliant wall, beyond a piece at its full travel (its
    # face at travel + h on straights; the haustral folds bring it in by up to 1.5 mm)
    travel, h = net.mechanics.max_travel_m, net.mechanics.thickness_m
    ends = np.array([[tuple(s.a), tuple(s.b)] for s in handles.backstop]).reshape(-1, 2)
    faces = scene.wall_distance(ends) - 0.5 * h
    assert len(ends) and np.all(faces > travel) and np.median(faces) == pytest.approx(travel + h, abs=2e-4)
    filt = wall_shape_filter()
    for s in handles.shapes:
        assert s.collision_type == WALL_COLLISION_TYPE and s.filter == filt and s.friction == 1.0
    assert filt.rejects_collision(filt) and not filt.rejects_collision(pymunk.ShapeFilter())
    for _ in range(300):
        space.step(DT)
    assert handles.wall_displacement() < 1e-9


def test_masses_keep_the_wall_stable_at_one_millisecond():
    _, _, handles = built()
    net = handles.network
    M = np.diag(np.column_stack([net.mass, net.mass, net.moment]).ravel())
    lam = scipy.linalg.eigh(net.stiffness_matrix(), M, eigvals_only=True)
    assert math.sqrt(lam[-1]) * DT <= 0.3 + 1e-9
    assert net.time_constant_s == pytest.approx(1 / math.sqrt(lam[0]))
    assert 0.005 < net.time_constant_s < 0.05


def test_point_load_deflects_the_wall_as_its_stiffness_says_and_it_recovers():
    scene, space, handles = built()
    net = handles.network
    i = piece_near(scene, net, 0.2)
    k = net.point_stiffness(i)
    foundation = scene.derived["wall_stiffness_n_per_m_per_mm"] * 1e3 * net.length[i]
    assert foundation < k < 3 * foundation  # the neighbours share the load
    force = 0.05  # N, outwards
    body = handles.bodies[i]
    steps = int(10 * net.time_constant_s / DT)
    for _ in range(steps):
        body.apply_force_at_world_point(tuple(force * net.normal[i]), tuple(body.position))
        space.step(DT)
    loaded = normal_displacement(handles, i)
    assert loaded == pytest.approx(force / k, rel=0.02)  # ~2 mm
    assert handles.wall_displacement() == pytest.approx(loaded, rel=0.05)
    for _ in range(int(8 * net.time_constant_s / DT)):
        space.step(DT)
    assert handles.wall_displacement() < 0.01 * loaded


def test_uniform_pressure_deflects_a_straight_wall_by_q_over_k():
    scene, space, handles = built({"sigmoid_angle_deg": 0.0})  # straight from the funnel to the bend
    net = handles.network
    k_per_m = scene.derived["wall_stiffness_n_per_m_per_mm"] * 1e3
    q = 3.0  # N per m of tube
    left = [i for i in range(net.n_pieces) if scene.project(net.position[i])[1] > 0]
    for _ in range(int(10 * net.time_constant_s / DT)):
        for i in left:
            b = handles.bodies[i]
            b.apply_force_at_world_point(tuple(q * net.length[i] * net.normal[i]), tuple(b.position))
        space.step(DT)
    s = np.array([scene.project(net.position[i])[0] for i in left])
    middle = [i for i, si in zip(left, s) if 0.1 < si < 0.3]
    u = np.array([normal_displacement(handles, i) for i in middle])
    assert len(middle) == 20
    assert np.allclose(u, q / k_per_m, rtol=0.005)  # ~1.9 mm


def test_a_disc_pushed_into_the_wall_indents_it_and_the_wall_recovers():
    scene, space, handles = built()
    net = handles.network
    i = piece_near(scene, net, 0.2)
    probe = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    start = scene.point_at(scene.project(net.position[i])[0])  # on the centreline, opposite piece i
    gap = float(scene.wall_distance(start)[0]) - 5 * MM  # a disc of 5 mm radius
    probe.position = tuple(start)
    space.add(probe, pymunk.Circle(probe, 5 * MM))
    probe.velocity = tuple(0.02 * net.normal[i])  # m/s
    for _ in range(int(round((gap + 3 * MM) / 0.02 / DT))):  # 3 mm into the wall
        space.step(DT)
    assert handles.wall_displacement() == pytest.approx(3 * MM, abs=0.3 * MM)
    assert normal_displacement(handles, i) > 2 * MM
    probe.velocity = (0.0, 0.0)
    probe.position = tuple(start)
    for _ in range(int(8 * net.time_constant_s / DT)):
        space.step(DT)
    assert handles.wall_displacement() < 0.03 * MM


@pytest.mark.parametrize("dt", [1e-3, 2e-3])
def test_global_damping_does_not_bias_the_wall_when_build_knows_dt(dt):
    scene = make_scene({"family": "colon", "params": {}})
    space = pymunk.Space()
    space.damping = 1e-6  # the simulator's default
    handles = scene.build(space, dt=dt)
    net = handles.network
    i = piece_near(scene, net, 0.2)
    body = handles.bodies[i]
    for _ in range(int(0.25 / dt)):
        body.apply_force_at_world_point(tuple(0.05 * net.normal[i]), tuple(body.position))
        space.step(dt)
    assert normal_displacement(handles, i) == pytest.approx(0.05 / net.point_stiffness(i), rel=0.005)
