"""The switchable laws of the band-mechanism study (evertgym.sim.band_laws): their
formulas, their effect on the quasi-static engine's stall, and their bad input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from test_sim import _InclinedWall, grow_into_inclined_wall

from evertgym.design import Band, TubeDesign
from evertgym.sim import EversionSim, SimConfig
from evertgym.sim.band_laws import band_fold_pressure, flattening, fold_excess

R = 0.02  # the paper robot's radius (m)


def test_a_band_goes_slack_at_the_paper_robots_numbers():
    """bend-physics.md section 8: at 3 kPa a 10/20/30% band's wall tension p pi r_b^2 is 3.05 / 2.41 /
    1.85 N; a push equal to it makes the band slack exactly at 3 kPa."""
    for red, force in ((0.1, 3.05), (0.2, 2.41), (0.3, 1.85)):
        r_b = R * (1 - red)
        assert 3000.0 * math.pi * r_b**2 == pytest.approx(force, abs=0.01)
        assert band_fold_pressure(force - 0.5, 0.5, r_b) == pytest.approx(3000.0, rel=0.01)
    assert band_fold_pressure(-1.0, 0.0, R) == 0.0  # a wall pulling the tip is no push


def test_the_excess_fold_angle_is_zero_for_a_smooth_bend_and_the_hinge_angle_for_a_fold():
    ds = 0.0075
    smooth = np.full(20, 0.5 * ds / R)  # curvature 1 / (2 r): the inner side shortened, not folded
    assert fold_excess(smooth, np.full(20, ds), np.full(20, R)) == 0.0
    for n in (10, 20, 40):  # one hinge of 1 rad: Phi -> 1 rad as the segments shrink
        phi = np.zeros(n)
        phi[n // 2] = 1.0
        seg = np.full(n, 0.15 / n)
        assert fold_excess(phi, seg, np.full(n, R)) == pytest.approx(1.0 - 0.15 / n / R)


def test_flattening_starts_at_wrinkling_saturates_at_three_times_it_and_is_deeper_at_a_band():
    k = np.full(5, 2.0)  # N m/rad
    mw = np.full(5, 0.02)  # N m: wrinkling at phi_w = 0.01 rad
    phi = np.array([0.005, 0.01, 0.02, 0.03, 0.5])  # x = 0.5, 1, 2, 3, 50
    r = np.full(5, R)
    assert flattening(phi, k, mw, r, R, 0.2) == pytest.approx([0.0, 0.0, 0.1, 0.2, 0.2])
    r[4] = 0.9 * R  # a 10% band: f_max 0.2 + 0.1
    assert flattening(-phi, k, mw, r, R, 0.2)[4] == pytest.approx(0.3)


def _bare_robot_in_the_30mm_bend(sim: dict):
    """The bare paper robot (trial 0 of the 30 mm U-bend) grown 4.5 s at 3 kPa with the SimConfig overrides ``sim``:
    its tip is in the bend."""
    from evertgym.experiments.paper import ubend_specs
    from evertgym.experiments.trial import make_trial_env
    spec = ubend_specs(1, radii=(30.0,), reductions=(0.0,), sim={"engine": "quasistatic", **sim})[0]
    env = make_trial_env(spec)
    env.reset(seed=0)
    env.sim.set_pressure_command(3000.0)
    env.sim.run(4.5)
    assert env.sim.length > 0.34
    return env.sim


def test_flattening_shrinks_the_collision_radius_of_a_bent_body_and_its_collapse_moment():
    """The paper robot grown into a 30 mm U-bend: with flattening the segments in the bend collide with
    a smaller radius and their joints collapse at a lower moment; without it, neither changes."""
    out = {}
    for f_max in (0.0, 0.2):
        sim = _bare_robot_in_the_30mm_bend({"flattening": f_max})
        out[f_max] = (float(np.min(sim.radii()[:-1])), float(np.min(sim.collapse_moments() / (3000.0 * math.pi * R**3))))
    assert out[0.0][0] == pytest.approx(R, abs=1e-9) and out[0.0][1] == pytest.approx(sim.pressure / 3000.0, rel=0.05)
    assert out[0.2][0] < 0.9 * R and out[0.2][1] < 0.9 * out[0.0][1]


def test_a_band_that_folds_under_the_push_stops_the_tip_at_a_smaller_wall_force():
    """Head-on against a wall (10 degrees incidence) with a 30% band everted behind the tip: with
    ``band_fold`` the robot stalls when the wall's reaction reaches p pi r_b^2 - T_tail; without it,
    at the growth law's own limit, which is larger."""
    design = TubeDesign(length_m=0.3, bands=(Band(0.04, 0.3),))
    out = {}
    for fold in (False, True):
        cfg = SimConfig(engine="quasistatic", band_fold=fold)
        sim = EversionSim(design, scene=_InclinedWall(0.1, 80.0), config=cfg)
        sim.set_pressure_command(3000.0)
        sim.run(4.0)
        assert sim.stalled and sim.solve_stats["solve_failures"] == 0
        out[fold] = sim.tip_force
    p_y = float(sim.threshold(0.0))
    r_b = R * 0.7
    cap = 3000.0 * math.pi * r_b**2 - p_y * math.pi * R**2  # the tail's tension: the bare threshold's force
    assert out[True] == pytest.approx(cap, rel=0.03)
    assert out[False] > out[True] + 0.5


