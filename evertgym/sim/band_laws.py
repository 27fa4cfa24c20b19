"""Switchable band-mechanism laws of the quasi-static engine (docs/bands.md; the bend-physics note, sections 2, 8, 10, 11).

Each is a term of the engine's growth law or joint law, a ``SimConfig`` field whose default is the
adopted bend model's (``evertgym/data/bend_model.json``); ``evertgym bands fit``
(:mod:`evertgym.experiments.bend_model`) fits each candidate combination on the paper's
calibration cells and ranks them by likelihood.  SI throughout.

* **The band's axial fold** (``band_fold``; note, sections 2 and 8, candidate 2).  An everted band
  carries the tip's push on to the base only while its wall stays in tension: the gas pulls its
  section with ``p pi r_b^2``; the tail's tension ``T_tail`` and the wall's reaction on the tip
  ``F_tip`` load it, so it goes slack and telescopes (folds axially) once
  ``F_tip + T_tail >= p pi r_b^2`` (Comer & Levy 1963, wrinkling with axial load; axial buckling of
  vine bodies: Coad et al., RA-L 2020).  Growth against a wall reaction ``F_tip`` then needs
  ``p >= (F_tip + T_tail) / (pi r_b^2)`` at every everted band.  ``T_tail`` at the band is the bare
  eversion threshold's force ``p_y(0) pi r^2`` (an upper bound: the tail's drag at the base with the
  fold's own force) times the capstan loss of the turning between the base and the band.
* **The tail pinched in a fold** (``fold_pinch_per_rad``; note, section 10, candidate 5).  Where the
  body's curvature exceeds ``1 / r`` its inner side has folded over (the inner-side strain ``r
  kappa`` passes 1) and the lumen the tail runs through is pinched.  The excess fold angle
  ``Phi = sum_j max(0, |phi_j| - ds / r_j)`` (rad; ``ds / r_j`` is the turn a segment of length
  ``ds`` and radius ``r_j`` makes without folding) multiplies the tail's losses by
  ``exp(mu_p Phi)``, a capstan law for the pinch.  ``Phi`` is a curvature integral: it converges
  as ``ds`` shrinks (a hinge of angle ``phi`` gives ``Phi -> phi``).  A band's smaller radius
  lets it turn further before folding (``ds / r_b``), and a turn shared among several joints folds
  less than one sharp fold.
* **Cross-section flattening** (``flattening``; note, section 5a, candidate 4; Brazier 1927).  A bent
  pressurised tube ovalises past wrinkling; its section flattens towards the bend's plane.  Per joint,
  ``f = f_max min(1, (x - 1) / 2)`` for ``x = kappa / kappa_w > 1`` (``kappa_w``: the curvature at the
  wrinkling moment ``p pi r^3 / 2``), with ``f_max`` the bare value plus the local band reduction (a
  band's slack fabric flattens further).  The segments either side of the joint collide with the
  radius ``r (1 - f)`` and the joint's wrinkling and collapse moments scale with ``1 - f``.  The
  engine lags it by one growth increment (the state of the last equilibrium sets the next).
* **The section's axial load** (``axial_load``; the bend model's candidate (c); note, section 2 and
  section 11's axial balance).  At a cut the gas pulls with ``p pi r(s)^2``; the wall carries that
  less the compressive loads, the tip's push against the wall ``F_tip`` and the tail's tension
  ``T_tail``: ``N_wall = p pi r^2 - F_tip - T_tail``.  The wall's wrinkling and collapse moments
  (about ``N_wall r / 2``) scale with ``N_wall / (p pi r^2)``, lowest at bands (``r_b^2``).  Lagged by
  one increment, as flattening is.
* **The band hinge** (``band_hinge_relief``, ``band_hinge_reach_m``; candidate (e), phenomenological).
  A band that has wrinkled sets the hinge the turn folds into; the chain carries the body's shape at
  the band, not the way the hinge steers the tip along the outer wall.  The law stands for that:
  while a wrinkled band (a joint of its strip at or past its wrinkling moment) lies within the reach
  behind the tip, the tip's friction coefficient is lowered by the relief fraction.  Both parameters
  are fitted on the 10% U-bend cells at 30 and 25 mm alone (measurements.json's rule).
* **The eversion bottleneck** (candidate 3) is the calibrated threshold of the material at the
  tip (Exp 4, :class:`evertgym.model.eversion.EversionThreshold`), always part of the growth law;
  ``band_eversion_threshold = False`` removes it (a counterfactual of the study, never a default).
"""

