"""Gathering a solve's window from the scene: the joints ``a..`` of the chain, the wall features
within reach, the compliant pieces that are unknowns, and the lagged friction entries in the
window; and the entries merged back after the solve."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Body, Chain, Entries, Joints, Pieces, ScenePieces, SceneWalls, Walls, Window, WindowQuery
from evertgym.sim.kernel.contacts import overlaps, select_features, touching
from evertgym.sim.kernel.friction import empty_entries

#: Rounding allowance (in segments) when a material coordinate is placed on its segment.
SEGMENT_ROUNDING = 1e-9


@nb.njit(cache=True, nogil=True)
def gather_walls(sel: np.ndarray, scene: SceneWalls) -> tuple[Walls, np.ndarray]:
    """The wall features ``sel`` (indices, ascending) of the scene's arrays, in one pass, and their
    friction coefficients."""
    w = scene.walls
    k = sel.shape[0]
    a = np.empty((k, 2))
    b = np.empty((k, 2))
    piece = np.empty(k, np.int64)
    vert = np.empty(k, w.vertex.dtype)
    rad = np.empty(k)
    mu = np.empty(k)
    for i in range(k):
        f = sel[i]
        a[i, 0] = w.a[f, 0]
        a[i, 1] = w.a[f, 1]
        b[i, 0] = w.b[f, 0]
        b[i, 1] = w.b[f, 1]
        piece[i] = w.piece[f]
        vert[i] = w.vertex[f]
        rad[i] = w.radius[f]
        mu[i] = scene.mu[f]
    return Walls(a, b, piece, vert, rad), mu


@nb.njit(cache=True, nogil=True)
def window_friction(entries: Entries, sel: np.ndarray, ds: float, n: int, a: int) -> tuple[np.ndarray, Entries]:
    """The scene's lagged friction entries seen by a solve of joints ``a..`` of ``n`` segments of length
    ``ds`` (m) with the features ``sel`` (ascending): whether each entry's robot point is in the window,
    and the entries in the window on a seen feature, their feature given as its position in ``sel``."""
    e_s = entries.s
    ne = e_s.shape[0]
    in_window = np.empty(ne, np.bool_)
    pos = np.empty(ne, np.int64)
    cnt = 0
    for i in range(ne):
        s = e_s[i]
        if s < 0.0:
            j = n - 1
        else:
            j = min(int(math.floor(s / ds + SEGMENT_ROUNDING)), n - 1)
        in_window[i] = j >= a
        pos[i] = -1
        if in_window[i]:
            q = np.searchsorted(sel, entries.w[i])
            if q < sel.shape[0] and sel[q] == entries.w[i]:
                pos[i] = q
                cnt += 1
    out = empty_entries(cnt)
    c = 0
    for i in range(ne):
        if pos[i] >= 0:
            _copy_entry(out, c, entries, i, e_s[i], pos[i])
            c += 1
    return in_window, out


@nb.njit(cache=True, nogil=True)
def _copy_entry(out: Entries, c: int, src: Entries, i: int, s: float, w: int) -> None:
    """Entry ``i`` of ``src`` into slot ``c`` of ``out``, at segment parameter ``s`` on wall feature ``w``."""
    out.s[c] = s
    out.w[c] = w
    out.wl[c, 0] = src.wl[i, 0]
    out.wl[c, 1] = src.wl[i, 1]
    out.t[c, 0] = src.t[i, 0]
    out.t[c, 1] = src.t[i, 1]
    out.ml[c] = src.ml[i]


@nb.njit(cache=True, nogil=True)
def _unknown_pieces(nodes: np.ndarray, seg_rad: np.ndarray, held_nodes: np.ndarray, held_rad: np.ndarray, a: int, blo: np.ndarray,
                    bhi: np.ndarray, gathered: Walls, pieces: ScenePieces, reach: float) -> np.ndarray:
    """Mask of the scene's pieces that are unknowns: within ``reach`` of the window and not touched
    by the held body."""
    wpiece_g = gathered.piece
    nf = wpiece_g.shape[0]
    unknown = np.zeros(pieces.u.shape[0], np.bool_)
    close = select_features(nodes, seg_rad, blo, bhi, reach)
    n_unknown = 0
    for i in range(close.shape[0]):
        p = wpiece_g[close[i]]
        if p >= 0 and not unknown[p]:
            unknown[p] = True
            n_unknown += 1
    if a > 0 and n_unknown > 0:
        held = touching(held_nodes, held_rad, blo, bhi, gathered, pieces.pc0, pieces.u, reach)
        for f in range(nf):
            if held[f] and wpiece_g[f] >= 0:
                unknown[wpiece_g[f]] = False
    return unknown


@nb.njit(cache=True, nogil=True)
def _held_in_world(wa: np.ndarray, wb: np.ndarray, f: int, p: int, pieces: ScenePieces) -> None:
    """Feature ``f``'s ends moved from its piece ``p``'s frame to world coordinates (a held piece)."""
    a0, a1, b0, b1 = wa[f, 0], wa[f, 1], wb[f, 0], wb[f, 1]
    cs = pieces.cos_u[p]
    sn = pieces.sin_u[p]
    o0 = pieces.pc0[p, 0] + pieces.u[p, 0]
    o1 = pieces.pc0[p, 1] + pieces.u[p, 1]
    wa[f, 0] = o0 + cs * a0 - sn * a1
    wa[f, 1] = o1 + sn * a0 + cs * a1
    wb[f, 0] = o0 + cs * b0 - sn * b1
    wb[f, 1] = o1 + sn * b0 + cs * b1


@nb.njit(cache=True, nogil=True)
def piece_window(nodes: np.ndarray, seg_rad: np.ndarray, held_nodes: np.ndarray, held_rad: np.ndarray, a: int, scene: SceneWalls,
                 sel: np.ndarray, gathered: Walls, pieces: ScenePieces, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The compliant wall pieces of a solve of joints ``a..`` (``nodes``, ``seg_rad``; the held body
    ``held_nodes``, ``held_rad``) seeing the features ``sel`` (``gathered``: their ends in their piece's
    frame): the pieces within ``reach`` (m) of the window are unknowns, except those the held body
    touches (held with it, else a solve could push one into it).  Returns the features' ends ``wa``,
    ``wb`` (world coordinates for a piece held where it is, its frame for an unknown one), the unknown
    pieces (ascending) and each feature's unknown piece (its position among them; -1 for a static
    wall or a held piece)."""
    wpiece_g = gathered.piece
    nf = sel.shape[0]
    npc = pieces.u.shape[0]
    wpiece = np.full(nf, -1, np.int64)
    if not np.any(wpiece_g >= 0):
        return gathered.a, gathered.b, np.zeros(0, np.int64), wpiece
    blo = np.empty((nf, 2))
    bhi = np.empty((nf, 2))
    for f in range(nf):
        blo[f, 0] = scene.box_lo[sel[f], 0]
        blo[f, 1] = scene.box_lo[sel[f], 1]
        bhi[f, 0] = scene.box_hi[sel[f], 0]
        bhi[f, 1] = scene.box_hi[sel[f], 1]
    unknown = _unknown_pieces(nodes, seg_rad, held_nodes, held_rad, a, blo, bhi, gathered, pieces, reach)
    unknowns = np.nonzero(unknown)[0]
    local = np.full(npc, -1, np.int64)
    for c in range(unknowns.shape[0]):
        local[unknowns[c]] = c
    wa = gathered.a.copy()
    wb = gathered.b.copy()
    for f in range(nf):
        p = wpiece_g[f]
        if p < 0:
            continue
        wpiece[f] = local[p]
        if not unknown[p]:
            _held_in_world(wa, wb, f, p, pieces)
    return wa, wb, unknowns.astype(np.int64), wpiece


