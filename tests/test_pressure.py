"""Inflated-beam pressure law: Le van-Wielgosz stiffening, Comer-Levy wrinkling and collapse."""

import math

import numpy as np
import pytest

from evertgym.design import TubeDesign
from evertgym.model.pressure import (
    InflatedBeamLaw,
    collapse_moment,
    wrinkled_curvature_ratio,
    wrinkled_curvature_ratio_scalar,
    wrinkled_moment_fraction,
    wrinkling_moment,
)


def test_law_is_anchored_on_the_paper_modulus():
    law = InflatedBeamLaw.for_design(TubeDesign())
    assert law.effective_modulus(6900.0) == pytest.approx(25.2e6, rel=1e-12)
    # pressure term p r / (2 t) = 1.38 MPa at 6.9 kPa for r = 20 mm, t = 0.05 mm
    assert law.effective_modulus(6900.0) - law.effective_modulus(0.0) == pytest.approx(1.38e6, rel=1e-9)


def test_wrinkling_and_collapse_moments():
    p, r = 3000.0, 0.02
    assert wrinkling_moment(p, r) == pytest.approx(p * math.pi * r**3 / 2)
    assert collapse_moment(p, r) == pytest.approx(2 * wrinkling_moment(p, r))
    # a band of 30% reduction wrinkles at (0.7)^3 = 34% of the bare tube's moment
    assert wrinkling_moment(p, 0.7 * r) / wrinkling_moment(p, r) == pytest.approx(0.343)


def test_tension_field_law_limits():
    # continuous with the linear branch at wrinkling onset; unbounded towards collapse
    assert wrinkled_curvature_ratio(0.5) == pytest.approx(1.0, abs=1e-6)
    assert wrinkled_curvature_ratio(0.95) > 25  # the kink: radius of curvature ~ tube radius
    # past the kink the section is a hinge: 10x more curvature for < 3% more moment
    k = float(wrinkled_curvature_ratio(0.95))
    assert wrinkled_moment_fraction(10 * k) < 0.95 * 1.05
    m = np.linspace(0.5, 0.99, 50)
    k = wrinkled_curvature_ratio(m)
    assert np.all(np.diff(k) > 0)
    assert np.allclose(wrinkled_moment_fraction(k), m, atol=1e-6)
    for mf in (0.55, 0.7, 0.9, 0.94, 0.97):
        assert wrinkled_curvature_ratio_scalar(mf) == pytest.approx(wrinkled_curvature_ratio(mf), rel=1e-5)


def test_tension_field_law_against_a_direct_section_integration():
    """Integrate the membrane stress of a taut/slack section numerically and compare."""
    E, t, r, p = 25e6, 5e-5, 0.02, 5000.0
    law_kw = wrinkling_moment(p, r) / (E * math.pi * r**3 * t)
    phi = np.linspace(-math.pi, math.pi, 200001)
    for kappa_ratio in (1.5, 3.0, 10.0):
        kappa = kappa_ratio * law_kw
        # find the neutral offset eps0 such that the axial force equals p pi r^2
        from scipy.optimize import brentq

        def axial(eps0, kappa=kappa):
            strain = eps0 + kappa * r * np.cos(phi)
            return np.trapezoid(E * t * np.maximum(strain, 0) * r, phi) - p * math.pi * r**2

        eps0 = brentq(axial, -kappa * r, kappa * r + 1.0)
        strain = eps0 + kappa * r * np.cos(phi)
        moment = np.trapezoid(E * t * np.maximum(strain, 0) * r * r * np.cos(phi), phi)
        assert moment / collapse_moment(p, r) == pytest.approx(float(wrinkled_moment_fraction(kappa_ratio)), rel=1e-4)


def test_law_rejects_bad_parameters():
    with pytest.raises(ValueError, match="membrane_modulus_pa"):
        InflatedBeamLaw(-1.0)
    with pytest.raises(ValueError, match=r"pressure_stiffening = 11 is out of range: allowed \[0, 10\]"):
        InflatedBeamLaw(1e6, 11)
