"""The fast rasteriser: bands, compliant walls where they are, the overlay, env rendering."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from evertgym.env import EversionEnv
from evertgym.render import FrameRenderer, Overlay, robot_profile
from evertgym.scenes import SceneSpec, make_scene

BANDS_M = (0.1, 0.2)


@pytest.fixture(scope="module")
def grown():
    """A 40 mm robot with bands at 100 and 200 mm from the base, grown about 300 mm into a straight channel."""
    design = {"tube": {"length_mm": 600.0}, "bands": [{"position_mm": b * 1e3, "reduction": 0.3} for b in BANDS_M]}
    env = EversionEnv(scene={"family": "straight", "params": {}}, design=design, render_mode="rgb_array")
    env.reset(seed=0)
    while env.sim.length < 0.3:
        env.step(np.array([0.0], np.float32))
    return env


def test_robot_profile_narrows_only_inside_band_strips():
    line = np.array([[0.0, 0.0], [0.3, 0.0]])
    pts, s, r = robot_profile(line, 0.02, [(0.1, 0.3, 0.015)])
    assert pts[-1] == pytest.approx([0.3, 0.0])
    inside = np.abs(s - 0.1) <= 0.0075
    assert np.allclose(r[inside], 0.014) and np.allclose(r[~inside], 0.02)


def test_banded_frame_differs_from_bare_where_the_bands_are(grown):
    sim = grown.sim
    centre = sim.centreline()
    fr = FrameRenderer(grown.scene, handles=sim.scene_handles)
    bands = [(b.position_m, b.reduction, b.width_m) for b in sim.design.bands]
    banded = fr.frame(centre, sim.design.radius_m, bands, sim.scene_handles)
    bare = fr.frame(centre, sim.design.radius_m, [], sim.scene_handles)
    diff = np.argwhere(np.any(banded != bare, axis=-1))  # (row, col)
    assert len(diff) > 0
    # band centres in pixels (x, y) -> (row, col)
    pts, s, _ = robot_profile(centre, sim.design.radius_m, [])
    centres = [fr.to_px(pts[np.searchsorted(s, b.position_m)])[::-1] / fr.k for b in sim.design.bands]
    reach = (1.35 * sim.design.radius_m + 0.5 * sim.design.bands[0].width_m) * fr.scale / fr.k + 3
    dist = np.min([np.hypot(*(diff - c).T) for c in centres], axis=0)
    assert dist.max() <= reach  # every changed pixel is at a band
    for c in centres:  # and every band changed pixels
        assert np.sum(np.hypot(*(diff - c).T) <= reach) > 20


def test_compliant_walls_are_drawn_where_they_are():
    scene = make_scene(SceneSpec("colon", {}, 0))
    import pymunk

    handles = scene.build(pymunk.Space())
    fr = FrameRenderer(scene, handles=handles)
    before = fr.frame(handles=handles)
    body = handles.bodies[len(handles.bodies) // 2]
    rest = np.array(tuple(body.position))
    body.position = tuple(rest + 0.01 * handles.network.normal[len(handles.bodies) // 2])
    after = fr.frame(handles=handles)
    changed = np.argwhere(np.any(before != after, axis=-1))
    assert len(changed) > 0
    moved_px = fr.to_px(rest)[::-1] / fr.k
    piece_px = handles.network.length[len(handles.bodies) // 2] * fr.scale / fr.k
    assert np.hypot(*(changed - moved_px).T).max() <= piece_px + 0.01 * fr.scale / fr.k + 5


def test_overlay_is_drawn_in_its_strip_only(grown):
    sim = grown.sim
    fr = FrameRenderer(grown.scene, handles=sim.scene_handles)
    args = (sim.centreline(), sim.design.radius_m, [], sim.scene_handles)
    plain = fr.frame(*args)
    a = fr.frame(*args, overlay=Overlay(1.0, 3e3, 2.9e3, 0.3, 0.6, "running"))
    b = fr.frame(*args, overlay=Overlay(2.0, 5e3, 4.9e3, 0.3, 0.6, "success"))
    rows = np.flatnonzero(np.any(a != plain, axis=(1, 2)))
    assert rows.max() < fr.overlay_px
    assert np.any(a[: fr.overlay_px] != b[: fr.overlay_px])


def test_env_frame_shape_and_headless_human_mode(grown):
    img = grown.render()
    assert img.shape == (480, 480, 3) and img.dtype == np.uint8
    env = EversionEnv(scene={"family": "straight", "params": {}}, design={"tube": {"length_mm": 600.0}}, render_mode="human")
    env.reset(seed=0)
    import matplotlib

    if matplotlib.get_backend().lower() != "agg":
        pytest.skip("a display backend is active")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.step(np.array([0.0], np.float32))
        env.step(np.array([0.0], np.float32))
    assert sum("cannot show a window" in str(w.message) for w in caught) == 1
    env.close()


def test_bad_frame_size_is_rejected():
    with pytest.raises(ValueError, match="width"):
        FrameRenderer(make_scene(SceneSpec("straight", {}, 0)), width=10)
