"""The peer comparison (evertgym.bench.peers): lumping, convergence rule, choice, output.

The optional engines (``pip install -e '.[bench]'``) are only needed by the tests that
import them with ``pytest.importorskip``.
"""

import json
import math

import numpy as np
import pytest
from scipy.integrate import quad

from evertgym.bench import peers
from evertgym.bench.peers import (
    Case,
    Engine,
    Relaxed,
    choose_discretisation,
    default_case,
    force_error,
    format_table,
    mean_stiffness,
    mujoco_stiffness,
    pyelastica_stiffness,
    reference,
    relax,
    start_shape,
)
from evertgym.cli import build_parser, cmd_bench_peers
from evertgym.design import TubeDesign
from evertgym.sim.discretize import joint_law


@pytest.fixture(scope="module")
def case():
    return default_case()


@pytest.fixture(scope="module")
def bare():
    return Case(TubeDesign(), default_case().free_length_m)


def test_reference_is_below_wrinkling(case):
    ref = reference(case)
    assert not ref["wrinkled"] and ref["max_moment_fraction"] < 0.5
    assert 0.02 < ref["tip_force_n"] < 0.05  # N: three 50% bands soften the 0.227 N bare tube about 7-fold


def test_error_metric_is_signed_relative():
    assert force_error(1.01, 1.0) == pytest.approx(0.01)
    assert force_error(0.98, 1.0) == pytest.approx(-0.02)


def test_start_shape_has_equal_segments_and_reaches_the_displacement(case):
    for flat in (False, True):
        x, y = start_shape(case, 12, flat_first=flat)
        assert np.allclose(np.hypot(np.diff(x), np.diff(y)), case.free_length_m / 12)
        assert y[0] == 0 and y[-1] == pytest.approx(case.displacement_m)
    assert start_shape(case, 12, flat_first=True)[1][1] == 0.0


def test_mean_stiffness_is_compliance_consistent(case):
    sec = case.section
    a, b = case.s_tip - 0.06, case.s_tip - 0.04  # straddles the band 50 mm from the tip
    exact = (b - a) / quad(lambda s: 1.0 / float(sec.bending_stiffness(s)), a, b,
                           points=[p for p in sec.breakpoints() if a < p < b], limit=200)[0]
    assert mean_stiffness(sec.bending_stiffness, a, b, sec.breakpoints()) == pytest.approx(exact, rel=1e-9)


def test_pyelastica_lumping_of_a_uniform_tube_is_exact(bare):
    k = pyelastica_stiffness(bare, 10)
    sec = bare.section
    assert k["bend"].shape == (9,) and k["shear"].shape == k["stretch"].shape == (10,)
    assert np.allclose(k["bend"], sec.bare_bending_stiffness)
    assert np.allclose(k["shear"], sec.shear_stiffness(bare.s_tip))
    assert np.allclose(k["stretch"], sec.axial_stiffness(bare.s_tip))


def test_pyelastica_lumping_keeps_the_bands_compliance(case):
    n = 24
    ds = case.free_length_m / n
    k = pyelastica_stiffness(case, n)
    sec = case.section
    a, b = case.s_base + ds / 2, case.s_tip - ds / 2  # the Voronoi cells tile this
    cuts = [p for p in sec.breakpoints() if a < p < b]
    total = quad(lambda s: 1.0 / float(sec.bending_stiffness(s)), a, b, points=cuts, limit=400)[0]
    assert np.sum(ds / k["bend"]) == pytest.approx(total, rel=1e-9)
    assert k["bend"].min() < 0.1 * k["bend"].max()  # the bands show


def test_mujoco_joints_are_evertgyms_hat_lumping(case):
    n = 7
    k = mujoco_stiffness(case, n)
    law = joint_law(case.section, case.s_base + case.free_length_m / n * np.arange(n), case.s_tip)
    assert np.array_equal(k["hinge"], law.stiffness) and np.array_equal(k["slide"], law.shear_stiffness)


def test_mujoco_sweep_matches_evertgyms_segment_counts(case):
    counts = tuple(max(2, round(case.free_length_m / ds)) for ds in peers.EVERTGYM_SEGMENTS_M)
    assert counts == peers.MUJOCO_SEGMENTS


@pytest.mark.parametrize("errors, expected", [
    ([(0.02, True), (0.005, True), (0.012, True), (0.009, True), (0.001, True)], 3),
    ([(0.005, True), (-0.004, True)], 0),
    ([(0.005, True), (0.001, False)], None),
    ([(0.5, False), (0.009, True)], 1),
])
def test_coarsest_discretisation_with_every_finer_in_budget(errors, expected):
    assert choose_discretisation(errors) == expected


