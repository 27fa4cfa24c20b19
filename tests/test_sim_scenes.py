"""The simulator in the scenes: the paper's U-bend rig and the colon phantom."""

import numpy as np
import pytest

from evertgym.design import TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim


def grow(scene, design, pressure_pa, t_max, check=None):
    sim = EversionSim(design, scene=scene)
    sim.set_pressure_command(pressure_pa)
    while sim.t < t_max:
        sim.run(0.25)
        if check is not None:
            check(sim)
        s, _ = scene.project(sim.tip_position)
        if s >= scene.goal_arclength:
            return sim, True
    return sim, False


def test_paper_robot_passes_the_40mm_ubend_at_3kpa_without_bands():
    scene = make_scene({"family": "ubend", "params": {"radius_mm": 40.0}})
    sim, passed = grow(scene, TubeDesign(length_m=0.9), 3000.0, 15.0)
    assert passed
    assert sim.tip_direction[0] < -0.9  # it came round: growing back along -x


@pytest.mark.parametrize("pressure_pa", [1000.0, 8000.0])
def test_no_tunnelling_through_the_tightest_ubend(pressure_pa):
    scene = make_scene({"family": "ubend", "params": {"radius_mm": 20.0}})

    def inside(sim):
        line = sim.centreline()[1:]
        # every node's tube cross-section stays in the lumen (1 mm contact tolerance)
        assert np.all(scene.wall_distance(line) >= sim.radii() - 1e-3)
        s, _ = scene.project(line)
        assert np.all(np.asarray(s) <= scene.length)

    grow(scene, TubeDesign(length_m=0.9), pressure_pa, 8.0, inside)


def test_colon_phantom_runs_with_compliant_walls():
    scene = make_scene({"family": "colon", "params": {}})
    sim = EversionSim(TubeDesign(diameter_m=0.02, length_m=0.8), scene=scene)
    assert sim.scene_handles.bodies  # compliant walls are bodies here
    sim.set_pressure_command(4000.0)
    sim.run(4.0)
    assert np.all(np.isfinite(sim.centreline()))
    assert sim.length > 0.2