from __future__ import annotations

import math

import numpy as np


def fold_excess(phi: np.ndarray, seg_len: np.ndarray, r_cell: np.ndarray) -> float:
    """``Phi = sum_j max(0, |phi_j| - l_j / r_j)`` (rad): the body's turning beyond what its
    segments make without folding their inner side; ``phi`` (rad) the joint rotations, ``seg_len``
    (m) and ``r_cell`` (m) the length and radius of the segment each joint starts."""
    return float(np.sum(np.maximum(0.0, np.abs(phi) - seg_len / r_cell)))


def band_fold_pressure(tip_force_n: float, tail_n: float, band_radius_m: float) -> float:
    """Pressure (Pa) below which a band's wall goes slack under the tip's push ``tip_force_n`` and
    the tail's tension ``tail_n`` (N): ``(F_tip + T_tail) / (pi r_b^2)``."""
    return (max(tip_force_n, 0.0) + max(tail_n, 0.0)) / (math.pi * band_radius_m * band_radius_m)


def flattening(phi: np.ndarray, k: np.ndarray, mw: np.ndarray, r_cell: np.ndarray, radius_m: float,
               f_max: float) -> np.ndarray:
    """Per joint the flattening ``f`` (fraction of the radius) of the law above: ``phi`` (rad), the
    joint stiffness ``k`` (N m/rad) and unflattened wrinkling moment ``mw`` (N m), the local radius
    ``r_cell`` (m) against the tube's ``radius_m``; ``f_max`` the bare tube's largest flattening."""
    phi_w = np.where(k > 0, mw / np.maximum(k, 1e-300), np.inf)
    x = np.abs(phi) / np.maximum(phi_w, 1e-300)
    cap = f_max + np.clip(1.0 - r_cell / radius_m, 0.0, 1.0)
    return np.where(x > 1.0, cap * np.minimum(1.0, 0.5 * (x - 1.0)), 0.0)


def axial_share(load_n: float, pressure_pa: float, r_cell: np.ndarray) -> np.ndarray:
    """``max(0.05, 1 - N / (p pi r^2))`` per node: the share of the wall's pressure tension left after
    the axial load ``load_n`` (N) at pressure ``pressure_pa`` (Pa) and radius ``r_cell`` (m); ones at
    zero pressure (no load is carried)."""
    if pressure_pa <= 0.0:
        return np.ones_like(r_cell)
    return np.maximum(0.05, 1.0 - load_n / (pressure_pa * math.pi * r_cell * r_cell))


def hinged_band_near_tip(moments: np.ndarray, mw: np.ndarray, band_joints: list[np.ndarray], centres_m: np.ndarray,
                         length_m: float, reach_m: float) -> bool:
    """Whether an everted band within ``reach_m`` behind the tip (band centre at ``centres_m``, tip at
    ``length_m``) has wrinkled: a joint of its strip (``band_joints``, indices into ``moments``) carries
    at least its wrinkling moment ``mw`` (N m)."""
    n = len(moments)
    for joints, c in zip(band_joints, centres_m):
        if c > length_m or length_m - c > reach_m:
            continue
        for j in joints.tolist():  # (a band's strip is a few joints: a loop, not numpy's per-call overhead)
            if j < n and abs(moments[j]) >= mw[j] * (1.0 - 1e-9):
                return True
    return False
