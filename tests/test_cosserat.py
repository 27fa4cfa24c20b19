"""The rod solver against closed-form beam theory (Euler-Bernoulli, Timoshenko, elastica)."""

import math

import numpy as np
import pytest
from scipy.special import ellipeinc, ellipkinc

from evertgym.design import TubeDesign
from evertgym.model.cosserat import CosseratRod
from evertgym.model.section import TubeSection
from evertgym.model.stiffness import paper_prototype, tensile_rod

L = 0.2
P = 6900.0


def uniform_rod(**kw) -> CosseratRod:
    d = TubeDesign()
    return CosseratRod(TubeSection(d, P), d.length_m - L, d.length_m, **kw)


def elastica_tip(load_param: float) -> tuple[float, float, float]:
    """Closed-form end-loaded cantilever elastica (Bisshopp & Drucker 1945).

    ``load_param = F L^2 / EI`` for a transverse tip force of fixed direction.  Returns
    (x/L, y/L, tip angle).  The tip angle theta_L solves
    ``sqrt(load_param) = K(k) - F(phi1, k)``, ``k^2 = (1 + sin theta_L) / 2``,
    ``sin phi1 = 1 / (sqrt(2) k)``.
    """
    from scipy.optimize import brentq

    def parts(th):
        k = math.sqrt((1 + math.sin(th)) / 2)
        phi1 = math.asin(min(1.0, 1 / (math.sqrt(2) * k)))
        m = k * k
        return k, phi1, m

    def resid(th):
        _, phi1, m = parts(th)
        return ellipkinc(math.pi / 2, m) - ellipkinc(phi1, m) - math.sqrt(load_param)

    th = brentq(resid, 1e-9, math.pi / 2 - 1e-9, xtol=1e-15)
    k, phi1, m = parts(th)
    a = math.sqrt(load_param)
    y = 1 - 2 * (ellipeinc(math.pi / 2, m) - ellipeinc(phi1, m)) / a
    x = math.sqrt(2 * math.sin(th)) / a
    return x, y, th


def test_small_deflection_matches_euler_bernoulli():
    rod = uniform_rod(shear=False, extension=False, wrinkling=False)
    ei = rod.section.bare_bending_stiffness
    f = 1e-4
    sol = rod.solve_force(0.0, f)
    assert sol.tip_y == pytest.approx(f * L**3 / (3 * ei), rel=1e-3)
    assert sol.tip_angle == pytest.approx(f * L**2 / (2 * ei), rel=1e-3)


def test_small_deflection_with_shear_matches_timoshenko():
    rod = uniform_rod(wrinkling=False)
    sec = rod.section
    ei = sec.bare_bending_stiffness
    ga = float(sec.shear_stiffness(0.5))
    f = 1e-4
    sol = rod.solve_force(0.0, f)
    assert sol.tip_y == pytest.approx(f * L**3 / (3 * ei) + f * L / ga, rel=1e-3)


@pytest.mark.parametrize("load_param", [0.5, 1.0, 3.0, 10.0])
def test_large_deflection_matches_elastica(load_param):
    rod = uniform_rod(shear=False, extension=False, wrinkling=False)
    ei = rod.section.bare_bending_stiffness
    sol = rod.solve_force(0.0, load_param * ei / L**2)
    x, y, th = elastica_tip(load_param)
    assert sol.tip_y / L == pytest.approx(y, rel=1e-3)
    assert sol.tip_x / L == pytest.approx(x, rel=1e-3)
    assert sol.tip_angle == pytest.approx(th, rel=1e-3)


def test_elastica_reference_is_the_published_one():
    # Bisshopp & Drucker (1945), table: F L^2/EI = 1 gives y/L = 0.30172, 1 - x/L = 0.05643.
    x, y, _ = elastica_tip(1.0)
    assert y == pytest.approx(0.30172, abs=2e-5)
    assert 1 - x == pytest.approx(0.05643, abs=2e-5)


def test_displacement_control_inverts_force_control():
    rod = uniform_rod()
    sol = rod.solve_lateral_displacement(0.03)
    again = rod.solve_force(0.0, sol.force[1])
    assert again.tip_y == pytest.approx(0.03, rel=1e-7)


def test_converges_at_60mm_tip_displacement_for_every_paper_design():
    for bands, red in [((), 0.0), ((50, 100, 150, 200), 0.5), ((100,), 0.1), ((30,), 0.5)]:
        rod = tensile_rod(paper_prototype(bands, red))
        sol = rod.solve_lateral_displacement(0.06)
        assert sol.tip_y == pytest.approx(0.06, rel=1e-7)
        # the internal moment at the tip vanishes and the force is positive
        assert abs(sol.moment[-1]) < 1e-9
        assert sol.force[1] > 0
        # refinement: a tighter tolerance changes the force by < 0.1%
        fine = tensile_rod(paper_prototype(bands, red), rtol=1e-12).solve_lateral_displacement(0.06)
        assert sol.force[1] == pytest.approx(fine.force[1], rel=1e-3)


def test_bare_tube_wrinkles_at_its_base_at_60mm():
    sol = tensile_rod(paper_prototype((), 0.0)).solve_lateral_displacement(0.06)
    sec = tensile_rod(paper_prototype((), 0.0)).section
    assert sol.wrinkled
    assert abs(sol.moment[0]) > float(sec.wrinkling_moment(0.5))
    assert not sol.kinked


def test_stronger_band_at_100mm_lowers_k():
    k = {}
    for red in (0.1, 0.5):
        k[red] = tensile_rod(paper_prototype((100,), red)).solve_lateral_displacement(0.02).force[1] / 0.02
    k0 = tensile_rod(paper_prototype((), 0)).solve_lateral_displacement(0.02).force[1] / 0.02
    assert k[0.5] < k[0.1] < k0


def test_more_bands_and_farther_bands_lower_k():
    ks = [tensile_rod(paper_prototype(b, 0.5)).solve_lateral_displacement(0.02).force[1] for b in [(), (50,), (50, 100), (50, 100, 150)]]
    assert all(a > b for a, b in zip(ks, ks[1:]))
    kp = [tensile_rod(paper_prototype((d,), 0.5)).solve_lateral_displacement(0.02).force[1] for d in (30, 60, 100)]
    assert kp[0] > kp[1] > kp[2]


def test_point_force_before_the_tip_leaves_the_rest_straight():
    rod = uniform_rod()
    sol = rod.solve_force(0.0, 0.05, s_c=rod.s_base + 0.1)
    beyond = sol.s > rod.s_base + 0.1 + 1e-9
    assert np.allclose(sol.theta[beyond], sol.theta[beyond][0])
    assert np.allclose(sol.moment[beyond], 0.0)
