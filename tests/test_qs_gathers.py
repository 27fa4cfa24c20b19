"""The quasi-static engine's compiled gathers give the same bits as the numpy expressions they replaced.

A solve's set-up (the window's wall features, its lagged friction entries, how far a solve moved the
nodes, the kinked joints) moved from numpy expressions into :mod:`evertgym.sim.kernel` (about 50
numpy calls per solve).  The answers must not move by a bit, or the shipped policies would no longer
retrain exactly from their configs: these tests hold each helper to its numpy original on random input.
"""

from __future__ import annotations

import numpy as np
import pytest

from evertgym.model.pressure import KINK_MOMENT_FRACTION
from evertgym.sim import kernel as qk
from evertgym.sim.kernel import linear
from evertgym.sim.kernel.geometry import closest
from evertgym.sim.quasistatic import law_table

_LAW_TABLE = law_table(0.0)  # the joint law without softening


def test_the_window_friction_entries_are_those_numpy_selected():
    rng = np.random.default_rng(3)
    ds = 0.0075
    for _ in range(300):
        n, n_walls, ne = int(rng.integers(2, 60)), int(rng.integers(1, 400)), int(rng.integers(0, 40))
        a = int(rng.integers(0, n))
        sel = np.sort(rng.choice(n_walls, size=int(rng.integers(0, n_walls + 1)), replace=False)).astype(np.int64)
        s = rng.uniform(-0.01, n * ds * 1.1, ne)
        s[rng.random(ne) < 0.2] = -1.0  # the tip's cap
        s[: ne // 4] = np.round(s[: ne // 4] / ds) * ds  # on a joint, where the 1e-9 matters
        wall = rng.integers(0, n_walls, ne).astype(np.int64)
        wl, t, ml = rng.normal(size=(ne, 2)), rng.normal(size=(ne, 2)), rng.random(ne)
        # the numpy expressions of the engine before (git 4d2c01e, QuasiStaticSim._entry_segments and _solve_window_at)
        j = np.minimum(np.floor(np.maximum(s, 0.0) / ds + 1e-9).astype(np.int64), n - 1)
        j[s < 0] = n - 1
        in_window = j >= a
        sel_pos = np.full(n_walls, -1, np.int64)
        sel_pos[sel] = np.arange(len(sel))
        mine = in_window & (sel_pos[wall] >= 0)
        got_in, got_e = qk.window_friction(qk.Entries(s, wall, wl, t, ml), sel, ds, n, a)
        got = (got_in, *got_e)
        want = (in_window, s[mine], sel_pos[wall[mine]], wl[mine], t[mine], ml[mine])
        for g, w in zip(got, want):
            assert g.dtype == w.dtype and g.shape == w.shape and np.array_equal(g, w)


def test_the_gathered_wall_features_are_numpy_fancy_indexing():
    rng = np.random.default_rng(4)
    nw = 500
    arrays = (rng.normal(size=(nw, 2)), rng.normal(size=(nw, 2)), rng.integers(-1, 20, nw).astype(np.int64),
              rng.random(nw) < 0.5, rng.random(nw), rng.random(nw))
    for k in (0, 1, 37, nw):
        sel = np.sort(rng.choice(nw, size=k, replace=False)).astype(np.int64)
        walls, mu = qk.gather_walls(sel, qk.SceneWalls(qk.Walls(*arrays[:5]), np.zeros((nw, 2)), np.zeros((nw, 2)), arrays[5]))
        for g, arr in zip((*walls, mu), arrays):
            assert g.dtype == arr.dtype and np.array_equal(g, arr[sel])


def test_the_largest_node_shift_is_numpys_hypot_maximum():
    rng = np.random.default_rng(5)
    for _ in range(200):
        m = int(rng.integers(1, 80))
        phi, seg_len = rng.normal(scale=0.3, size=m), rng.uniform(1e-4, 0.0075, m)
        theta0, n0 = float(rng.normal()), rng.normal(size=2)
        ref = qk.chain_nodes(theta0, n0, phi + rng.normal(scale=1e-3, size=m), seg_len)[0]
        want = float(np.max(np.hypot(*(qk.chain_nodes(theta0, n0, phi, seg_len)[0] - ref).T)))
        assert qk.max_node_shift(qk.Chain(theta0, n0, seg_len, np.zeros(m)), phi, ref) == want


def test_the_kinked_joints_are_those_numpy_found():
    rng = np.random.default_rng(6)
    for _ in range(200):
        m = int(rng.integers(1, 80))
        phi = rng.normal(scale=0.5, size=m)
        k = rng.uniform(1e-3, 1e-1, m)
        mw = rng.uniform(1e-4, 5e-3, m) * (rng.random() < 0.9)
        moments = qk.joint_moments(phi, qk.Joints(k, mw), _LAW_TABLE)
        mc = 2.0 * mw
        want = np.nonzero(np.abs(moments) >= KINK_MOMENT_FRACTION * mc)[0] if np.any(mc > 0) else np.zeros(0, np.int64)
        got_m, got = qk.kinked_joints(phi, qk.Joints(k, mw), _LAW_TABLE, KINK_MOMENT_FRACTION)
        assert np.array_equal(got_m, moments) and np.array_equal(got, want)


def _piece_window_numpy(sim, a, sel, a_sel, b_sel, wpiece_g, w_vertex, w_radius, nodes, seg_rad, reach):
    """The numpy code of ``QuasiStaticSim._solve_window_at`` before (git 4d2c01e) that chose a solve's wall pieces."""
    pieces = np.zeros(0, np.int64)
    wpiece = np.full(len(sel), -1, np.int64)
    wa, wb = a_sel, b_sel
    if sim._piece_bodies and np.any(wpiece_g >= 0):
        wa, wb = a_sel.copy(), b_sel.copy()
        blo, bhi = sim._feature_boxes[0][sel], sim._feature_boxes[1][sel]
        close = np.zeros(len(sel), np.bool_)
        close[qk.select_features(nodes[a:], seg_rad, blo, bhi, reach)] = True
        unknown = np.zeros(len(sim._piece_bodies) + 1, np.bool_)
        unknown[wpiece_g[(wpiece_g >= 0) & close]] = True
        if a > 0 and np.any(unknown):
            held = qk.touching(nodes[: a + 1], sim.seg_rad[:a], blo, bhi, qk.Walls(a_sel, b_sel, wpiece_g, w_vertex, w_radius), sim._pc0,
                               sim._u_all, reach)
            unknown[wpiece_g[(wpiece_g >= 0) & held]] = False
        pieces = np.nonzero(unknown)[0]
        moving = wpiece_g >= 0
        if np.any(moving):
            q = sim._u_all[wpiece_g[moving]]
            c, sn = np.cos(q[:, 2]), np.sin(q[:, 2])
            o = sim._pc0[wpiece_g[moving]] + q[:, :2]
            for arr in (wa, wb):
                loc = arr[moving].copy()
                arr[moving, 0] = o[:, 0] + c * loc[:, 0] - sn * loc[:, 1]
                arr[moving, 1] = o[:, 1] + sn * loc[:, 0] + c * loc[:, 1]
        solved = unknown[wpiece_g]
        wa[solved], wb[solved] = a_sel[solved], b_sel[solved]
        local = np.full(len(sim._piece_bodies) + 1, -1, np.int64)
        local[pieces] = np.arange(len(pieces))
        wpiece = np.where(wpiece_g >= 0, local[np.maximum(wpiece_g, 0)], -1)
        wpiece[wpiece_g < 0] = -1
    return wa, wb, pieces, wpiece


def _scene_walls(sim) -> qk.SceneWalls:
    """The kernel's bundle of a quasi-static simulator's wall features."""
    w = sim._walls
    return qk.SceneWalls(qk.Walls(w.a, w.b, w.piece, w.vertex, w.radius), *sim._feature_boxes, w.friction)


def _scene_pieces(sim) -> qk.ScenePieces:
    """The kernel's bundle of a quasi-static simulator's wall pieces."""
    return qk.ScenePieces(sim._pc0, sim._u_all, np.cos(sim._u_all[:, 2]), np.sin(sim._u_all[:, 2]), sim._k_piece, sim._travel,
                          sim._k_travel)


def test_the_solved_wall_pieces_are_those_the_numpy_code_chose():
    """On a Colon-v0 episode (compliant wall pieces pushed by the robot, held joints behind the window),
    at every window start of the body, with the pieces displaced as the solves left them."""
    import gymnasium as gym

    import evertgym  # noqa: F401  (registers the envs)

    env = gym.make("evertgym/Colon-v0")
    env.reset(seed=2)
    sim = env.unwrapped.sim
    rng = np.random.default_rng(7)
    checked = moved = 0
    for step in range(60):
        _, _, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
        if term or trunc:  # (step() after the end of an episode raises)
            break
        if step % 10:
            continue
        nodes, _ = sim._all_nodes()
        moved += int(np.any(sim._u_all != 0))
        for a in range(0, len(sim.phi), 3):
            seg_rad = sim.seg_rad[a:].copy()
            reach = 0.001 + 0.003
            sel = qk.select_features(nodes[a:], seg_rad, *sim._feature_boxes, 0.001 + 0.012)
            scene = _scene_walls(sim)
            gathered, _ = qk.gather_walls(sel, scene)
            a_sel, b_sel, wpiece_g, w_vertex, w_radius = gathered
            want = _piece_window_numpy(sim, a, sel, a_sel, b_sel, wpiece_g, w_vertex, w_radius, nodes, seg_rad, reach)
            got = qk.piece_window(nodes[a:], seg_rad, nodes[: a + 1], sim.seg_rad[:a], a, scene, sel, gathered, _scene_pieces(sim),
                                  reach)
            for g, x in zip(got, want):
                assert g.shape == x.shape and np.array_equal(g, x)
            checked += len(want[2])
    env.close()
    assert checked > 0 and moved > 0  # the test saw solved pieces, and pieces the robot had displaced


def test_the_semiseparable_solve_is_the_dense_one_to_rounding():
    """``H = diag(d) + a_i . p_j`` (i <= j, symmetric) from random generators, positive definite and
    indefinite (the Levenberg shift then engages): the O(m) factorisation picks the same shift as the
    dense Cholesky (to rounding) and the same step to 1e-9 of its size."""
    rng = np.random.default_rng(8)
    shifted = 0
    for trial in range(200):
        m = int(rng.integers(1, 90))
        gen = _random_generators(rng, m, compress=trial % 2 == 1, vertex_terms=trial % 3 == 0)
        full = np.triu(gen[:, 1:4] @ gen[:, 4:7].T)
        full = full + np.triu(full, 1).T + np.diag(gen[:, 0])
        rhs = rng.normal(size=m)
        x_dense, mu_dense = linear.cholesky_solve(full, rhs, 0.0)
        x_semi, mu_semi = linear.semi_solve(gen, rhs, 0.0)
        assert mu_semi == pytest.approx(mu_dense, rel=1e-12, abs=0.0)  # (the largest diagonal term, rounded otherwise)
        assert np.max(np.abs(x_semi - x_dense)) <= 1e-9 * np.max(np.abs(x_dense))
        shifted += mu_dense > 0
    assert shifted > 10  # the ladder was exercised


def test_a_decayed_warm_start_still_finds_the_shift():
    """The Newton driver warm-starts the Levenberg shift from a tenth of the last one, which decays
    towards zero while the Hessian stays positive definite (1e-67 after 60 iterations at one UBend-v0
    stall).  When the Hessian then turns indefinite, both solvers still find a shift that makes it
    positive definite: the tries below 1e-8 of the largest diagonal term do not count among the forty
    (from the decayed warm start, forty tenfold steps ended near 1e-27 and the step failed)."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        m = int(rng.integers(5, 60))
        gen = _random_generators(rng, m, compress=True)
        gen[0, 0] = -5.0  # an indefinite joint
        full = np.triu(gen[:, 1:4] @ gen[:, 4:7].T)
        full = full + np.triu(full, 1).T + np.diag(gen[:, 0])
        rhs = rng.normal(size=m)
        assert np.min(np.linalg.eigvalsh(full)) < -1e-3
        for mu0 in (1e-67, 1e-30):
            x_dense, mu_dense = linear.cholesky_solve(full, rhs, mu0)
            x_semi, mu_semi = linear.semi_solve(gen, rhs, mu0)
            assert mu_dense > 1e-3 and mu_semi > 1e-3
            assert np.min(np.linalg.eigvalsh(full + mu_dense * np.eye(m))) > 0
            assert np.allclose((full + mu_dense * np.eye(m)) @ x_dense, rhs, rtol=1e-8, atol=1e-10)
            assert mu_semi == pytest.approx(mu_dense, rel=1e-12, abs=0.0)
    assert not linear.counted(1e-67, 2.0) and not linear.counted(1.9e-8, 2.0)  # below the first shift: not counted
    assert linear.counted(0.0, 2.0) and linear.counted(2e-8, 2.0) and linear.counted(1.0, 2.0)


def _random_generators(rng: np.random.Generator, m: int, compress: bool, vertex_terms: bool = False) -> np.ndarray:
    """Generators ``[d, a, p]`` of a random joints' block: ``p_j`` from suffix sums of PSD 3 x 3 contact terms,
    minus a compressive part if ``compress``, plus a wall vertex's ``vf`` terms if ``vertex_terms``."""
    nodes = np.cumsum(rng.normal(scale=0.0075, size=(m, 2)), axis=0)
    gen = np.empty((m, 7))
    gen[:, 0] = rng.uniform(0.01, 1.0, m)
    gen[:, 1] = 1.0
    gen[:, 2:4] = nodes
    w = np.stack([np.ones(m), -nodes[:, 0], nodes[:, 1]], axis=1)
    s = np.zeros((m, 3, 3))
    for k in rng.choice(m, size=min(m, 3), replace=False):
        v = rng.normal(size=3)
        s[k] += rng.uniform(0, 50) * np.outer(v, v)
    s = np.cumsum(s[::-1], axis=0)[::-1]
    cj = np.einsum("jrc,jc->jr", s, w)
    c3 = -rng.uniform(0, 2.0, m) * compress
    vf = rng.normal(scale=0.1, size=(m, 2)) * vertex_terms
    gen[:, 4] = cj[:, 0] + c3
    gen[:, 5] = vf[:, 0] - cj[:, 1]
    gen[:, 6] = cj[:, 2] + vf[:, 1]
    return gen


def test_the_semiseparable_solve_with_wall_pieces_is_the_dense_schur_solve_to_rounding():
    """Wall pieces coupled to the joints through contact records (:func:`evertgym.sim.kernel.terms.record`) on one segment,
    two adjacent ones (eliminated into the generators) and three or more (kept as unknowns): the
    O(m) solve picks the dense Schur solve's shift and its step to 1e-8 of its size, definite and
    indefinite (the shift engages), with uncoupled pieces beside them."""
    rng = np.random.default_rng(11)
    shifted = kept = 0
    for trial in range(300):
        m = int(rng.integers(2, 70))
        npc = int(rng.integers(1, 12))
        gen = _random_generators(rng, m, compress=trial % 2 == 1)
        hess = np.triu(gen[:, 1:4] @ gen[:, 4:7].T)
        hess = hess + np.triu(hess, 1).T + np.diag(gen[:, 0])
        hpp = np.empty((npc, 3, 3))
        for p in range(npc):
            v = rng.normal(size=(3, 3))
            hpp[p] = v @ v.T + rng.uniform(0.01, 5.0) * np.eye(3) - (trial % 4 == 3) * rng.uniform(0, 3.0) * np.eye(3)
        recs = []
        for p in range(npc):
            span = int(rng.choice([0, 1, 1, 2, 3, 5]))  # 0: uncoupled; 1: one segment; 2: two adjacent; more: kept
            if span == 0:
                continue
            k0 = int(rng.integers(0, max(1, m - span + 1)))
            for _ in range(int(rng.integers(1, 4))):
                k = min(m - 1, k0 + int(rng.integers(0, span)))
                c = rng.normal(size=3) * rng.uniform(0.1, 10.0)
                g = rng.normal(size=3)
                recs.append([p, k, *c, *g])
                # the hpp term of that contact, so that the whole Hessian is a sum of contact terms
                hpp[p] += 0.1 * np.outer(g, g)
            kept += span >= 3
        rec = np.array(recs, dtype=float).reshape(-1, 8)
        hjp = np.zeros((m, 3 * npc))
        a = np.stack([np.ones(m), gen[:, 2], gen[:, 3]], axis=1)
        for r in rec:
            p, k = int(r[0]), int(r[1])
            hjp[: k + 1, 3 * p : 3 * p + 3] += np.outer(a[: k + 1] @ r[2:5], r[5:8])
        rhs = rng.normal(size=m + 3 * npc)
        x_dense, mu_dense = linear.schur_solve(hess, hjp, hpp, rhs, m, npc, 0.0)
        x_semi, mu_semi = linear.semi_schur_solve(gen, rec, hpp, rhs, m, npc, 0.0)
        assert mu_semi == pytest.approx(mu_dense, rel=1e-12, abs=0.0)
        assert np.max(np.abs(x_semi - x_dense)) <= 1e-8 * np.max(np.abs(x_dense))
        shifted += mu_dense > 0
    assert shifted > 20 and kept > 20  # the ladder and the kept pieces were exercised


def test_a_solves_setup_in_one_call_is_the_setup_of_the_separate_calls():
    """``window_setup`` (one compiled call) against the functions it composes and the numpy glue it replaced, at
    every third window start of a Colon-v0 episode (wall pieces displaced, friction entries behind the window), and
    ``merge_friction`` against the concatenation it replaced."""
    import gymnasium as gym

    import evertgym  # noqa: F401  (registers the envs)

    env = gym.make("evertgym/Colon-v0")
    env.reset(seed=2)
    sim = env.unwrapped.sim
    rng = np.random.default_rng(7)
    checked = entries = 0
    for step in range(60):
        _, _, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
        if term or trunc:  # (step() after the end of an episode raises)
            break
        if step % 10:
            continue
        nodes, theta = sim._all_nodes()
        fric = sim._fric
        for a in range(0, len(sim.phi), 3):
            theta0 = sim.base_angle if a == 0 else float(theta[a - 1])
            scene_entries = qk.Entries(fric["s"], fric["wall"], fric["wl"], fric["t"], fric["ml"])
            body = qk.Body(nodes, sim.phi, sim.seg_len, sim.seg_rad, sim.nodes, sim.length, qk.Joints(sim._k_all, sim._mw_all))
            scene, pieces_all = _scene_walls(sim), _scene_pieces(sim)
            out = qk.window_setup(body, scene, pieces_all, scene_entries,
                                  qk.WindowQuery(a, theta0, sim.ds, 0.001 + 0.012, 0.001 + 0.003, 0.4, 0.3))
            m = len(sim.phi) - a
            seg_rad = sim.seg_rad[a:].copy()
            sel = qk.select_features(nodes[a:], seg_rad, *sim._feature_boxes, 0.001 + 0.012)
            chain = qk.Chain(theta0, nodes[a].copy(), sim.seg_len[a:].copy(), seg_rad)
            overlap = qk.overlaps(chain, sim.phi[a:].copy(), sel, *sim._feature_boxes, scene.walls, sim._pc0, sim._u_all)
            assert out.overlap == overlap and np.array_equal(out.sel, sel)
            if overlap:
                continue
            gathered, wall_mu = qk.gather_walls(sel, scene)
            wa, wb, pieces, wpiece = qk.piece_window(nodes[a:], seg_rad, nodes[: a + 1], sim.seg_rad[:a], a, scene, sel, gathered,
                                                     pieces_all, 0.001 + 0.003)
            in_window, f_entries = qk.window_friction(scene_entries, sel, sim.ds, len(sim.seg_len), a)
            robot_mu = np.full(m, 0.4)
            robot_mu[-1] = 0.3
            got = (out.chain.n0, out.phi, out.chain.seg_len, out.chain.seg_rad, out.s_nodes, *out.joints, out.sel, *out.walls,
                   out.wall_mu, out.pieces, out.piece_data.pc0, out.u, out.piece_data.kaa, out.piece_data.travel,
                   out.piece_data.k_travel, out.robot_mu, out.in_window, *out.entries)
            want = (nodes[a], sim.phi[a:], sim.seg_len[a:], seg_rad, np.concatenate((sim.nodes[a:a + m], (sim.length,))),
                    sim._k_all[a:a + m], sim._mw_all[a:a + m], sel, wa, wb, wpiece, *gathered[3:], wall_mu, pieces, sim._pc0[pieces],
                    sim._u_all[pieces], sim._k_piece[pieces], np.full(len(pieces), sim._travel),
                    np.full(len(pieces), sim._k_travel), robot_mu, in_window, *f_entries)
            assert out.chain.theta0 == theta0
            for g, x in zip(got, want, strict=True):
                assert g.shape == x.shape and g.dtype == x.dtype and np.array_equal(g, x)
            # the commit: entries outside the window kept, the window's own appended (as if the solve returned them)
            f_s, f_w, f_wl, f_t, f_ml = f_entries
            merged = qk.merge_friction(scene_entries, in_window, sel, f_entries)
            keep = ~in_window
            concat = (np.concatenate([fric["s"][keep], f_s]), np.concatenate([fric["wall"][keep], sel[f_w]]),
                      np.concatenate([fric["wl"][keep], f_wl]), np.concatenate([fric["t"][keep], f_t]),
                      np.concatenate([fric["ml"][keep], f_ml]))
            for g, x in zip(merged, concat):
                assert g.dtype == x.dtype and np.array_equal(g, x)
            checked += 1
            entries += len(f_s)
    env.close()
    assert checked > 10 and entries > 0


def test_a_segments_gap_is_the_python_loops():
    """``segment_gap`` (compiled) against the loop over the features it replaced, for every segment of a Colon-v0
    body with its wall pieces displaced."""
    import math

    import gymnasium as gym

    import evertgym  # noqa: F401  (registers the envs)

    env = gym.make("evertgym/Colon-v0")
    env.reset(seed=2)
    sim = env.unwrapped.sim
    rng = np.random.default_rng(7)
    checked = finite = 0
    for step in range(40):
        env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
        if step % 13 != 12:
            continue
        nodes, _ = sim._all_nodes()
        w = sim._walls
        for k in range(0, len(sim.seg_len), 5):
            sel = sim._query_walls(nodes[k:k + 2], sim.seg_rad[k] + sim.ds)
            want = math.inf
            for f in sel:
                if w.vertex[f]:
                    continue
                a, b, pc = w.a[f], w.b[f], w.piece[f]
                if pc >= 0:
                    u = sim._u_all[pc]
                    c, s = math.cos(u[2]), math.sin(u[2])
                    o = sim._pc0[pc] + u[:2]
                    a = o + np.array([c * a[0] - s * a[1], s * a[0] + c * a[1]])
                    b = o + np.array([c * b[0] - s * b[1], s * b[0] + c * b[1]])
                d = closest((nodes[k, 0], nodes[k, 1]), (nodes[k + 1, 0], nodes[k + 1, 1]), (a[0], a[1]), (b[0], b[1]))[6]
                want = min(want, d - sim.seg_rad[k] - w.radius[f])
            got = sim._segment_gap(k)
            assert got == want
            checked += 1
            finite += math.isfinite(want)
    env.close()
    assert checked > 20 and finite > 10