@nb.njit(cache=True, nogil=True)
def _overlapping(chain: Chain, phi: np.ndarray, sel: np.ndarray, vertex_dtype_like: np.ndarray) -> Window:
    """The window of a configuration that overlaps a wall: nothing gathered."""
    e2 = np.zeros((0, 2))
    e_i = np.zeros(0, np.int64)
    e_f = np.zeros(0)
    walls = Walls(e2, e2, e_i, np.zeros(0, vertex_dtype_like.dtype), e_f)
    return Window(True, chain, phi, e_f, Joints(e_f, e_f), sel, walls, e_f, e_i, Pieces(e2, np.zeros((0, 3, 3)), e_f, e_f),
                  np.zeros((0, 3)), e_f, np.zeros(0, np.bool_), Entries(e_f, e_i, e2, e2, e_f))


@nb.njit(cache=True, nogil=True)
def _piece_data(unknowns: np.ndarray, pieces: ScenePieces) -> tuple[Pieces, np.ndarray]:
    """The unknown pieces' data (:class:`~evertgym.sim.kernel.bundles.Pieces`) and displacements."""
    npc = unknowns.shape[0]
    pc0 = np.empty((npc, 2))
    u = np.empty((npc, 3))
    kaa = np.empty((npc, 3, 3))
    for i in range(npc):
        p = unknowns[i]
        pc0[i, 0] = pieces.pc0[p, 0]
        pc0[i, 1] = pieces.pc0[p, 1]
        for c in range(3):
            u[i, c] = pieces.u[p, c]
            for d in range(3):
                kaa[i, c, d] = pieces.k_piece[p, c, d]
    return Pieces(pc0, kaa, np.full(npc, pieces.travel), np.full(npc, pieces.k_travel)), u


