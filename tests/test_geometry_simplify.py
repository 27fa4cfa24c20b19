"""scenes.geometry.simplify (Ramer-Douglas-Peucker, compiled): the vertices numpy's vectorised form keeps, to the
bit, on random polylines with ties, repeated points and degenerate chords."""

from __future__ import annotations

import numpy as np

from evertgym.scenes.geometry import simplify


def _numpy_simplify(poly: np.ndarray, tol: float) -> np.ndarray:
    """The vectorised form ``simplify`` had before it was compiled (the reference)."""
    keep = np.zeros(len(poly), bool)
    keep[[0, -1]] = True
    stack = [(0, len(poly) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg = poly[b] - poly[a]
        rel = poly[a + 1:b] - poly[a]
        norm = np.hypot(*seg)
        dist = np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / norm if norm > 0 else np.hypot(rel[:, 0], rel[:, 1])
        i = int(np.argmax(dist))
        if dist[i] > tol:
            m = a + 1 + i
            keep[m] = True
            stack += [(a, m), (m, b)]
    return np.flatnonzero(keep)


def test_simplify_keeps_the_vertices_of_the_vectorised_form():
    rng = np.random.default_rng(3)
    for trial in range(600):
        n = int(rng.integers(1, 300))
        poly = np.cumsum(rng.normal(scale=1e-3, size=(n, 2)), axis=0)
        if trial % 5 == 0:
            poly = np.round(poly, 4)  # equal distances: the first of equals is kept
        if trial % 7 == 0 and n > 3:
            poly[-1] = poly[0]  # a closed chord (zero length): distances to the end point
        tol = 10 ** rng.uniform(-6, -2)
        assert np.array_equal(simplify(poly, tol), _numpy_simplify(poly, tol))


def test_a_straight_line_keeps_its_ends_and_a_corner_its_apex():
    line = np.column_stack([np.linspace(0, 1, 50), np.zeros(50)])
    assert simplify(line, 1e-9).tolist() == [0, 49]
    corner = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0, 0.5], [1.0, 1.0]])
    assert simplify(corner, 1e-6).tolist() == [0, 2, 4]
