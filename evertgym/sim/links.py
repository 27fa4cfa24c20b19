"""The joint between two segments: an axial constraint, a shear spring and a bending spring.

A joint joins the distal segment's origin (``body`` local (0, 0)) to an anchor on the
proximal segment.  By default (the rigid-column model) a ``GrooveJoint`` across the end of
the proximal segment holds it axially (the distal origin may slide along the proximal
segment's normal, within +/- a quarter segment) and a linear ``DampedSpring`` between the
two points resists that sliding.  With an ``axial_capacity`` (the section law,
``SimConfig(section_law=True)``) it instead holds the chain together with two one-sided slide joints
measured from a point ``lever`` behind the anchor on the proximal axis, so that they act
along that axis only (a sideways shear offset ``d`` changes their length by ``d^2 / 2 lever``):

* ``hold`` keeps the joint from opening (the wall is inextensible: any tension) and from
  closing by more than ``fold_travel``;
* ``push`` keeps it from closing with at most ``max_force``, the section's compression
  capacity ``N_max = p pi r^2 - T_tail`` (:mod:`evertgym.model.section_law`): beyond it the
  wall goes slack and the section folds axially (telescopes), up to ``fold_travel``, and
  pushes back out at ``N_max`` once the load falls.

Sideways, a linear ``DampedSpring`` along the proximal segment's normal (again on a long
lever, so it carries no axial load) resists the shear offset with the lumped shear
stiffness ``k_s = 1 / int h_j / GA ds``; a ``DampedRotarySpring`` carries the lumped bending
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

#: Lever (in segment lengths) of the axial struts and the shear spring.
LEVER_SEGMENTS = 20.0


@dataclass
class Link:
    axial: tuple[pymunk.Constraint, ...]
    shear: pymunk.DampedSpring
    bend: pymunk.DampedRotarySpring
    push: pymunk.SlideJoint | None = None  # the foldable compression strut (section law only)

    @property
    def constraints(self) -> tuple:
        return (*self.axial, self.shear, self.bend)


def make_link(
    prev: pymunk.Body,
    body: pymunk.Body,
    anchor_prev: tuple[float, float],
    normal_prev: tuple[float, float],
    segment_length: float,
    k_bend: float,
    k_shear: float,
    beta: float,
    rest_angle: float = 0.0,
    axial_capacity: float | None = None,
) -> Link:
    """A joint whose distal origin (``body`` local (0, 0)) sits at ``anchor_prev`` on ``prev``.

    ``normal_prev`` is the unit shear direction in ``prev``'s local frame (world frame when
    ``prev`` is the static body); the axis is the normal turned by -90 degrees.
    ``axial_capacity`` (N), if given, is the compression the joint carries before it folds
    (by up to half a segment); ``None`` makes the chain axially rigid (a groove joint).
    """
    ax, ay = anchor_prev
    nx, ny = normal_prev
    bend = pymunk.DampedRotarySpring(prev, body, rest_angle, k_bend / beta, 0.0)
    if axial_capacity is None:
        half = segment_length / 4
        groove = pymunk.GrooveJoint(prev, body, (ax - nx * half, ay - ny * half), (ax + nx * half, ay + ny * half), (0.0, 0.0))
        shear_spring = pymunk.DampedSpring(prev, body, anchor_prev, (0.0, 0.0), 0.0, k_shear / beta, 0.0)
        for c in (groove, shear_spring, bend):
            c.collide_bodies = False
        return Link((groove,), shear_spring, bend)
    tx, ty = ny, -nx  # the proximal axis
    lever = LEVER_SEGMENTS * segment_length
    back = (ax - tx * lever, ay - ty * lever)
    hold = pymunk.SlideJoint(prev, body, back, (0.0, 0.0), lever - 0.5 * segment_length, lever)
    push = pymunk.SlideJoint(prev, body, back, (0.0, 0.0), lever, 1e3 * lever)
    push.max_force = axial_capacity
    side = (ax - nx * lever, ay - ny * lever)
    shear = pymunk.DampedSpring(prev, body, side, (0.0, 0.0), lever, k_shear / beta, 0.0)
    for strut in (hold, push):
        strut.collide_bodies = False
    shear.collide_bodies = bend.collide_bodies = False
    return Link((hold, push), shear, bend, push)
