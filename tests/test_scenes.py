"""Scenes: specs and validation, geometry (numbers), determinism, passability, rendering."""

import json
import math

import numpy as np
import pymunk
import pytest
from matplotlib.image import imread

from evertgym.scenes import (
    FAMILIES,
    PAPER_UBEND_RADII_MM,
    WALL_COLLISION_TYPE,
    SceneError,
    SceneSpec,
    make_scene,
    render_rgb,
)
from evertgym.scenes.geometry import Piece, arc, sample_path, self_intersection

MM = 1e-3


def fit_circle(pts):
    """Least-squares circle (centre, radius) through points (Kasa fit)."""
    A = np.column_stack([2 * pts, np.ones(len(pts))])
    b = (pts**2).sum(axis=1)
    (cx, cy, c), *_ = np.linalg.lstsq(A, b, rcond=None)
    return np.array([cx, cy]), math.sqrt(c + cx**2 + cy**2)


# ---------------------------------------------------------------- specs and validation


def test_every_family_makes_its_default_scene():
    assert {"straight", "ubend", "bend", "sbend", "tortuous", "colon"} <= set(FAMILIES)
    for name, fam in FAMILIES.items():
        for pname, p in fam.params.items():
            assert p.validate(pname, p.default) == p.default
        scene = make_scene({"family": name, "params": {}})
        assert scene.spec.family == name
        assert set(scene.params) == set(fam.params)
        assert np.all(np.diff(scene.arclength) <= 2 * MM + 1e-12)
        assert np.allclose(np.hypot(*np.diff(scene.centreline, axis=0).T), np.diff(scene.arclength), rtol=1e-3)
        assert np.array_equal(scene.entry, [0.0, 0.0]) and np.allclose(scene.entry_direction, [1.0, 0.0])
        assert 0 < scene.goal_arclength <= scene.length
        assert np.allclose(scene.goal, scene.point_at(scene.goal_arclength))
        assert not scene.self_intersecting()


@pytest.mark.parametrize(
    "family, params, message",
    [
        ("ubend", {"radius_mm": 10}, "radius_mm = 10 is out of range: allowed [20, 40] mm"),
        ("ubend", {"radius_mm": 45.0}, "radius_mm = 45 is out of range: allowed [20, 40] mm"),
        ("bend", {"radius_mm": -5}, "radius_mm = -5 is out of range: allowed [3, 1000] mm"),
        ("bend", {"angle_deg": 0}, "angle_deg = 0 is out of range: allowed (0, 180] deg"),
        ("bend", {"angle_deg": 190}, "angle_deg = 190 is out of range: allowed (0, 180] deg"),
        ("straight", {"lumen_mm": float("nan")}, "lumen_mm = nan is not a finite number: allowed [5, 200] mm"),
        ("straight", {"length_mm": float("inf")}, "length_mm = inf is not a finite number"),
        ("straight", {"length_mm": "600"}, "length_mm = '600' is not a number"),
        ("straight", {"length_mm": True}, "length_mm = True is not a number"),
        ("bend", {"turn": "up"}, "turn = 'up' is not allowed: allowed one of 'left', 'right'"),
        ("colon", {"compliant": 1}, "compliant = 1 is not a boolean"),
        ("tortuous", {"n_bends": [2.5, 4]}, "n_bends = [2.5, 4] is not an integer"),
        ("tortuous", {"radius_mm": [60, 20]}, "radius_mm = [60, 20] has min > max"),
        ("tortuous", {"radius_mm": [20, 30, 40]}, "radius_mm = [20, 30, 40] is not a [min, max] pair"),
        ("tortuous", {"radius_mm": 2}, "radius_mm = [2, 2] is out of range: allowed [min, max] with both in [3, 500] mm"),
        ("tortuous", {"angle_deg": [0, 90]}, "angle_deg = [0, 90] is out of range: allowed [min, max] with both in (0, 180] deg"),
        ("tortuous", {"lumen_mm": [30, 50]}, "lumen_mm = [30, 50] is out of range: its min must be >= robot_diameter_mm = 40"),
        ("colon", {"fold_depth_mm": 4}, "fold_depth_mm = 4 is out of range: allowed [0, 3] mm"),
        ("colon", {"lumen_mm": 21}, "fold_depth_mm = 2 is out of range: allowed [0, 0.5] mm"),
        ("colon", {"bend_at_mm": 40}, "bend_at_mm = 40 is out of range: must be >= funnel_length_mm"),
        ("colon", {"length_mm": 420}, "length_mm = 420 is out of range: must be >= bend_at_mm"),
        ("colon", {"bend_radius_end_mm": 3}, "bend_radius_end_mm = 3 is out of range: must be > wall_thickness_mm = 3"),
        ("colon", {"mesocolon_n_per_m_per_mm": 0, "wall_influence_mm": 0}, "mesocolon_n_per_m_per_mm = 0 is out of range"),
        ("ubend", {"goal_after_bend_mm": 200}, "goal_after_bend_mm = 200 is out of range: allowed [0, exit_length_mm = 150] mm"),
    ],
)
def test_bad_parameters_name_the_field_and_range(family, params, message):
    with pytest.raises(SceneError) as err:
        SceneSpec(family, params)
    assert message in str(err.value)
    assert isinstance(err.value, ValueError)


