"""The kernel's entry points for Python code: the compiled calls, with their results made bundles in
Python.

numba boxes a ``NamedTuple`` result by calling its class, which runs Python code: a Ctrl-C that
arrived during a compiled solve is raised there, inside numba's boxing, and crashes the process.
So the compiled calls that Python makes per solve return plain tuples (boxed without running Python
code; the Ctrl-C is then raised cleanly after the call), and these functions build the bundles."""

from __future__ import annotations

import numba as nb
import numpy as np

from evertgym.sim.kernel import newton, window
from evertgym.sim.kernel.bundles import (
    Body,
    Chain,
    Entries,
    Joints,
    Pieces,
    Problem,
    ScenePieces,
    SceneWalls,
    SolveResult,
    SolveSettings,
    Walls,
    Window,
    WindowQuery,
)

EntriesTuple = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@nb.njit(cache=True, nogil=True)
def _entries_tuple(e: Entries) -> EntriesTuple:
    return (e.s, e.w, e.wl, e.t, e.ml)


@nb.njit(cache=True, nogil=True)
def _window_setup(body: Body, scene: SceneWalls, pieces: ScenePieces, entries: Entries, query: WindowQuery) -> tuple:
    w = window.window_setup(body, scene, pieces, entries, query)
    c, j, ws, p = w.chain, w.joints, w.walls, w.piece_data
    return (w.overlap, (c.theta0, c.n0, c.seg_len, c.seg_rad), w.phi, w.s_nodes, (j.k, j.mw), w.sel,
            (ws.a, ws.b, ws.piece, ws.vertex, ws.radius), w.wall_mu, w.pieces, (p.pc0, p.kaa, p.travel, p.k_travel), w.u, w.robot_mu,
            w.in_window, _entries_tuple(w.entries))


def window_setup(body: Body, scene: SceneWalls, pieces: ScenePieces, entries: Entries, query: WindowQuery) -> Window:
    """:func:`evertgym.sim.kernel.window.window_setup`, called from Python."""
    (overlap, chain, phi, s_nodes, joints, sel, walls, wall_mu, unknowns, piece_data, u, robot_mu, in_window,
     win_entries) = _window_setup(body, scene, pieces, entries, query)
    return Window(overlap, Chain(*chain), phi, s_nodes, Joints(*joints), sel, Walls(*walls), wall_mu, unknowns, Pieces(*piece_data), u,
                  robot_mu, in_window, Entries(*win_entries))


@nb.njit(cache=True, nogil=True)
def _solve_increment(problem: Problem, phi: np.ndarray, phi_ref: np.ndarray, u: np.ndarray, u_ref: np.ndarray, s_nodes: np.ndarray,
                     robot_mu: np.ndarray, wall_mu: np.ndarray, entries: Entries, settings: SolveSettings) -> tuple:
    r = newton.solve_increment(problem, phi, phi_ref, u, u_ref, s_nodes, robot_mu, wall_mu, entries, settings)
    return (r.status, r.iterations, r.residual_m, r.residual_f, _entries_tuple(r.entries), r.seg_force, r.seg_moment, r.tip, r.rows,
            r.lag_converged, r.refreshes)


def solve_increment(problem: Problem, phi: np.ndarray, phi_ref: np.ndarray, u: np.ndarray, u_ref: np.ndarray, s_nodes: np.ndarray,
                    robot_mu: np.ndarray, wall_mu: np.ndarray, entries: Entries, settings: SolveSettings) -> SolveResult:
    """:func:`evertgym.sim.kernel.newton.solve_increment`, called from Python (``phi`` and ``u`` updated
    in place)."""
    status, iterations, res_m, res_f, new, seg_force, seg_moment, tip, rows, lag_converged, refreshes = _solve_increment(
        problem, phi, phi_ref, u, u_ref, s_nodes, robot_mu, wall_mu, entries, settings)
    return SolveResult(status, iterations, res_m, res_f, Entries(*new), seg_force, seg_moment, tip, rows, lag_converged, refreshes)


@nb.njit(cache=True, nogil=True)
def _merge_friction(scene_entries: Entries, in_window: np.ndarray, sel: np.ndarray, solved: Entries) -> EntriesTuple:
    return _entries_tuple(window.merge_friction(scene_entries, in_window, sel, solved))


def merge_friction(scene_entries: Entries, in_window: np.ndarray, sel: np.ndarray, solved: Entries) -> Entries:
    """:func:`evertgym.sim.kernel.window.merge_friction`, called from Python."""
    return Entries(*_merge_friction(scene_entries, in_window, sel, solved))
