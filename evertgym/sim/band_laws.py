"""Switchable laws of the band-mechanism study (issue 26; ``shared/notes/bend-physics.md``, sections 2, 8, 10).

Each is a term of the quasi-static engine's growth law, off by default (``SimConfig``); the study
(``scripts/band_mechanisms.py``, :mod:`evertgym.experiments.mechanisms`) switches them on one at a
time and refits what the no-band U-bend rows may calibrate.  SI throughout.

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