def test_unknown_family_param_and_bad_seed_list_what_is_allowed():
    with pytest.raises(ValueError, match="unknown scene family 'pipe': allowed families are bend, colon, colon_random"):
        make_scene({"family": "pipe", "params": {}})
    with pytest.raises(ValueError, match=r"unknown parameter 'radius' for family 'ubend': allowed parameters are "
                                         r"exit_length_mm, goal_after_bend_mm, lumen_mm, pipe_length_mm, radius_mm"):
        SceneSpec("ubend", {"radius": 25})
    with pytest.raises(ValueError, match="seed = -1 is not allowed"):
        SceneSpec("ubend", {}, seed=-1)
    with pytest.raises(ValueError, match="unknown scene spec keys"):
        SceneSpec.from_dict({"family": "ubend", "parameters": {}})


def test_spec_is_data_roundtrip_and_immutable():
    spec = SceneSpec("tortuous", {"radius_mm": [25, 50], "n_bends": (2, 4)}, seed=7)
    d = spec.to_dict()
    assert d == {"family": "tortuous", "params": {"n_bends": [2, 4], "radius_mm": [25.0, 50.0]}, "seed": 7}
    back = SceneSpec.from_dict(json.loads(json.dumps(d)))
    assert back == spec and hash(back) == hash(spec)
    assert SceneSpec.from_dict({"family": "ubend"}) == SceneSpec("ubend", {})
    with pytest.raises(TypeError):
        spec.params["seed"] = 3
    assert spec.with_params(lumen_mm=50).params["lumen_mm"] == (50.0, 50.0)  # one number: a fixed value


def test_paper_ubend_radii_are_all_valid():
    assert PAPER_UBEND_RADII_MM == tuple(40 - 2.5 * i for i in range(9))
    for r in PAPER_UBEND_RADII_MM:
        assert make_scene({"family": "ubend", "params": {"radius_mm": r}}).params["radius_mm"] == r


# ---------------------------------------------------------------- determinism


def _shape_data(scene):
    space = pymunk.Space()
    handles = scene.build(space)
    return [(tuple(s.a), tuple(s.b), s.radius) for s in handles.shapes], [tuple(b.position) for b in handles.bodies]


