"""The section law: axial load in the wall of an inflated tube and the limits it sets.

Closed-tube statics.  Cut the everted tube at
material coordinate ``s``, where its radius is ``r(s)``; the distal free body (wall + gas +
tail) balances

    p pi r(s)^2 = T_wall(s) + T_tail(s) + C(s),

with ``T_tail(s)`` the tension of the inner tail crossing the cut and ``C(s)`` the axial part
of every external force distal to ``s`` (the wall's reaction on the tip, side contacts ahead
of ``s``), compression positive.  The pressure on the tip cap is internal to wall + gas and
does not offset ``C``.  Wrinkling and collapse follow the wall's tension, not ``p`` alone
(Comer & Levy 1963 and Stein & Hedgepeth 1961 for the moment of a pressurised membrane tube,
whose axial stress resultant is ``T_wall / (2 pi r)``; vine bodies buckle under axial load:
Coad et al., RA-L 2020):

    M_w = T_wall r / 2,    M_c = T_wall r.

With no axial load (``T_tail = C = 0``) these are the classical ``p pi r^3 / 2`` and
``p pi r^3``.  A section whose ``T_wall`` reaches zero carries no moment and no further
compression: it folds axially (telescopes), so the compression it can carry,

    N_max(s) = p pi r(s)^2 - T_tail(s),

caps the push any wall can exert on the tip through it, and a deflated tube carries
neither moment nor compression.  Everything here is vectorised over joints (SI: Pa, m, N,
N m) and holds no state.
"""

from __future__ import annotations

import math

import numpy as np


def compression_capacity(pressure_pa: float, radius_m: np.ndarray, tail_tension_n: np.ndarray | float) -> np.ndarray:
    """``N_max = p pi r^2 - T_tail`` (N, never below 0): the most compression a section carries
    before its wall goes slack and it folds axially."""
    return np.maximum(max(pressure_pa, 0.0) * math.pi * np.asarray(radius_m) ** 2 - tail_tension_n, 0.0)


def wall_tension(
    pressure_pa: float, radius_m: np.ndarray, tail_tension_n: np.ndarray | float, compression_n: np.ndarray | float
) -> np.ndarray:
    """``T_wall = p pi r^2 - T_tail - C`` (N); negative where the wall would have to push."""
    return max(pressure_pa, 0.0) * math.pi * np.asarray(radius_m) ** 2 - tail_tension_n - compression_n


def wrinkling_moment(wall_tension_n: np.ndarray, radius_m: np.ndarray) -> np.ndarray:
    """``M_w = T_wall r / 2`` (N m), 0 where the wall is slack."""
    return 0.5 * np.maximum(wall_tension_n, 0.0) * np.asarray(radius_m)


def collapse_moment(wall_tension_n: np.ndarray, radius_m: np.ndarray) -> np.ndarray:
    """``M_c = T_wall r = 2 M_w`` (N m), 0 where the wall is slack."""
    return 2.0 * wrinkling_moment(wall_tension_n, radius_m)


def tail_tension(base_tension_n: float, turning_rad: np.ndarray, bend_loss_per_rad: float) -> np.ndarray:
    """Tension (N) of the tail where it crosses each section: the spool's drag ``T_base``,
    amplified by capstan friction over the turning ``Theta(0..s)`` of the body between the
    base and the section, ``T_base exp(mu_b Theta)`` (Euler-Eytelwein; the tail is hauled
    towards the tip over the inside of every bend: Haggerty, Naclerio & Hawkes, IROS 2019)."""
    return base_tension_n * np.exp(bend_loss_per_rad * np.asarray(turning_rad))


def distal_compression(forces_n: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """``C_j = -t_j . sum_{k >= j} F_k`` (N): the compression that the external forces ``F_k``
    (K x 2, on bodies ``k``, base to tip) put along each body's unit axis ``t_j`` (K x 2) at
    the joint proximal to it."""
    distal = np.cumsum(np.asarray(forces_n)[::-1], axis=0)[::-1]
    return -np.einsum("ij,ij->i", distal, np.asarray(axes))