def _relax_sequence(forces, speeds=None):
    it = iter(forces)
    sp = iter(speeds) if speeds is not None else None
    current = {}

    def advance(steps):
        current["f"] = next(it)

    return relax(advance, lambda: current["f"], lambda: next(sp) if sp else 0.0, max_steps=100 * len(forces))


def test_relax_stops_when_the_force_settles_and_all_is_still():
    res = _relax_sequence([1.0, 0.5, 0.52, 0.52, 0.52, 0.52])
    assert res.converged and res.steps == 400 and res.force_n == 0.52
    # the speed is asked once the force has settled: still moving at 300 steps, still at 400
    moving = _relax_sequence([1.0, 0.52, 0.52, 0.52, 0.52], speeds=[1e-6, 1e-8])
    assert moving.converged and moving.steps == 400


def test_relax_reports_divergence_and_the_step_cap():
    assert not _relax_sequence([1.0, math.nan, 1.0]).converged
    blown = _relax_sequence([1.0, 2.0, 500.0, 500.0])
    assert not blown.converged and blown.steps == 300
    capped = _relax_sequence([1.0, 0.9, 0.8, 0.7])
    assert not capped.converged and capped.steps == 400


def _fake_engine(name, module=None, force=1.0):
    def solve(case, disc, max_steps=peers.MAX_STEPS, **setting):
        return Relaxed(force * (1 + 0.02 / disc), 300, True)

    return Engine(name, module, (1, 4, 8), lambda case, n: f"n={n}", solve, lambda case, n: {},
                  lambda case, n: [{"knob": 1.0}, {"knob": 2.0}])


def test_compare_output_keys(monkeypatch, case):
    ref = reference(case)["tip_force_n"]
    monkeypatch.setattr(peers, "ENGINES", (_fake_engine("evertgym", force=ref), _fake_engine("pyelastica", force=ref),
                                           _fake_engine("mujoco", "no_such_module_for_evertgym_tests")))
    result = json.loads(json.dumps(peers.compare(case, repeats=1)))
    assert set(result) == {"case", "rows", "sweeps", "ratios", "criterion"}
    ev, pe, mj = result["rows"]
    assert set(ev) == {"engine", "discretisation", "tip_force_n", "tip_force_error", "wall_s", "steps", "converged",
                       "setting", "untuned_wall_s"}
    assert ev["discretisation"] == "n=4" and ev["tip_force_error"] == pytest.approx(0.005)
    assert mj == {"engine": "mujoco", "skipped": "not installed: pip install -e '.[bench]'"}
    assert result["ratios"]["mujoco_over_evertgym"] is None
    assert result["ratios"]["pyelastica_over_evertgym"] > 0
    assert [r["discretisation"] for r in result["sweeps"]["evertgym"]] == ["n=1", "n=4", "n=8"]
    text = "\n".join(format_table(result))
    assert "tip_force_n" in text and "wall_s" in text and "pip install -e '.[bench]'" in text


def test_cli_has_bench_peers():
    args = build_parser().parse_args(["bench", "peers", "--json"])
    assert args.func is cmd_bench_peers and args.json


def test_evertgym_meets_the_budget_at_its_chosen_segment(case):
    res = peers.solve_evertgym(case, 0.03)
    assert res.converged and abs(force_error(res.force_n, reference(case)["tip_force_n"])) <= peers.ERROR_BUDGET


def test_mujoco_chain_matches_evertgyms_chain(case):
    pytest.importorskip("mujoco")
    n = 7
    mj = peers.solve_mujoco(case, n, 0.8 * (case.free_length_m / n) ** 2, 4e-3)
    ev = peers.solve_evertgym(case, case.free_length_m / n)
    assert mj.converged and mj.force_n == pytest.approx(ev.force_n, rel=1e-4)


def test_mujoco_model_holds_the_tip_on_its_line(case):
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_string(peers.mujoco_xml(case, 7, 5e-4, 4e-3))
    assert model.nv == 2 * 7 + 1 and model.neq == 1
    assert np.allclose(model.jnt_stiffness[1:14:2], mujoco_stiffness(case, 7)["hinge"])


@pytest.mark.slow
def test_pyelastica_rod_meets_the_budget(case):
    pytest.importorskip("elastica")
    n = 24
    res = peers.solve_pyelastica(case, n, 4e-3 * case.free_length_m / n, 600.0)
    assert res.converged and abs(force_error(res.force_n, reference(case)["tip_force_n"])) <= peers.ERROR_BUDGET
