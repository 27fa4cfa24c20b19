"""Compliant wall pieces far from the robot sleep: static, out of the solver, until it comes near.

A compliant channel (the colon) has about a hundred spring-mounted wall pieces with several
collision shapes and constraints each; stepping them all costs 3.5x a rigid channel
(docs/benchmarks.md), although at any time only those near the robot's moving part are
loaded.  :class:`DormantWalls` keeps the others out of the solver, as the active set does
for the robot's resting segments:

* a piece **sleeps** (becomes a static body; its constraints to the ground or to sleeping
  neighbours leave the space) when it lies farther than ``margin_m`` from every active robot
  segment's surface and moves slower than ``rest_speed_m_per_s`` at its far end;
* a sleeping piece **wakes** (dynamic again, with its mass, moment and constraints) as soon
  as an active segment comes within ``margin_m`` of it.

Checks run every few steps (the simulator's freeze interval, 50 ms): the tip grows at most
5 mm in that time, far less than the default margin of 30 mm, and a wall indentation decays
over about 5 mm (``wall_influence_mm``).  A sleeping piece keeps the pose it had, so a
deformed piece left behind holds its deformation, and its awake neighbours still feel their
springs to it.  Pieces ahead of the tip start at rest and sleep from the first check.

What it changes, measured (``python scripts/dormant_walls.py``): the colon robot's stall
position under a constant pressure is itself sensitive to round-off, with or without dormant
walls: the paper's banded colon robot at 3 kPa for 12 s stalls at 429.6, 432.6, 430.5 and
410.2 mm when the command is perturbed by 0, 1e-9, 1e-6 and 1e-3 (relative), and at 408.4,
408.4, 430.0 and 408.4 mm with dormant walls; 12 s of it cost 0.5 s instead of 1.3 s (one core).  The
two sets of outcomes overlap but a given run is not reproduced, so dormant walls are opt-in
(``SimConfig(dormant_walls=True)``) until the colon's outcomes are shown not to depend on
such perturbations (docs/benchmarks.md).
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

#: A far piece sleeps when its far end moves slower than this (m/s); 5 mm/s (the robot's
#: freeze speed) also gave the same spread of colon outcomes, the lower value is the safer.
WALL_REST_SPEED_M_PER_S = 1e-5


class DormantWalls:
    """Sleep and wake the compliant wall pieces ``bodies`` of ``space``.

    ``margin_m``: gap (m) between a piece's shapes and an active robot segment's surface
    below which the piece is awake; ``rest_speed_m_per_s``: the speed (m/s, at the piece's
    far end) below which a far piece may sleep.
    """

    def __init__(self, space: pymunk.Space, bodies: list[pymunk.Body], margin_m: float, rest_speed_m_per_s: float) -> None:
        self.space = space
        self.bodies = bodies
        self.margin_m = margin_m
        self.rest_speed = rest_speed_m_per_s
        self._mass = [b.mass for b in bodies]
        self._moment = [b.moment for b in bodies]
        self._cog = [(b.center_of_gravity.x, b.center_of_gravity.y) for b in bodies]
        # reach: how far a piece's shapes extend from its body position (m)
        self._reach = np.array([max((max(abs(sh.a), abs(sh.b)) + sh.radius for sh in b.shapes), default=0.0) for b in bodies])
        index = {id(b): i for i, b in enumerate(bodies)}
        self._constraints: list[list[tuple[pymunk.Constraint, int | None]]] = []  # (constraint, other piece or None)
        for b in bodies:
            own = []
            for c in b.constraints:
                other = c.b if c.a is b else c.a
                own.append((c, index.get(id(other))))
            self._constraints.append(own)
        self._removed: set[pymunk.Constraint] = set()  # constraints taken out of the space
        self.asleep = np.zeros(len(bodies), dtype=bool)
        self.wakes = 0  # how many times a piece woke (for tests and benchmarks)

    def update(self, centres: np.ndarray, radius_m: float) -> None:
        """Sleep and wake pieces given the active robot segments' centres (K, 2) and the robot's
        largest collision radius plus half a segment (m)."""
        if not self.bodies:
            return
        pos = np.array([tuple(b.position) for b in self.bodies])
        if len(centres):
            d = np.sqrt(np.min(((pos[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2), axis=1))
        else:
            d = np.full(len(pos), math.inf)
        near = d - self._reach - radius_m < self.margin_m
        for i in np.nonzero(near & self.asleep)[0]:
            self._wake(int(i))
        for i in np.nonzero(~near & ~self.asleep)[0]:
            b = self.bodies[i]
            if b.velocity.length + abs(b.angular_velocity) * self._reach[i] < self.rest_speed:
                self._sleep(int(i))

    def _sleep(self, i: int) -> None:
        b = self.bodies[i]
        b.velocity = (0.0, 0.0)
        b.angular_velocity = 0.0
        b.body_type = pymunk.Body.STATIC
        self.asleep[i] = True
        for c, other in self._constraints[i]:  # a constraint between two static bodies does nothing
            if (other is None or self.asleep[other]) and c not in self._removed:
                self.space.remove(c)
                self._removed.add(c)

    def _wake(self, i: int) -> None:
        b = self.bodies[i]
        b.body_type = pymunk.Body.DYNAMIC
        b.mass = self._mass[i]
        b.moment = self._moment[i]
        b.center_of_gravity = self._cog[i]
        b.velocity = (0.0, 0.0)
        b.angular_velocity = 0.0
        self.asleep[i] = False
        self.wakes += 1
        for c, _ in self._constraints[i]:
            if c in self._removed:
                self.space.add(c)
                self._removed.discard(c)
