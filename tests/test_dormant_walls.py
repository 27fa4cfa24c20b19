"""Dormant compliant walls: far pieces at rest sleep (static, constraints out), near ones wake."""

import numpy as np
import pymunk
import pytest

from evertgym.design import Band, TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim, SimConfig

COLON_ROBOT = TubeDesign(diameter_m=0.02, length_m=0.8, bands=tuple(Band(p, 0.1) for p in (0.25, 0.3, 0.35)))


def colon_sim(**cfg) -> EversionSim:
    return EversionSim(COLON_ROBOT, scene=make_scene({"family": "colon", "params": {}}), config=SimConfig(engine="dynamic", **cfg))


def test_off_by_default_and_every_piece_stays_dynamic():
    sim = colon_sim()
    sim.set_pressure_command(3000.0)
    sim.run(0.5)
    assert sim._dormant is None
    assert all(b.body_type == pymunk.Body.DYNAMIC for b in sim.scene_handles.bodies)


def test_far_pieces_sleep_near_ones_wake_as_the_robot_grows():
    sim = colon_sim(dormant_walls=True)
    n_constraints = len(sim.space.constraints)
    sim.set_pressure_command(3000.0)
    sim.step(1)
    d = sim._dormant
    assert d.asleep.sum() > 0.8 * len(d.bodies)  # at the entry, nearly all the wall is far from the robot
    asleep0 = d.asleep.copy()
    assert len(sim.space.constraints) < n_constraints  # their ground springs and tethers left the solver
    sim.run(3.0)
    assert sim.length > 0.2 and d.wakes > 0
    woke = asleep0 & ~d.asleep
    assert woke.any()
    # a woken piece is a dynamic body with its mass again, and lies near the robot
    centres = np.array([tuple(b.position) for b in sim.bodies])
    for i in np.nonzero(woke)[0]:
        b = d.bodies[i]
        assert b.body_type == pymunk.Body.DYNAMIC and b.mass == pytest.approx(d._mass[i])
    for i in np.nonzero(d.asleep)[0]:  # a sleeping piece is far from every active segment
        gap = np.min(np.linalg.norm(centres[sim.active_start:] - np.array(tuple(d.bodies[i].position)), axis=1))
        assert gap - d._reach[i] > 0.0


def test_waking_everything_restores_every_constraint():
    sim = colon_sim(dormant_walls=True)
    n_constraints = len(sim.space.constraints)
    sim.step(1)
    d = sim._dormant
    assert d.asleep.any()
    d.margin_m = 100.0  # everything is near now
    sim.step(25)
    assert not d.asleep.any()
    assert len(sim.space.constraints) == n_constraints


def test_the_colon_stall_lies_in_the_band_awake_walls_give():
    """Measured (python -m evertgym.bench.dormant): at 3 kPa the stall length moves between 408 and 433 mm
    under round-off-sized perturbations of the command, with or without dormant walls."""
    out = {}
    for dormant in (False, True):
        sim = colon_sim(dormant_walls=dormant)
        sim.set_pressure_command(3000.0)
        sim.run(12.0)
        out[dormant] = sim.length
        assert sim.stalled
    assert all(0.400 < v < 0.440 for v in out.values()), out


@pytest.mark.parametrize("kw, message", [
    ({"dormant_walls": "yes"}, "dormant_walls = 'yes' is out of range"),
    ({"wall_wake_margin_m": -0.01}, "wall_wake_margin_m = -0.01 is out of range"),
])
def test_bad_settings_are_one_line(kw, message):
    with pytest.raises(ValueError, match=message):
        SimConfig(**kw)
