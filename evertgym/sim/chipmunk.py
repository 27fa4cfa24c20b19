"""Reads and writes of many Chipmunk objects at once, without a pymunk property per object.

pymunk's properties cost about 1 us each in Python (attribute lookup, the property, the
cffi call); the simulator reads every active segment's angle and writes every joint's
stiffness several times per control step.  These helpers call the same Chipmunk functions
the properties call (``cpBodyGetAngle``, ``cpDampedRotarySpringSetStiffness``, ...) through
pymunk's cffi library directly, so the values are bit-for-bit those of the properties.
They rely on pymunk's ``_body`` / ``_constraint`` handles (pymunk 6.6 to 7.x); where those are
missing they fall back to the properties.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import pymunk

try:
    from pymunk._chipmunk_cffi import lib as _lib

    _FAST = hasattr(pymunk.Body(1, 1), "_body") and hasattr(pymunk.DampedRotarySpring(pymunk.Body(1, 1), pymunk.Body(1, 1), 0, 1, 0),
                                                              "_constraint")
except ImportError:  # pragma: no cover - another pymunk layout
    _FAST = False


def body_angles(bodies: Sequence[pymunk.Body]) -> np.ndarray:
    """``[b.angle for b in bodies]`` (rad) as an array."""
    if _FAST:
        get = _lib.cpBodyGetAngle
        return np.fromiter((get(b._body) for b in bodies), float, len(bodies))
    return np.fromiter((b.angle for b in bodies), float, len(bodies))


def set_rotary_stiffness(springs: Iterable[pymunk.DampedRotarySpring], values: Iterable[float]) -> None:
    """``spring.stiffness = value`` (N m / rad) pairwise."""
    if _FAST:
        put = _lib.cpDampedRotarySpringSetStiffness
        for spring, value in zip(springs, values):
            put(spring._constraint, value)
    else:
        for spring, value in zip(springs, values):
            spring.stiffness = value


def set_spring_stiffness(springs: Iterable[pymunk.DampedSpring], values: Iterable[float]) -> None:
    """``spring.stiffness = value`` (N / m) pairwise."""
    if _FAST:
        put = _lib.cpDampedSpringSetStiffness
        for spring, value in zip(springs, values):
            put(spring._constraint, value)
    else:
        for spring, value in zip(springs, values):
            spring.stiffness = value


def arbiter_impulses(body: pymunk.Body) -> list[tuple[float, float, float, float]]:
    """``(J_x, J_y, n_x, n_y)`` of each arbiter (contact pair) of ``body`` in Chipmunk's order:
    the pair's total impulse on the other shape (N s) and its normal (from ``body``'s shape
    towards the other), as ``Arbiter.total_impulse`` and ``Arbiter.normal`` give them."""
    rows: list[tuple[float, float, float, float]] = []
    if _FAST:
        imp_of, normal_of = _lib.cpArbiterTotalImpulse, _lib.cpArbiterGetNormal

        def fast(arb: pymunk.Arbiter) -> None:
            ptr = arb._arbiter
            j, n = imp_of(ptr), normal_of(ptr)
            rows.append((j.x, j.y, n.x, n.y))

        body.each_arbiter(fast)
    else:

        def slow(arb: pymunk.Arbiter) -> None:
            j, n = arb.total_impulse, arb.normal
            rows.append((j.x, j.y, n.x, n.y))

        body.each_arbiter(slow)
    return rows