@nb.njit(cache=True, nogil=True)
def window_setup(body: Body, scene: SceneWalls, pieces: ScenePieces, entries: Entries, query: WindowQuery) -> Window:
    """Everything a solve of joints ``query.a..`` needs, in one call: the features within
    ``query.reach`` (m) of the window (:func:`~evertgym.sim.kernel.contacts.select_features`), whether
    the window overlaps one (:func:`~evertgym.sim.kernel.contacts.overlaps`; nothing else is gathered
    then), the features' arrays (:func:`gather_walls`), the unknown pieces within ``query.piece_reach``
    (:func:`piece_window`) and their arrays, the robot's friction coefficients per segment, and the
    friction entries in the window (:func:`window_friction`)."""
    a = query.a
    nodes = body.nodes
    n = body.phi.shape[0]
    m = n - a
    wnodes = nodes[a:]
    phi = body.phi[a:].copy()
    chain = Chain(query.theta0, nodes[a].copy(), body.seg_len[a:].copy(), body.seg_rad[a:].copy())
    sel = select_features(wnodes, chain.seg_rad, scene.box_lo, scene.box_hi, query.reach)
    if overlaps(chain, phi, sel, scene.box_lo, scene.box_hi, scene.walls, pieces.pc0, pieces.u):
        return _overlapping(chain, phi, sel, scene.walls.vertex)
    s_nodes = np.empty(m + 1)
    for j in range(m):
        s_nodes[j] = body.s_nodes[a + j]
    s_nodes[m] = body.length
    joints = Joints(body.joints.k[a:a + m].copy(), body.joints.mw[a:a + m].copy())
    gathered, wall_mu = gather_walls(sel, scene)
    if pieces.pc0.shape[0] > 0:
        wa, wb, unknowns, wpiece = piece_window(wnodes, chain.seg_rad, nodes[:a + 1], body.seg_rad[:a], a, scene, sel, gathered,
                                                pieces, query.piece_reach)
    else:
        wa, wb = gathered.a, gathered.b
        unknowns = np.zeros(0, np.int64)
        wpiece = np.full(sel.shape[0], -1, np.int64)
    walls = Walls(wa, wb, wpiece, gathered.vertex, gathered.radius)
    piece_data, u = _piece_data(unknowns, pieces)
    robot_mu = np.full(m, query.wall_mu)
    robot_mu[m - 1] = query.tip_mu
    in_window, in_entries = window_friction(entries, sel, query.ds, n, a)
    return Window(False, chain, phi, s_nodes, joints, sel, walls, wall_mu, unknowns, piece_data, u, robot_mu, in_window, in_entries)


@nb.njit(cache=True, nogil=True)
def merge_friction(scene_entries: Entries, in_window: np.ndarray, sel: np.ndarray, solved: Entries) -> Entries:
    """The lagged friction entries after a solve: those outside its window as they were, then the
    solve's own (``solved``; their features positions in ``sel``, mapped back to the scene's)."""
    keep = 0
    for i in range(scene_entries.s.shape[0]):
        keep += not in_window[i]
    out = empty_entries(keep + solved.s.shape[0])
    c = 0
    for i in range(scene_entries.s.shape[0]):
        if not in_window[i]:
            _copy_entry(out, c, scene_entries, i, scene_entries.s[i], scene_entries.w[i])
            c += 1
    for i in range(solved.s.shape[0]):
        _copy_entry(out, c, solved, i, solved.s[i], sel[solved.w[i]])
        c += 1
    return out