@pytest.mark.parametrize("family", ["tortuous", "colon_random"])
def test_same_seed_rebuilds_the_same_scene_bit_for_bit(family):
    a = make_scene({"family": family, "params": {}, "seed": 123})
    b = make_scene(SceneSpec(family, {}, 123))
    for name in ("centreline", "arclength", "lumen_width", "heading", "entry", "goal"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert all(np.array_equal(wa, wb) for wa, wb in zip(a.walls, b.walls))
    assert a.goal_arclength == b.goal_arclength and dict(a.params) == dict(b.params)
    assert _shape_data(a) == _shape_data(b)
    c = make_scene({"family": family, "params": {}, "seed": 124})
    assert len(c.centreline) != len(a.centreline) or not np.array_equal(c.centreline, a.centreline)


def test_unseeded_scene_records_its_seed_and_rebuilds():
    a = make_scene({"family": "tortuous", "params": {}})
    assert isinstance(a.spec.seed, int)
    b = make_scene(a.spec.to_dict())
    assert np.array_equal(a.centreline, b.centreline)


def test_pinning_a_variant_parameter_keeps_the_other_draws():
    free = make_scene({"family": "colon_random", "params": {}, "seed": 5})
    pinned = make_scene({"family": "colon_random", "params": {"bend_angle_deg": 90.0}, "seed": 5})
    assert pinned.params["bend_angle_deg"] == 90.0
    for k in ("lumen_mm", "fold_spacing_mm", "fold_depth_mm", "bend_radius_end_mm", "wall_modulus_kpa"):
        assert pinned.params[k] == free.params[k]


# ---------------------------------------------------------------- geometry, in numbers


@pytest.mark.parametrize("radius_mm", [20.0, 25.0, 37.5, 40.0])
def test_ubend_is_the_paper_rig(radius_mm):
    scene = make_scene({"family": "ubend", "params": {"radius_mm": radius_mm}})
    left, right = scene.walls
    rc = (radius_mm + 27.5) * MM
    bend = (scene.arclength > 0.3 + 1e-9) & (scene.arclength < 0.3 + math.pi * rc - 1e-9)
    centre, r_in = fit_circle(left[bend])
    _, r_out = fit_circle(right[bend])
    assert r_in == pytest.approx(radius_mm * MM, abs=0.5 * MM)  # inner wall radius as measured from the wall
    assert r_out - r_in == pytest.approx(55 * MM, abs=1e-6)
    assert np.allclose(scene.lumen_width, 55 * MM)
    assert scene.min_clearance() == pytest.approx(55 * MM, abs=0.02 * MM)
    assert np.allclose(centre, [0.3, rc], atol=1e-9)
    assert scene.length == pytest.approx(0.3 + math.pi * rc + 0.15, abs=1e-9)
    # goal: 60 mm into the exit leg, which runs back along -x
    assert scene.goal_arclength == pytest.approx(0.3 + math.pi * rc + 0.06, abs=1e-12)
    assert np.allclose(scene.goal, [0.3 - 0.06, 2 * rc], atol=1e-9)
    assert scene.heading[-1] == pytest.approx(math.pi)
    # in pymunk the inner surface of the static walls is the lumen boundary
    space = pymunk.Space()
    handles = scene.build(space)
    probe = centre + np.array([0.0, -(radius_mm + 5) * MM])  # 5 mm into the lumen from the inner wall
    hit = space.point_query_nearest(tuple(probe), 1.0, pymunk.ShapeFilter())
    assert hit.distance == pytest.approx(5 * MM, abs=0.03 * MM)
    assert not handles.bodies and not space.bodies and handles.wall_displacement() == 0.0


def test_rigid_scenes_have_static_wall_shapes_only():
    for spec in ({"family": "sbend", "params": {}}, {"family": "tortuous", "params": {}, "seed": 1},
                 {"family": "colon", "params": {"compliant": False}}):
        scene = make_scene(spec)
        space = pymunk.Space()
        handles = scene.build(space)
        assert not scene.compliant and not space.bodies and not space.constraints and handles.network is None
        assert len(space.shapes) == len(handles.shapes) > 0
        for s in handles.shapes:
            assert s.body is space.static_body
            assert (s.friction, s.elasticity, s.collision_type) == (1.0, 0.0, WALL_COLLISION_TYPE)
    assert make_scene(spec).wall_radius == 1.5 * MM  # the rigid colon keeps its 3 mm wall


def test_bend_and_sbend_geometry():
    for turn, sign in (("left", 1), ("right", -1)):
        scene = make_scene({"family": "bend", "params": {"angle_deg": 135, "radius_mm": 50, "lumen_mm": 40, "turn": turn}})
        assert scene.heading[-1] == pytest.approx(sign * 0.75 * math.pi)
        inner = scene.walls[0 if sign > 0 else 1]
        in_bend = (scene.arclength > 0.3 + 1e-9) & (scene.arclength < 0.3 + 0.75 * math.pi * 0.07 - 1e-9)
        assert fit_circle(inner[in_bend])[1] == pytest.approx(50 * MM, abs=1e-6)
        assert scene.goal_arclength == pytest.approx(0.3 + 0.75 * math.pi * 0.07 + 0.06)
    scene = make_scene({"family": "sbend", "params": {"angle_deg": 60, "radius_mm": 40, "lumen_mm": 30, "middle_mm": 50}})
    rc, th = 0.055, math.pi / 3
    assert scene.heading[-1] == pytest.approx(0.0, abs=1e-12)
    assert scene.centreline[-1, 1] == pytest.approx(2 * rc * (1 - math.cos(th)) + 0.05 * math.sin(th))


def test_colon_defaults_are_the_paper_phantom():
    scene = make_scene({"family": "colon", "params": {}})
    s, w = scene.arclength, scene.lumen_width
    assert scene.compliant and scene.length == pytest.approx(0.51)
    assert w[0] == pytest.approx(30 * MM) and scene.lumen_at(0.03) == pytest.approx(26 * MM)  # funnel
    body = s > 0.03
    assert w[body].max() == pytest.approx(26 * MM, abs=1e-6) and w[body].min() == pytest.approx(22 * MM, abs=1e-6)
    crests = s[1:-1][(w[1:-1] < w[:-2]) & (w[1:-1] < w[2:])]
    assert np.allclose(np.diff(crests), 30 * MM, atol=1.01 * MM)  # fold spacing
    # the 90-degree bend starts at 360 mm; its inner-wall radius runs from 80 to 20 mm
    bend = (s >= 0.36) & (scene.curvature > 1 / 0.2)
    assert s[bend][0] == pytest.approx(0.36, abs=1.01 * MM)
    end_of_bend = s[bend][-1]
    slope, k0 = np.polyfit(s[bend] - 0.36, scene.curvature[bend], 1)  # a clothoid: curvature linear in s
    assert 1 / k0 - 13 * MM == pytest.approx(80 * MM, rel=1e-6)
    assert 1 / (k0 + slope * (end_of_bend - 0.36)) - 13 * MM == pytest.approx(20 * MM, rel=1e-6)
    assert scene.heading[-1] - scene.heading[np.argmin(np.abs(s - 0.36))] == pytest.approx(math.pi / 2)
    assert scene.goal_arclength == pytest.approx(end_of_bend + 0.05, abs=1e-6)
    assert scene.passable(20 * MM) and not scene.passable(22.1 * MM)
    assert scene.derived["wall_stiffness_n_per_m_per_mm"] == pytest.approx(0.542 + 1.0, abs=0.01)


def test_colon_flexures_repeat_the_bend_turning_alternately():
    one = make_scene({"family": "colon", "params": {}})
    scene = make_scene({"family": "colon", "params": {"n_flexures": 3, "flexure_gap_mm": 60, "length_mm": 900}})
    bend = (one.arclength >= 0.36) & (one.curvature > 1 / 0.2)
    bend_m = one.arclength[bend][-1] - 0.36
    regions = scene.bend_regions()
    assert len(regions) == 3 and len(one.bend_regions()) == 1
    starts = [a for a, _ in regions]
    assert np.allclose(np.diff(starts), bend_m + 0.06, atol=1.01 * MM)  # each a copy of the bend, 60 mm of straight apart
    s, h = scene.arclength, scene.heading
    between = [0.35] + [0.36 + k * (bend_m + 0.06) + bend_m + 0.03 for k in range(3)]  # on the straights around them
    heading = [h[np.searchsorted(s, x)] for x in between]
    assert np.diff(heading) == pytest.approx([math.pi / 2, -math.pi / 2, math.pi / 2], abs=1e-6)  # left, right, left
    assert scene.goal_arclength == pytest.approx(0.36 + 3 * bend_m + 2 * 0.06 + 0.05, abs=1.01 * MM)
    assert not scene.self_intersecting()
    with pytest.raises(ValueError, match=r"length_mm = 600 is out of range: must be >= bend_at_mm \+ the flexures' length"):
        make_scene({"family": "colon", "params": {"n_flexures": 3, "length_mm": 600}})
    with pytest.raises(ValueError, match=r"n_flexures = 0 is out of range: allowed \[1, 8\]"):
        make_scene({"family": "colon", "params": {"n_flexures": 0}})


def test_random_colons_with_flexures_fit_their_length_and_leave_one_flexure_unchanged():
    for seed in range(100):
        c = make_scene({"family": "colon_random", "params": {"n_flexures": 4}, "seed": seed})
        assert len(c.bend_regions()) == 4 and c.passable(20 * MM) and not c.self_intersecting(), seed
        assert 40 <= c.params["flexure_gap_mm"] <= 120 and c.length >= c.goal_arclength
    # pinning the number of flexures leaves every other draw of the seed as it was
    one = make_scene({"family": "colon_random", "params": {}, "seed": 7})
    three = make_scene({"family": "colon_random", "params": {"n_flexures": 3}, "seed": 7})
    same = [k for k in one.params if k not in ("length_mm", "n_flexures", "flexure_gap_mm")]
    assert {k: one.params[k] for k in same} == {k: three.params[k] for k in same}


def test_project_lumen_and_inside():
    scene = make_scene({"family": "ubend", "params": {"radius_mm": 30}})
    s_true = np.array([0.1, 0.35, 0.5])
    pts = scene.point_at(s_true)
    s, e = scene.project(pts)
    assert np.allclose(s, s_true, atol=1e-6) and np.allclose(e, 0.0, atol=1e-6)
    assert scene.project(pts[0] + [0.0, -0.012]) == pytest.approx((0.1, -0.012), abs=1e-12)  # exact on straights
    n = np.column_stack([-np.sin(scene.heading), np.cos(scene.heading)])
    i = np.searchsorted(scene.arclength, 0.35)
    s1, e1 = scene.project(scene.centreline[i] + 0.01 * n[i])  # in the bend: chords, to O(e ds k)
    assert s1 == pytest.approx(scene.arclength[i], abs=0.5 * MM) and e1 == pytest.approx(0.01, abs=0.01 * MM)
    assert scene.lumen_at(0.35) == pytest.approx(0.055)
    assert scene.project(np.array([-0.02, 0.0]))[0] == pytest.approx(-0.02)
    inside = scene.is_inside(np.array([pts[0], pts[0] + [0, 0.01], pts[0] + [0, 0.02], [-0.02, 0.0]]), 0.015)
    assert inside.tolist() == [True, True, False, False]  # 10 + 15 <= 27.5; 20 + 15 > 27.5; before the entry
    assert scene.is_inside(pts[1], 0.0274) and not scene.is_inside(pts[1], 0.0276)


def test_self_intersection_check_detects_overlap_and_accepts_tight_bends():
    def channel(width, rc, angle, lead=0.1):
        path = sample_path([Piece(lead), arc(rc - width / 2, width / 2, angle), Piece(lead)], 2 * MM)
        reach = np.full(len(path.s), width / 2 + 2 * MM)
        return self_intersection(path.s, path.xy, reach, path.curvature)

    assert not channel(0.055, 0.06, math.pi)  # legs 120 mm apart, need 59
    assert not channel(0.020, 0.0125, math.pi)  # a tight U around a 2.5 mm post: legs 25 mm apart, need 24
    assert channel(0.020, 0.05, 2.2 * math.pi)  # a loop crossing its own lead-in
    assert channel(0.030, 0.016, math.pi / 2)  # inner wall folds over itself (curvature * reach > 1)
    # two U-turns the same way run back into the lead-in
    path = sample_path([Piece(0.1), arc(0.02, 0.03, math.pi), Piece(0.05), arc(0.02, 0.03, math.pi), Piece(0.1)], 2 * MM)
    assert self_intersection(path.s, path.xy, np.full(len(path.s), 0.032), path.curvature)
    legs_apart = sample_path([Piece(0.1), arc(0.02, 0.03, math.pi), Piece(0.05), arc(0.02, 0.03, -math.pi), Piece(0.1)], 2 * MM)
    assert not self_intersection(legs_apart.s, legs_apart.xy, np.full(len(legs_apart.s), 0.032), legs_apart.curvature)


def test_1000_random_tortuous_and_colon_scenes_are_passable_and_embedded():
    for seed in range(1000):
        t = make_scene({"family": "tortuous", "params": {}, "seed": seed})
        assert t.passable(40 * MM) and not t.self_intersecting(), seed
        c = make_scene({"family": "colon_random", "params": {}, "seed": seed})
        assert c.passable(20 * MM) and not c.self_intersecting(), seed
        assert c.lumen_width[c.arclength > c.compliant_from].min() == pytest.approx(
            (c.params["lumen_mm"] - 2 * c.params["fold_depth_mm"]) * MM, abs=0.05 * MM)


def test_tortuous_ranges_are_respected():
    p = {"n_bends": [4, 4], "radius_mm": [25, 35], "angle_deg": [80, 100], "lumen_mm": [30, 34], "robot_diameter_mm": 30}
    for seed in range(20):
        scene = make_scene({"family": "tortuous", "params": p, "seed": seed})
        k = np.abs(scene.curvature)
        w = scene.lumen_width
        assert 30 * MM <= w.min() and w.max() <= 34 * MM
        bends = k > 0
        r_in = 1 / k[bends] - w[bends] / 2
        assert r_in.min() >= 25 * MM - 1e-9 and r_in.max() <= 35 * MM + 1e-9
        starts = np.flatnonzero(np.diff(bends.astype(int)) == 1)
        assert len(starts) == 4


# ---------------------------------------------------------------- rendering


def test_render_rgb_draws_scene_and_robot():
    scene = make_scene({"family": "ubend", "params": {}})
    img = render_rgb(scene, width=320, height=240)
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 5
    robot = scene.point_at(np.linspace(0, 0.4, 41))
    with_robot = render_rgb(scene, robot_xy=robot, robot_radius=0.02, width=320, height=240)
    orange = (with_robot[..., 0] > 200) & (with_robot[..., 1] > 100) & (with_robot[..., 1] < 180) & (with_robot[..., 2] < 90)
    assert orange.sum() > 1000 and not ((img[..., 0] > 200) & (img[..., 2] < 90) & (img[..., 1] > 100)).any()
    thin = render_rgb(scene, robot_xy=robot, width=320, height=240)
    assert not np.array_equal(thin, img)


def test_the_gallery_writes_the_png(tmp_path):
    from evertgym.scenes.gallery import main as gallery

    out = tmp_path / "gallery.png"
    gallery(["--out", str(out)])
    img = imread(out)
    assert img.shape[0] > 500 and img.shape[1] > 1000


def test_bend_regions_cover_the_ubend_arc_and_nothing_of_a_straight():
    """The U-bend's bend region is its arc (samples within one spacing), entered ``approach_m``
    early; a straight pipe has none; a two-bend S has two."""
    import math

    scene = make_scene({"family": "ubend", "params": {"radius_mm": 30.0, "pipe_length_mm": 300.0}})
    half_w = 0.5 * scene.lumen_at(0.0)
    arc_len = math.pi * (0.030 + half_w)
    ds = float(np.max(np.diff(scene.arclength)))
    (a, b), = scene.bend_regions()
    assert a == pytest.approx(0.300, abs=2 * ds) and b == pytest.approx(0.300 + arc_len, abs=2 * ds)
    (a2, b2), = scene.bend_regions(approach_m=0.02)
    assert a2 == pytest.approx(a - 0.02) and b2 == b
    assert make_scene({"family": "straight"}).bend_regions() == []
    assert len(make_scene({"family": "sbend"}).bend_regions()) == 2
