"""Which robot-wall pairs a solve looks at: candidate pairs by bounding circles and boxes, the
contact rows of the pairs within reach, and the wall features near a chain.

A contact row is ``(k, w, s, 0, px, py, qx, qy, nx, ny, gap)`` as float: window segment ``k``, wall
feature ``w``, the parameter ``s`` of the robot point p on segment k, the wall point q, the unit
normal n from q to p and the gap between the surfaces (m)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Chain, Walls
from evertgym.sim.kernel.geometry import closest, lazy_pose, pair_at, poses, segment_box, wall_world, window_nodes

#: Segments per block in the candidate search of :func:`contacts` (a block's circle is tested first) and
#: in the box tests of :func:`overlaps` and :func:`select_features` (a block's box first).
BLOCK = 8
#: Candidate pairs per segment the candidate list is first made for (it doubles when full).
CANDIDATES_PER_SEGMENT = 8
#: Columns of a contact row.
ROW_COLUMNS = 11
#: Allowance (m) for rounding in a block's bounding circle: never narrower than its segments' circles.
CIRCLE_SLACK_M = 1e-9


@nb.njit(cache=True, nogil=True)
def _feature_circles(walls: Walls, pose: np.ndarray, grow: float) -> np.ndarray:
    """Each wall feature's bounding circle ``(x, y, r)`` now, its radius grown by its shape's radius
    and ``grow`` (m)."""
    wa, wb, wpiece, _, wradius = walls
    nw = wa.shape[0]
    circ = np.empty((nw, 3))
    for w in range(nw):
        cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
        circ[w, 0] = 0.5 * (cx + dx)
        circ[w, 1] = 0.5 * (cy + dy)
        circ[w, 2] = 0.5 * math.sqrt((dx - cx) ** 2 + (dy - cy) ** 2) + wradius[w] + grow
    return circ


@nb.njit(cache=True, nogil=True)
def _block_circle(nodes: np.ndarray, seg_len: np.ndarray, seg_rad: np.ndarray, k0: int, k1: int) -> tuple[float, float, float]:
    """The bounding circle ``(x, y, r)`` of segments ``k0..k1 - 1`` (with their radii)."""
    bx = 0.5 * (nodes[k0, 0] + nodes[k1, 0])
    by = 0.5 * (nodes[k0, 1] + nodes[k1, 1])
    big = 0.0
    for k in range(k0, k1):
        mx = 0.5 * (nodes[k, 0] + nodes[k + 1, 0])
        my = 0.5 * (nodes[k, 1] + nodes[k + 1, 1])
        big = max(big, math.sqrt((mx - bx) ** 2 + (my - by) ** 2) + 0.5 * seg_len[k] + seg_rad[k])
    return bx, by, big + CIRCLE_SLACK_M


@nb.njit(cache=True, nogil=True)
def candidates(nodes: np.ndarray, seg_len: np.ndarray, seg_rad: np.ndarray, circ: np.ndarray) -> np.ndarray:
    """The pairs ``(k, w)`` whose bounding circles meet (a block of :data:`BLOCK` segments' circle
    first: the features near it)."""
    m = seg_len.shape[0]
    nw = circ.shape[0]
    cand = np.empty((m * CANDIDATES_PER_SEGMENT + 2 * CANDIDATES_PER_SEGMENT, 2), np.int64)
    cnt = 0
    near = np.empty(nw, np.int64)
    for k0 in range(0, m, BLOCK):
        k1 = min(k0 + BLOCK, m)
        bx, by, big = _block_circle(nodes, seg_len, seg_rad, k0, k1)
        nn = 0
        for w in range(nw):
            reach = big + circ[w, 2]
            ddx = circ[w, 0] - bx
            ddy = circ[w, 1] - by
            if ddx * ddx + ddy * ddy <= reach * reach:
                near[nn] = w
                nn += 1
        for k in range(k0, k1):
            mx = 0.5 * (nodes[k, 0] + nodes[k + 1, 0])
            my = 0.5 * (nodes[k, 1] + nodes[k + 1, 1])
            own = 0.5 * seg_len[k] + seg_rad[k]
            for i in range(nn):
                w = near[i]
                reach = own + circ[w, 2]
                ddx = circ[w, 0] - mx
                ddy = circ[w, 1] - my
                if ddx * ddx + ddy * ddy > reach * reach:
                    continue
                if cnt == cand.shape[0]:
                    bigger = np.empty((2 * cnt, 2), np.int64)
                    bigger[:cnt] = cand
                    cand = bigger
                cand[cnt, 0] = k
                cand[cnt, 1] = w
                cnt += 1
    return cand[:cnt]


@nb.njit(cache=True, nogil=True)
def contacts(chain: Chain, phi: np.ndarray, walls: Walls, pc0: np.ndarray, u: np.ndarray, dhat: float, margin: float) -> np.ndarray:
    """The contact rows of every robot-wall pair (:func:`~evertgym.sim.kernel.geometry.point_edge`)
    with a gap below ``dhat + margin``."""
    nodes = window_nodes(chain, phi)
    circ = _feature_circles(walls, poses(pc0, u), dhat + margin)
    cand = candidates(nodes, chain.seg_len, chain.seg_rad, circ)
    return pair_rows(chain, phi, walls, pc0, u, cand, dhat, margin)


@nb.njit(cache=True, nogil=True)
def pair_rows(chain: Chain, phi: np.ndarray, walls: Walls, pc0: np.ndarray, u: np.ndarray, cand: np.ndarray, dhat: float,
              margin: float) -> np.ndarray:
    """:func:`contacts` restricted to the candidate pairs ``cand`` (k, w)."""
    nodes = window_nodes(chain, phi)
    pose = poses(pc0, u)
    seg_rad = chain.seg_rad
    wa, wb, wpiece, wvertex, wradius = walls
    out = np.empty((cand.shape[0], ROW_COLUMNS))
    cnt = 0
    for c in range(cand.shape[0]):
        k = cand[c, 0]
        w = cand[c, 1]
        _, _, _, _, s, px, py, qx, qy, dist, gap = pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvertex, wradius, pose)
        if gap >= dhat + margin:
            continue
        put_row(out, cnt, k, w, s, px, py, qx, qy, dist, gap)
        cnt += 1
    return out[:cnt]


@nb.njit(cache=True, nogil=True)
def put_row(out: np.ndarray, i: int, k: int, w: int, s: float, px: float, py: float, qx: float, qy: float, dist: float,
            gap: float) -> None:
    """Row ``i`` of ``out``: pair ``(k, w)`` with :func:`~evertgym.sim.kernel.geometry.pair_at`'s parameter, robot
    and wall points, distance and gap (its unit normal from the wall to the robot in columns 8 and 9)."""
    out[i, 0] = k
    out[i, 1] = w
    out[i, 2] = s
    out[i, 3] = 0.0
    out[i, 4] = px
    out[i, 5] = py
    out[i, 6] = qx
    out[i, 7] = qy
    out[i, 8] = (px - qx) / dist if dist > 0 else 0.0
    out[i, 9] = (py - qy) / dist if dist > 0 else 0.0
    out[i, 10] = gap


@nb.njit(cache=True, nogil=True)
def rows_to_pairs(rows: np.ndarray) -> np.ndarray:
    """The pairs ``(k, w)`` of contact rows."""
    out = np.empty((rows.shape[0], 2), np.int64)
    for i in range(rows.shape[0]):
        out[i, 0] = int(rows[i, 0])
        out[i, 1] = int(rows[i, 1])
    return out


@nb.njit(cache=True, nogil=True)
def rows_where(rows: np.ndarray, reach: float) -> np.ndarray:
    """The contact rows with a gap below ``reach`` (m), in order."""
    cnt = 0
    for i in range(rows.shape[0]):
        if rows[i, 10] < reach:
            cnt += 1
    out = np.empty((cnt, rows.shape[1]))
    cnt = 0
    for i in range(rows.shape[0]):
        if rows[i, 10] < reach:
            out[cnt] = rows[i]
            cnt += 1
    return out


@nb.njit(cache=True, nogil=True)
def near_pairs(nodes: np.ndarray, pairs: np.ndarray, seg_rad: np.ndarray, walls: Walls, pc0: np.ndarray, u: np.ndarray,
               reach: float) -> np.ndarray:
    """The pairs ``(k, w)`` of ``pairs`` with a gap below ``reach`` (m) at ``nodes``, ``u``, in order."""
    keep = np.empty(pairs.shape[0], np.bool_)
    cnt = 0
    pose = poses(pc0, u)
    wa, wb, wpiece, wvertex, wradius = walls
    for c in range(pairs.shape[0]):
        keep[c] = pair_at(nodes, pairs[c, 0], pairs[c, 1], seg_rad, wa, wb, wpiece, wvertex, wradius, pose)[10] < reach
        cnt += keep[c]
    out = np.empty((cnt, 2), np.int64)
    cnt = 0
    for c in range(pairs.shape[0]):
        if keep[c]:
            out[cnt, 0] = pairs[c, 0]
            out[cnt, 1] = pairs[c, 1]
            cnt += 1
    return out


@nb.njit(cache=True, nogil=True)
def block_boxes(nodes: np.ndarray, grow: np.ndarray) -> np.ndarray:
    """Per block of :data:`BLOCK` segments of the chain ``nodes``: the box ``(lx, hx, ly, hy)``
    around its segments' boxes (segment ``k``'s grown by ``grow[k]``); a box that misses a block's
    misses each of its segments'."""
    m = grow.shape[0]
    out = np.empty(((m + BLOCK - 1) // BLOCK, 4))
    for b in range(out.shape[0]):
        out[b, 0] = np.inf
        out[b, 1] = -np.inf
        out[b, 2] = np.inf
        out[b, 3] = -np.inf
        for k in range(b * BLOCK, min(m, (b + 1) * BLOCK)):
            lx, hx, ly, hy = segment_box(nodes, k, grow[k])
            out[b, 0] = min(out[b, 0], lx)
            out[b, 1] = max(out[b, 1], hx)
            out[b, 2] = min(out[b, 2], ly)
            out[b, 3] = max(out[b, 3], hy)
    return out


@nb.njit(cache=True, nogil=True)
def _disjoint(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Whether boxes ``(lx, hx, ly, hy)`` ``a`` and ``b`` do not meet."""
    return a[1] < b[0] or a[0] > b[1] or a[3] < b[2] or a[2] > b[3]


@nb.njit(cache=True, nogil=True)
def overlaps(chain: Chain, phi: np.ndarray, feats: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray, walls: Walls,
             pc0: np.ndarray, u: np.ndarray) -> bool:
    """Whether the window ``phi`` overlaps a wall: a robot-wall pair with a gap at or below zero,
    among the features ``feats`` whose boxes (``box_lo``, ``box_hi``) meet a segment's.  The same test
    that makes a solve return ``INFEASIBLE_START``, without a solve's setup (a growth increment that
    would overlap is refused before it is assembled)."""
    nodes = window_nodes(chain, phi)
    seg_rad = chain.seg_rad
    m = phi.shape[0]
    blocks = block_boxes(nodes, seg_rad)
    pose = np.empty((u.shape[0], 4))
    have = np.zeros(u.shape[0], np.bool_)
    wa, wb, wpiece, wvertex, wradius = walls
    for w in feats:
        # a wall piece's box covers its whole travel: its feature where it is now (grown by its radius)
        # is a tighter test before the exact one
        fb = (box_lo[w, 0], box_hi[w, 0], box_lo[w, 1], box_hi[w, 1])
        posed = False
        for b in range(blocks.shape[0] - 1, -1, -1):  # from the tip, where an overlap is likeliest
            bb = (blocks[b, 0], blocks[b, 1], blocks[b, 2], blocks[b, 3])
            if _disjoint(fb, bb):
                continue
            if not posed and wpiece[w] >= 0:
                lazy_pose(pose, have, w, wpiece, pc0, u)
                cx, cy, dx, dy = wall_world(w, wa, wb, wpiece, pose)
                rw = wradius[w]
                fb = (min(cx, dx) - rw, max(cx, dx) + rw, min(cy, dy) - rw, max(cy, dy) + rw)
                posed = True
                if _disjoint(fb, bb):
                    continue
            for k in range(min(m, (b + 1) * BLOCK) - 1, b * BLOCK - 1, -1):
                if _disjoint(fb, segment_box(nodes, k, seg_rad[k])):
                    continue
                lazy_pose(pose, have, w, wpiece, pc0, u)
                if pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvertex, wradius, pose)[10] <= 0.0:
                    return True
    return False


@nb.njit(cache=True, nogil=True)
def touching(nodes: np.ndarray, seg_rad: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray, walls: Walls, pc0: np.ndarray,
             u: np.ndarray, reach: float) -> np.ndarray:
    """Mask of the wall features within ``reach`` (m) of a segment of the chain ``nodes``: a
    robot-wall pair with a gap below ``reach``."""
    nf = box_lo.shape[0]
    out = np.zeros(nf, np.bool_)
    pose = np.empty((u.shape[0], 4))
    have = np.zeros(u.shape[0], np.bool_)
    wa, wb, wpiece, wvertex, wradius = walls
    for k in range(seg_rad.shape[0]):
        lx, hx, ly, hy = segment_box(nodes, k, seg_rad[k] + reach)
        for w in range(nf):
            if out[w] or box_hi[w, 0] < lx or box_lo[w, 0] > hx or box_hi[w, 1] < ly or box_lo[w, 1] > hy:
                continue
            lazy_pose(pose, have, w, wpiece, pc0, u)
            if pair_at(nodes, k, w, seg_rad, wa, wb, wpiece, wvertex, wradius, pose)[10] < reach:
                out[w] = True
    return out


@nb.njit(cache=True, nogil=True)
def _near_blocks(box: tuple[float, float, float, float], blocks: np.ndarray, nodes: np.ndarray, seg_rad: np.ndarray,
                 reach: float) -> bool:
    """Whether ``box`` meets a segment's box grown by its radius and ``reach`` (a block's box first)."""
    m = seg_rad.shape[0]
    for b in range(blocks.shape[0]):
        if _disjoint(box, (blocks[b, 0], blocks[b, 1], blocks[b, 2], blocks[b, 3])):
            continue
        for k in range(b * BLOCK, min(m, (b + 1) * BLOCK)):
            if not _disjoint(box, segment_box(nodes, k, seg_rad[k] + reach)):
                return True
    return False


@nb.njit(cache=True, nogil=True)
def select_features(nodes: np.ndarray, seg_rad: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray, reach: float) -> np.ndarray:
    """Indices of the wall features (boxes ``box_lo``, ``box_hi``) within ``reach`` (m) of a
    segment's box (its nodes grown by its radius): the window's box first, then each block's of
    :data:`BLOCK` segments (:func:`block_boxes`), then each segment's."""
    m = seg_rad.shape[0]
    g = reach
    for k in range(m):
        g = max(g, seg_rad[k] + reach)
    wlx = nodes[0, 0]
    whx = nodes[0, 0]
    wly = nodes[0, 1]
    why = nodes[0, 1]
    for k in range(m + 1):
        wlx = min(wlx, nodes[k, 0])
        whx = max(whx, nodes[k, 0])
        wly = min(wly, nodes[k, 1])
        why = max(why, nodes[k, 1])
    blocks = block_boxes(nodes, seg_rad + reach)
    out = np.empty(box_lo.shape[0], np.int64)
    cnt = 0
    for f in range(box_lo.shape[0]):
        if box_hi[f, 0] < wlx - g or box_lo[f, 0] > whx + g or box_hi[f, 1] < wly - g or box_lo[f, 1] > why + g:
            continue
        if _near_blocks((box_lo[f, 0], box_hi[f, 0], box_lo[f, 1], box_hi[f, 1]), blocks, nodes, seg_rad, reach):
            out[cnt] = f
            cnt += 1
    return out[:cnt]


@nb.njit(cache=True, nogil=True)
def boxes_near(box_lo: np.ndarray, box_hi: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices of the boxes (``box_lo``, ``box_hi``: (n, 2), m) that meet the box ``lo``-``hi`` (m), in order."""
    out = np.empty(box_lo.shape[0], np.int64)
    cnt = 0
    for f in range(box_lo.shape[0]):
        if box_hi[f, 0] >= lo[0] and box_hi[f, 1] >= lo[1] and box_lo[f, 0] <= hi[0] and box_lo[f, 1] <= hi[1]:
            out[cnt] = f
            cnt += 1
    return out[:cnt]


@nb.njit(cache=True, nogil=True)
def segment_gap(nodes: np.ndarray, k: int, rad_k: float, sel: np.ndarray, walls: Walls, pc0: np.ndarray, u: np.ndarray) -> float:
    """Smallest gap (m) between segment ``k`` of the chain ``nodes`` (radius ``rad_k``) and the wall
    segments among the features ``sel`` (vertices skipped), each piece's where its displacement ``u``
    puts it; ``inf`` if none."""
    best = np.inf
    for i in range(sel.shape[0]):
        w = sel[i]
        if walls.vertex[w]:
            continue
        ax, ay, bx, by = walls.a[w, 0], walls.a[w, 1], walls.b[w, 0], walls.b[w, 1]
        p = walls.piece[w]
        if p >= 0:
            c = math.cos(u[p, 2])
            s = math.sin(u[p, 2])
            ox = pc0[p, 0] + u[p, 0]
            oy = pc0[p, 1] + u[p, 1]
            ax, ay, bx, by = ox + (c * ax - s * ay), oy + (s * ax + c * ay), ox + (c * bx - s * by), oy + (s * bx + c * by)
        d = closest((nodes[k, 0], nodes[k, 1]), (nodes[k + 1, 0], nodes[k + 1, 1]), (ax, ay), (bx, by))[6]
        best = min(best, d - rad_k - walls.radius[w])
    return best
