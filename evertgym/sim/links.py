"""The joint between two segments: bending and shear springs on a short groove.

A joint is a ``GrooveJoint`` across the end of the proximal segment (the distal segment's
origin may slide along the proximal segment's normal, within +/- a quarter segment), a
linear ``DampedSpring`` that resists that sliding with the lumped shear stiffness
``k_s = 1 / int h_j / GA ds``, and a ``DampedRotarySpring`` with the lumped bending
stiffness.  Together they reproduce the rod's bending and shear compliance (the paper's
Kse includes shear; for the 200 mm test cantilever it is 4.5% of the tip deflection).
Extension is not modelled (0.03% of the tip deflection in the tensile test).

Spring stiffnesses are divided by ``beta = damping ** dt``: Chipmunk applies spring
impulses before it damps velocities, so an uncompensated spring would carry only
``beta`` of its force at equilibrium.
"""

from __future__ import annotations

from dataclasses import dataclass

import pymunk


@dataclass
class Link:
    groove: pymunk.GrooveJoint
    shear: pymunk.DampedSpring
    bend: pymunk.DampedRotarySpring

    @property
    def constraints(self) -> tuple:
        return (self.groove, self.shear, self.bend)


def make_link(
    prev: pymunk.Body,
    body: pymunk.Body,
    anchor_prev: tuple[float, float],
    normal_prev: tuple[float, float],
    half_travel: float,
    k_bend: float,
    k_shear: float,
    beta: float,
    rest_angle: float = 0.0,
) -> Link:
    """A joint whose distal origin (``body`` local (0, 0)) sits at ``anchor_prev`` on ``prev``.

    ``normal_prev`` is the shear direction in ``prev``'s local frame (world frame when
    ``prev`` is the static body).
    """
    ax, ay = anchor_prev
    nx, ny = normal_prev
    groove = pymunk.GrooveJoint(
        prev, body, (ax - nx * half_travel, ay - ny * half_travel), (ax + nx * half_travel, ay + ny * half_travel), (0.0, 0.0)
    )
    groove.collide_bodies = False
    shear = pymunk.DampedSpring(prev, body, anchor_prev, (0.0, 0.0), 0.0, k_shear / beta, 0.0)
    shear.collide_bodies = False
    bend = pymunk.DampedRotarySpring(prev, body, rest_angle, k_bend / beta, 0.0)
    bend.collide_bodies = False
    return Link(groove, shear, bend)