def test_the_laws_are_off_by_default_and_leave_the_engine_unchanged():
    a, _ = grow_into_inclined_wall(80.0, SimConfig(engine="quasistatic"))
    b, _ = grow_into_inclined_wall(80.0, SimConfig(engine="quasistatic", fold_pinch_per_rad=0.0, band_fold=False))
    assert a.length == b.length and a.tip_force == b.tip_force


@pytest.mark.parametrize("kwargs, message", [
    (dict(engine="dynamic", band_fold=not SimConfig().band_fold), f"band_fold = {not SimConfig().band_fold} means nothing to engine 'dynamic'"),
    (dict(fold_pinch_per_rad=-0.1), "fold_pinch_per_rad = -0.1 is out of range"),
    (dict(flattening=0.6), "flattening = 0.6 is out of range"),
    (dict(engine="dynamic", flattening=0.2), "flattening = 0.2 means nothing to engine 'dynamic'"),
    (dict(band_fold="yes"), "band_fold = 'yes' is out of range: allowed true or false"),
    (dict(engine="dynamic", band_eversion_threshold=False), "band_eversion_threshold = False means nothing to engine 'dynamic'"),
    (dict(joint_softening=0.95), "joint_softening = 0.95 is out of range: allowed [0, 0.9]"),
    (dict(joint_softening=-0.1), "joint_softening = -0.1 is out of range"),
])
def test_bad_law_settings_are_one_line(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)) as err:
        SimConfig(**kwargs)
    assert "\n" not in str(err.value)


# ---- the physics line of every U-bend and colon command ----------------------------------------------------------

def test_the_physics_line_names_the_adopted_model_its_fits_and_the_overrides():
    from evertgym.experiments.bend_model import physics_note
    from evertgym.sim.variation import bend_model
    default = physics_note()
    model = bend_model()
    assert default.startswith("physics: quasi-static engine with bend model (" + model["candidate"] + ")")
    for name in model["fitted"]:
        assert name in default and "fitted on" in default
    for miss in model.get("misses", []):
        assert miss in default
    for name, v in model["switches"].items():  # a switch's value that nothing fitted is declared as such
        if not isinstance(v, bool) and name not in model["fitted"]:
            assert f"{name} {v:g}" in default.split("declared, not fitted: ")[1]
    assert 'overrides on top: {"band_fold": true, "flattening": 0.2}' in physics_note({"band_fold": True, "flattening": 0.2})
    assert physics_note({"engine": "dynamic", "section_law": True}).startswith("physics: dynamic engine (section law)")


def test_reproduce_ubend_names_its_physics_in_the_table_and_the_json(capsys, tmp_path):
    import json

    from evertgym.cli import main
    argv = ["reproduce", "ubend", "--sim", '{"band_fold": true}', "--radii", "40", "--reductions", "0.3", "--trials", "1",
            "--db", str(tmp_path / "u.sqlite"), "--backend", "serial"]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert '"band_fold": true' in out["physics"] and out["rows"][0]["successes"] == 0  # a 30% band folds under a 40 mm bend's push
    assert main(argv) == 0
    assert "physics: quasi-static engine" in capsys.readouterr().out


# ---- candidate (b): the joint law softening past its peak ------------------------------------------------------

def test_the_softening_law_peaks_at_its_onset_falls_by_its_drop_and_is_off_at_zero():
    from evertgym.model.pressure import wrinkled_moment_fraction
    from evertgym.sim.discretize import RESIDUAL_STIFFNESS_FRACTION
    from evertgym.sim.quasistatic import SOFTENING_ONSET, SOFTENING_SPAN, _law_table, law_table

    u0, h0, hi0, s0 = _law_table(0.0)
    tension_field = np.maximum(np.asarray(wrinkled_moment_fraction(np.exp(u0)), float), 0.5 * RESIDUAL_STIFFNESS_FRACTION * np.exp(u0))
    assert np.array_equal(h0, tension_field)  # no softening: the tension-field law, bit for bit
    u, h, hi, slope = _law_table(0.3)
    x = np.exp(u)
    onset = x[np.argmax(h0 >= SOFTENING_ONSET)]
    assert h[x < 100].max() == pytest.approx(SOFTENING_ONSET, abs=2e-3)  # the peak: the onset's moment
    assert np.array_equal(h[x <= onset], h0[x <= onset])  # the rising branch unchanged
    falling = (x > onset) & (x < onset * SOFTENING_SPAN)
    assert np.all(np.diff(h[falling]) < 0)  # a negative tangent past the peak
    after = (x >= onset * SOFTENING_SPAN) & (x < 100)
    assert h[after] == pytest.approx(SOFTENING_ONSET * 0.7)  # fallen by the drop
    assert np.all(h >= 0.5 * RESIDUAL_STIFFNESS_FRACTION * x - 1e-12)  # never below the residual stiffness
    assert hi[-1] == pytest.approx(np.trapezoid(h, x), rel=1e-12)  # the energy is the moment's integral
    assert law_table(0.3) is law_table(0.3)  # built once per setting


def test_a_softening_joint_law_is_solved_to_equilibrium_and_turns_the_body_further_in_a_bend():
    """The paper robot grown into a 30 mm U-bend at 3 kPa: every solve converges with the softening law, and its
    joints turn further than without it (the moment falls past the peak, so a hinge takes more of the turn)."""
    turns = {}
    for drop in (0.0, 0.3):
        sim = _bare_robot_in_the_30mm_bend({"joint_softening": drop})
        assert sim.solve_stats["solve_failures"] == 0
        turns[drop] = float(np.max(np.abs(sim.joint_angles())))
    assert turns[0.3] > 1.2 * turns[0.0]
