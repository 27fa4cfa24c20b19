"""From the continuous rod to a chain of rigid segments and rotary joints.

Mapping EI(s) to joint stiffness
--------------------------------
Nodes sit at ``s_j = s_0 + j ds``; joint ``j`` joins the segments either side of node
``j`` (joint 0 is the clamp).  A joint's rotation stands for the curvature of the rod
around its node, weighted by the linear "hat" function ``h_j(s)`` of that node (1 at
``s_j``, 0 at the neighbouring nodes).  Its compliance is

    c_j = integral h_j(s) / EI(s) ds,      k_j = 1 / c_j.

For a bending moment that varies linearly between nodes (any point load) the chain's
tip rotation and deflection are then the rod's, up to the linear-interpolation error of
``(L - s)^2`` (O(ds^2)), wherever a band falls between nodes: the compliance of a band
is shared between its two nearest joints in proportion to its distance from each.  A
per-cell harmonic mean (``EI / ds`` with EI averaged over the cell) is only O(ds) when a
band straddles a cell edge.  At the clamp the hat is cut in half, so a uniform rod
gets ``k_0 = 2 EI / ds`` there (the clamp rule of DESIGN.md).  The hat of the last node
reaches past the tip only where the moment is zero.

Wrinkling and kinking per joint
-------------------------------
A joint is linear up to the wrinkling moment of the narrowest section in its cell
(``M_w = p pi r_min^3 / 2``) and follows the tension-field law beyond it, up to a kink
near ``M_c = 2 M_w`` (:mod:`evertgym.model.pressure`).  Its rotation at wrinkling onset
is ``phi_w = M_w c_j``; past it ``M = M_c f(phi / phi_w)`` with the universal law ``f``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from evertgym.model.pressure import KINK_MOMENT_FRACTION, wrinkled_moment_fraction
from evertgym.model.section import TubeSection

#: Quadrature points per segment for the hat integrals.
_QUAD_PER_SEGMENT = 64


@dataclass(frozen=True)
class JointLaw:
    """Per-joint constitutive data (arrays over joints, SI)."""

    stiffness: np.ndarray  # k_j, N m / rad
    shear_stiffness: np.ndarray  # k_s,j = 1 / int h_j / GA, N / m
    wrinkling_moment: np.ndarray  # M_w, N m
    radius: np.ndarray  # narrowest radius of the joint's cell, m

    def moment(self, angle: np.ndarray) -> np.ndarray:
        """Joint moment (N m) at relative rotation ``angle`` (rad): see :func:`joint_moment`."""
        return joint_moment(angle, self.stiffness, self.wrinkling_moment)

    def kinked(self, moment: np.ndarray) -> np.ndarray:
        """Joints whose moment passed the kink fraction of their collapse moment."""
        return np.abs(moment) >= KINK_MOMENT_FRACTION * 2.0 * self.wrinkling_moment


#: A wrinkled or unpressurised joint keeps this fraction of its linear stiffness (the
#: membrane's own bending stiffness; it also keeps a limp chain well posed).
RESIDUAL_STIFFNESS_FRACTION = 0.01


def joint_moment(angle: np.ndarray, stiffness: np.ndarray, wrinkling_moment: np.ndarray) -> np.ndarray:
    """Moment (N m) of joints at ``angle`` (rad): ``k phi`` up to the wrinkling moment, the
    tension-field law beyond it (towards ``M_c = 2 M_w``), never below the residual
    ``RESIDUAL_STIFFNESS_FRACTION k phi``."""
    lin = stiffness * angle
    ratio = np.full(np.shape(lin), np.inf)
    np.divide(np.abs(lin), wrinkling_moment, out=ratio, where=wrinkling_moment > 0)
    wrinkled = ratio > 1.0
    if not np.any(wrinkled):
        return lin
    finite = np.where(np.isfinite(ratio), np.maximum(ratio, 1.0), 1.0)
    m_wr = np.sign(angle) * 2.0 * wrinkling_moment * wrinkled_moment_fraction(finite)
    m_wr = np.where(np.abs(m_wr) > RESIDUAL_STIFFNESS_FRACTION * np.abs(lin), m_wr, RESIDUAL_STIFFNESS_FRACTION * lin)
    return np.where(wrinkled, m_wr, lin)


def hat_compliance(section: TubeSection, nodes: np.ndarray, s_end: float, shear: bool = False) -> np.ndarray:
    """``c_j = int h_j / EI ds`` for each node (``int h_j / GA ds`` with ``shear``);
    the last node's hat is cut at ``s_end``.

    Each half of a hat is integrated by the trapezoidal rule on :data:`_QUAD_PER_SEGMENT` intervals;
    every half is one row of a single array (one stiffness evaluation for all), and a node's two halves
    are added left to right, which gives the same bits as integrating them one at a time."""
    stiffness = section.shear_stiffness if shear else section.bending_stiffness
    n = len(nodes)
    if n == 0:
        return np.zeros(0)
    nodes = np.asarray(nodes, dtype=float)
    lo = np.empty(n)
    lo[0] = nodes[0]
    lo[1:] = nodes[:-1]
    hi = np.empty(n)
    hi[:-1] = nodes[1:]
    hi[-1] = min(s_end, nodes[-1] + (nodes[-1] - nodes[-2] if n > 1 else 0.0))
    a = np.concatenate([lo, nodes])  # rows 0..n-1: the left halves; n..2n-1: the right halves
    b = np.concatenate([nodes, hi])
    centre = np.concatenate([nodes, nodes])
    rows = b - a > 0
    a, b, centre = a[rows], b[rows], centre[rows]
    s = np.ascontiguousarray(np.linspace(a, b, _QUAD_PER_SEGMENT + 1, axis=-1))  # each row summed as a 1-D array is
    h = 1.0 - np.abs(s - centre[:, None]) / (b - a)[:, None]
    half = np.zeros(2 * n)
    half[rows] = np.trapezoid(h / stiffness(s), s, axis=-1)
    return half[:n] + half[n:]


def min_radius(section: TubeSection, lo: np.ndarray, hi: np.ndarray, samples: int) -> np.ndarray:
    """The narrowest radius (m) of each stretch ``[lo_i, hi_i]`` (m), sampled at ``samples``
    evenly spaced points (both ends included); one radius evaluation for all the stretches."""
    if len(lo) == 0:
        return np.zeros(0)
    s = np.linspace(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float), samples, axis=-1)
    return np.min(section.radius(s), axis=-1)


def joint_law(section: TubeSection, nodes: np.ndarray, s_end: float) -> JointLaw:
    """Stiffness and wrinkling data of the joints at ``nodes`` (body coordinates, m)."""
    comp = hat_compliance(section, nodes, s_end)
    n = len(nodes)
    half_lo = np.zeros(n)
    half_hi = np.zeros(n)
    if n:
        half_lo[1:] = (nodes[1:] - nodes[:-1]) / 2
        half_hi[:-1] = half_lo[1:]
        half_hi[-1] = max(0.0, min(s_end - nodes[-1], half_lo[-1]))
    r_min = min_radius(section, nodes - half_lo, nodes + half_hi, 33)
    mw = 0.5 * section.pressure_pa * math.pi * r_min**3
    return JointLaw(1.0 / comp, 1.0 / hat_compliance(section, nodes, s_end, shear=True), mw, r_min)


def segment_inertia(cfg, k_bend: float, k_shear: float, ds: float) -> tuple[float, float]:
    """Scaled (inertia, mass) of a segment next to joints of stiffness ``k_bend`` (N m/rad)
    and ``k_shear`` (N/m): the rotational mode of the stiffest joint turns by about
    ``1 / sqrt(inertia_factor)`` rad per step, the translational mass is ``mass_ratio`` of
    a uniform bar's but at least what keeps the shear spring's mode as slow."""
    inertia = cfg.inertia_factor * k_bend * cfg.dt_s**2
    mass = max(cfg.mass_ratio * 12.0 * inertia / ds**2, 0.5 * cfg.inertia_factor * k_shear * cfg.dt_s**2)
    return inertia, mass
