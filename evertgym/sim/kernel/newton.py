"""The Newton solve of a window's equilibrium: the stationary point of the incremental potential
(:mod:`evertgym.sim.kernel.potential`) over the joints' rotations and the wall pieces' displacements.

One iteration: the gradient and Hessian at the current configuration; the force residuals (the
stop); the Newton step from the Levenberg-shifted Hessian (:mod:`evertgym.sim.kernel.linear`); the
step's caps (a joint's turn, a node's travel); a backtracking line search whose every trial is
collision-free along the step (:mod:`evertgym.sim.kernel.ccd`) and, by Armijo's test, lowers the
energy; and the contact pairs listed again once the body has moved far enough to meet others.
The friction lag runs inside the same loop: at every iterate near equilibrium the normal forces and
tangents are made again from the contacts, and the solve ends where the equilibrium and the lagged
friction have both converged.  :func:`solve_increment` adds the wall forces of the result."""

# (no ``from __future__ import annotations``: the NamedTuples' fields keep their types as objects, which
# the API reference resolves)
import math
from typing import NamedTuple

import numba as nb
import numpy as np

from evertgym.sim.kernel.bundles import Entries, Friction, Hessian, LagSource, Problem, SolveResult, SolveSettings
from evertgym.sim.kernel.ccd import CCD_BACKOFF, step_bound
from evertgym.sim.kernel.contacts import ROW_COLUMNS, contacts, near_pairs, pair_rows, put_row, rows_to_pairs, rows_where
from evertgym.sim.kernel.friction import new_entries, resolve, same_entries
from evertgym.sim.kernel.geometry import moved, piece_reach, poses, window_nodes
from evertgym.sim.kernel.linear import dense_diag_max, schur_solve, semi_diag_max, semi_schur_solve
from evertgym.sim.kernel.potential import GEO_COLUMNS, contact_forces, energy, grad_hess, new_accumulators, pair_geometry

#: solve status codes
CONVERGED = 0
MAX_ITERATIONS = 1
LINE_SEARCH_FAILED = 2
INFEASIBLE_START = 3

#: Reach (m) beyond the barrier gap of the pairs a Newton solve evaluates: re-listed from its candidates
#: whenever a gap may have changed by more than this since they were listed.
NEAR_MARGIN_M = 1e-3
#: Allowance (m) for rounding in the bound on a gap's change.
NEAR_SLACK_M = 1e-9
#: Candidates of a solve: the pairs within the barrier gap plus this many largest steps (``max_move``);
#: listed again from every wall once anything has moved by one step since.
CANDIDATE_STEPS = 2.0
#: A bound (m) on a wall feature's distance from its piece's origin, for the drift of a piece's rotation.
PIECE_ROTATION_ARM_M = 0.05
#: Largest joint rotation (rad) of one Newton step (the linearisation's reach on the chain).
MAX_JOINT_TURN_RAD = 0.5
#: Armijo's sufficient decrease: a trial is taken if it lowers the energy by this fraction of the
#: decrease the gradient predicts ...
ARMIJO = 1e-4
#: ... or changes it by no more than its rounding (this fraction of it).
ENERGY_ROUNDING = 1e-13
#: Backtracking: the step's factor after a trial that overlaps a wall or fails Armijo's test ...
BACKTRACK = 0.5
#: ... and the trials before the line search gives up.
MAX_HALVINGS = 60
#: The Levenberg shift's warm start: this fraction of the last one.
SHIFT_WARM_START = 0.1
#: A step cut below this fraction of its length by the line search damps the next (an indefinite
#: model: a kink's plateau under compression) ...
DAMP_CUT = 0.1
#: ... to this many times the last shift or damping ...
DAMP_GROWTH = 10.0
#: ... and at least this fraction of the Hessian's largest diagonal term.
DAMP_FLOOR = 1e-6
#: A step taken at this fraction of its length or more relaxes the damping by :data:`DAMP_DECAY`.
DAMP_KEEP = 0.5
DAMP_DECAY = 0.1
#: Reach (m) beyond the barrier gap of the contact rows a solve reports (the tip's clearance).
WIDE_REACH_M = 1.0
#: The friction lag's entries are made again at every iterate whose last residuals were within this
#: multiple of the tolerance: the lag's refreshes overlap the Newton's last iterations (far from
#: equilibrium, where Newton walks under its step caps, the entries keep the lag's budget for later).
LAG_REFRESH_FACTOR = 1000.0
#: ... for this many refreshes; later ones wait for convergence (near a snap-through, entries made again at
#: every iterate move the equilibrium Newton chases, and it does not converge).
LAG_EARLY_REFRESHES = 10
#: The wall-force rows a solve reports are those of its candidates, listed again from every wall if
#: anything has moved by more than this fraction of their reach.
WIDE_RELIST_FRACTION = 0.5


class Listing(NamedTuple):
    """The contact pairs a solve evaluates: the candidates ``pairs`` listed at ``anchor`` (nodes),
    ``anchor_u``; the ``near`` ones (within the barrier gap and :data:`NEAR_MARGIN_M`) at ``ref_nodes``,
    ``ref_u``; and the near pairs' geometry ``geo`` at the configuration whose energy was taken last."""

    pairs: np.ndarray
    near: np.ndarray
    geo: np.ndarray
    anchor: np.ndarray
    anchor_u: np.ndarray
    ref_nodes: np.ndarray
    ref_u: np.ndarray


class Trial(NamedTuple):
    """The line search's outcome: whether a trial was taken, its step fraction ``alpha``, its
    configuration and energy, and the pairs as it left them."""

    accepted: bool
    alpha: float
    phi: np.ndarray
    u: np.ndarray
    nodes: np.ndarray
    energy: float
    listing: Listing


@nb.njit(cache=True, nogil=True)
def residuals(grad: np.ndarray, m: int, npc: int) -> tuple[float, float]:
    """The largest unbalanced joint moment (N m; a piece's rotation's too) and wall-piece force (N)."""
    res_m = 0.0
    for j in range(m):
        res_m = max(res_m, abs(grad[j]))
    res_f = 0.0
    for p in range(npc):
        res_f = max(res_f, abs(grad[m + 3 * p]), abs(grad[m + 3 * p + 1]))
        res_m = max(res_m, abs(grad[m + 3 * p + 2]))
    return res_m, res_f


@nb.njit(cache=True, nogil=True)
def drift(nodes: np.ndarray, anchor: np.ndarray, u: np.ndarray, anchor_u: np.ndarray) -> float:
    """How far (m) the body and the pieces have moved since ``anchor``, ``anchor_u``."""
    d = 0.0
    for j in range(nodes.shape[0]):
        d = max(d, math.sqrt((nodes[j, 0] - anchor[j, 0]) ** 2 + (nodes[j, 1] - anchor[j, 1]) ** 2))
    for p in range(u.shape[0]):
        d = max(d, math.sqrt((u[p, 0] - anchor_u[p, 0]) ** 2 + (u[p, 1] - anchor_u[p, 1]) ** 2)
                + PIECE_ROTATION_ARM_M * abs(u[p, 2] - anchor_u[p, 2]))
    return d


@nb.njit(cache=True, nogil=True)
def listing_at(rows: np.ndarray, nodes: np.ndarray, u: np.ndarray, dhat: float) -> Listing:
    """The pairs of the contact ``rows`` listed at ``nodes``, ``u``."""
    pairs = rows_to_pairs(rows)
    near = rows_to_pairs(rows_where(rows, dhat + NEAR_MARGIN_M))
    return Listing(pairs, near, np.empty((pairs.shape[0], GEO_COLUMNS)), nodes, u.copy(), nodes, u.copy())


@nb.njit(cache=True, nogil=True)
def direction(hs: Hessian, grad: np.ndarray, m: int, npc: int, semi: bool, mu0: float) -> tuple[np.ndarray, float]:
    """The Newton step ``-(H + mu I)^-1 grad`` and its shift ``mu`` (< 0: none made it positive definite)."""
    if semi:
        return semi_schur_solve(hs.gen, hs.hjp, hs.hpp, -grad, m, npc, mu0)
    return schur_solve(hs.hess, hs.hjp, hs.hpp, -grad, m, npc, mu0)


@nb.njit(cache=True, nogil=True)
def step_caps(problem: Problem, phi: np.ndarray, nodes: np.ndarray, step: np.ndarray, max_move: float) -> tuple[float, bool, np.ndarray]:
    """The step's fraction ``scale`` that turns no joint by more than :data:`MAX_JOINT_TURN_RAD` and
    moves no node nor piece by more than ``max_move`` (m); whether the second cap left it whole, and
    the nodes at the first cap's fraction."""
    m = phi.shape[0]
    npc = (step.shape[0] - m) // 3
    smax = 0.0
    for j in range(m):
        smax = max(smax, abs(step[j]))
    scale = 1.0 if smax <= MAX_JOINT_TURN_RAD else MAX_JOINT_TURN_RAD / smax
    nodes1 = window_nodes(problem.chain, phi + scale * step[:m])
    move = 0.0
    for j in range(m + 1):
        move = max(move, math.sqrt((nodes1[j, 0] - nodes[j, 0]) ** 2 + (nodes1[j, 1] - nodes[j, 1]) ** 2))
    for p in range(npc):
        move = max(move, math.sqrt(step[m + 3 * p] ** 2 + step[m + 3 * p + 1] ** 2) * scale)
    whole = move <= max_move  # the first trial is then this one (its nodes: nodes1)
    if not whole:
        scale *= max_move / move
    return scale, whole, nodes1


@nb.njit(cache=True, nogil=True)
def _trial_u(u: np.ndarray, step: np.ndarray, alpha: float, m: int, out: np.ndarray) -> None:
    """The pieces' displacements ``u + alpha step[m:]`` into ``out``."""
    for p in range(u.shape[0]):
        out[p, 0] = u[p, 0] + alpha * step[m + 3 * p]
        out[p, 1] = u[p, 1] + alpha * step[m + 3 * p + 1]
        out[p, 2] = u[p, 2] + alpha * step[m + 3 * p + 2]


@nb.njit(cache=True, nogil=True)
def _relisted(problem: Problem, lst: Listing, nodes: np.ndarray, u: np.ndarray, rho: np.ndarray) -> Listing:
    """``lst`` with its near pairs listed again at ``nodes``, ``u`` if a gap may have changed by more
    than :data:`NEAR_MARGIN_M` since they were."""
    if moved(nodes, lst.ref_nodes, u, lst.ref_u, rho) <= NEAR_MARGIN_M - NEAR_SLACK_M:
        return lst
    near = near_pairs(nodes, lst.pairs, problem.chain.seg_rad, problem.walls, problem.pieces.pc0, u, problem.contact.dhat + NEAR_MARGIN_M)
    return Listing(lst.pairs, near, lst.geo, lst.anchor, lst.anchor_u, nodes, u.copy())


@nb.njit(cache=True, nogil=True)
def collision_free(problem: Problem, lst: Listing, nodes: np.ndarray, u: np.ndarray, trial_nodes: np.ndarray, u_try: np.ndarray,
                   rho: np.ndarray) -> float:
    """The fraction (0-1] of the step from ``nodes``, ``u`` to the trial along which no pair touches
    (:func:`~evertgym.sim.kernel.ccd.step_bound`).  The near pairs suffice while both ends lie within
    :data:`NEAR_MARGIN_M` of where they were listed (every point of the straight-line step does
    then, and the other pairs' gaps stay positive), and of those only the ones whose gap at the trial
    is within the step's largest displacement; else every candidate is checked."""
    near_enough = moved(nodes, lst.ref_nodes, u, lst.ref_u, rho) <= NEAR_MARGIN_M - NEAR_SLACK_M
    pairs = _closer_than(lst.near, lst.geo, moved(trial_nodes, nodes, u_try, u, rho)) if near_enough else lst.pairs
    return step_bound(nodes, trial_nodes, u, u_try, pairs, problem.chain.seg_rad, problem.walls, problem.pieces.pc0)


@nb.njit(cache=True, nogil=True)
def _closer_than(pairs: np.ndarray, geo: np.ndarray, reach: float) -> np.ndarray:
    """The pairs whose gap at the trial (``geo``, as the trial's energy left it) is at most ``reach``,
    the largest relative displacement of any of their points on the way: the others' gaps stay
    positive all along the step."""
    keep = np.empty(pairs.shape[0], np.bool_)
    for c in range(pairs.shape[0]):
        keep[c] = geo[c, 10] <= reach
    return pairs[keep]


@nb.njit(cache=True, nogil=True)
def line_search(problem: Problem, fr: Friction, phi: np.ndarray, u: np.ndarray, nodes: np.ndarray, e0: float, step: np.ndarray,
                slope: float, scale: float, first: np.ndarray, lst: Listing, rho: np.ndarray) -> Trial:
    """Backtracking from ``scale`` along ``step`` (``slope``: the energy's derivative along it): the
    first trial that passes Armijo's test and is collision-free along the step (``first``: the nodes
    of the trial at ``scale``, if already known; else an empty array).  A trial that overlaps a wall
    (infinite energy) or fails the test halves the step; one beyond a wall the step passed through
    is cut to :data:`~evertgym.sim.kernel.ccd.CCD_BACKOFF` of the step's free part."""
    m = phi.shape[0]
    alpha = scale
    u_try = u.copy()
    trial_phi = phi.copy()
    trial_nodes = nodes
    e1 = np.inf
    for ls in range(MAX_HALVINGS):
        trial_phi = phi + alpha * step[:m]
        _trial_u(u, step, alpha, m, u_try)
        trial_nodes = first if ls == 0 and first.shape[0] > 0 else window_nodes(problem.chain, trial_phi)
        lst = _relisted(problem, lst, trial_nodes, u_try, rho)
        e1 = energy(problem, trial_phi, u_try, trial_nodes, lst.near, fr, lst.geo)
        if math.isfinite(e1) and (e1 <= e0 + ARMIJO * alpha * slope or (e1 - e0) <= ENERGY_ROUNDING * abs(e0)):
            # a trial whose gaps are all positive may still lie beyond a wall the step passed through
            free = collision_free(problem, lst, nodes, u, trial_nodes, u_try, rho)
            if free >= 1.0:
                return Trial(True, alpha, trial_phi, u_try, trial_nodes, e1, lst)
            alpha *= CCD_BACKOFF * free
            continue
        alpha *= BACKTRACK
    return Trial(False, alpha, trial_phi, u_try, trial_nodes, e1, lst)


@nb.njit(cache=True, nogil=True)
def _damping(damp: float, shift: float, alpha: float, scale: float, hs: Hessian, semi: bool) -> float:
    """The Levenberg-Marquardt damping of the next step: an indefinite model (a kink's plateau under
    compression) gives long steps that the line search cuts; damp the next step instead (a trust
    region in Levenberg-Marquardt's form), and relax it when steps are taken whole."""
    if alpha < DAMP_CUT * scale:
        return max(DAMP_GROWTH * max(damp, shift), DAMP_FLOOR * (semi_diag_max(hs.gen, hs.hpp) if semi else dense_diag_max(hs.hess, hs.hpp)))
    if alpha >= DAMP_KEEP * scale:
        return damp * DAMP_DECAY
    return damp


@nb.njit(cache=True, nogil=True)
def lag_rows(lst: Listing, dhat: float) -> np.ndarray:
    """The contact rows (:func:`~evertgym.sim.kernel.contacts.pair_rows`) of the near pairs whose gap is
    below ``dhat``, at the configuration whose energy was taken last (``lst.geo``): every pair in
    contact is among the near ones."""
    near = lst.near
    geo = lst.geo
    rows = np.empty((near.shape[0], ROW_COLUMNS))
    cnt = 0
    for c in range(near.shape[0]):
        if geo[c, 10] < dhat:
            put_row(rows, cnt, near[c, 0], near[c, 1], geo[c, 4], geo[c, 5], geo[c, 6], geo[c, 7], geo[c, 8], geo[c, 9], geo[c, 10])
            cnt += 1
    return rows[:cnt]


@nb.njit(cache=True, nogil=True)
def _resolved(problem: Problem, entries: Entries, lag: LagSource) -> Friction:
    """``entries`` resolved on the window (:func:`~evertgym.sim.kernel.friction.resolve`)."""
    return resolve(entries, lag.start_nodes, lag.s_nodes, problem.chain.seg_len, problem.walls.piece, problem.pieces.pc0, lag.u0)


@nb.njit(cache=True, nogil=True)
def _refresh(problem: Problem, lst: Listing, entries: Entries, fr: Friction, e0: float, lag: LagSource, settings: SolveSettings,
             phi: np.ndarray, u: np.ndarray, nodes: np.ndarray, allowed: bool) -> tuple[bool, Entries, Friction, float, bool]:
    """The friction lag's check at the configuration whose energy was taken last: whether the entries
    made from its contacts are ``entries`` (normal forces within ``tol_f``); if not and ``allowed``,
    they replace them (and the friction and the energy ``e0`` follow).  Returns ``(same, entries,
    friction, e0, refreshed)``."""
    fresh = new_entries(lag_rows(lst, problem.contact.dhat), lag.s_nodes, problem.chain.seg_len, lag.robot_mu, lag.wall_mu,
                        problem.walls, problem.pieces.pc0, u, problem.contact)
    if same_entries(entries, fresh, settings.tol_f):
        return True, entries, fr, e0, False
    if not allowed:
        return False, entries, fr, e0, False
    fr = _resolved(problem, fresh, lag)
    return False, fresh, fr, energy(problem, phi, u, nodes, lst.near, fr, lst.geo), True


@nb.njit(cache=True, nogil=True)
def solve(problem: Problem, phi: np.ndarray, u: np.ndarray, entries: Entries, lag: LagSource, settings: SolveSettings,
          rows0: np.ndarray) -> tuple[int, int, float, float, Entries, bool, int]:
    """Newton's method on the incremental potential from ``(phi, u)`` (updated in place) with the
    friction lag: ``entries``, the lagged friction at the start, are made again from the contacts
    (:func:`~evertgym.sim.kernel.friction.new_entries`, from ``lag``) at every iterate where they have
    changed once the residuals are within :data:`LAG_REFRESH_FACTOR` of the tolerance, at most
    ``lag_iterations`` times, so that the lag converges with the equilibrium, not after it.
    ``rows0``: the contact rows (:func:`~evertgym.sim.kernel.contacts.pair_rows`) at the start, at
    least those within ``dhat + 2 max_move``; once anything has moved by ``max_move`` the rows are
    listed again from every wall (:func:`~evertgym.sim.kernel.contacts.contacts`).

    Returns ``(status, iterations, residual_m, residual_f, entries, lag_converged, refreshes)``: the largest
    unbalanced joint moment (N m) and wall-piece force (N) at the end; ``status`` is
    :data:`CONVERGED` when they are below ``tol_m`` and ``tol_f``; the entries at the end, and
    whether the contacts there give the same ones (normal forces within ``tol_f``,
    :func:`~evertgym.sim.kernel.friction.same_entries`), and how many times they were made again.  A step moves no node by more than
    ``max_move`` (m); the Newton budget ``max_iter`` counts from the last refresh, and a solve that
    spends it makes the entries again there (while the lag's budget lasts) and goes on."""
    m = phi.shape[0]
    npc = u.shape[0]
    dhat = problem.contact.dhat
    max_move = settings.max_move
    nodes = window_nodes(problem.chain, phi)
    lst = listing_at(rows_where(rows0, dhat + CANDIDATE_STEPS * max_move), nodes, u, dhat)
    rho = piece_reach(problem.walls, npc)
    fr = _resolved(problem, entries, lag)
    e0 = energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
    if not math.isfinite(e0):
        return INFEASIBLE_START, 0, np.inf, np.inf, entries, False, 0
    res_m = np.inf
    res_f = np.inf
    shift = 0.0  # the last Levenberg shift, warm start of the next
    damp = 0.0  # Levenberg-Marquardt damping: grows while steps are cut short, shrinks when they are taken whole
    refreshes = 0
    iters = 0
    since = 0  # iterations since the last refresh
    near = False  # whether the last residuals were within LAG_REFRESH_FACTOR of the tolerance
    while True:
        checked = near  # the entries are checked against the contacts here, before the gradient
        same = False
        if checked:
            same, entries, fr, e0, refreshed = _refresh(problem, lst, entries, fr, e0, lag, settings, phi, u, nodes,
                                                        refreshes < settings.lag_iterations)
            refreshes += refreshed
            if refreshed:
                same = True  # (the entries are now the contacts' here)
                since = 0
        grad, hs = grad_hess(problem, phi, u, nodes, lst.near, fr, lst.geo, True, settings.semi)
        res_m, res_f = residuals(grad, m, npc)
        if res_m <= settings.tol_m and res_f <= settings.tol_f:
            if not checked:  # converged where the lag was not checked: it is checked here
                same, entries, fr, e0, refreshed = _refresh(problem, lst, entries, fr, e0, lag, settings, phi, u, nodes,
                                                            refreshes < settings.lag_iterations)
                refreshes += refreshed
                if refreshed:
                    since = 0
                    near = True
                    continue
            if same or refreshes == settings.lag_iterations:
                return CONVERGED, iters, res_m, res_f, entries, same, refreshes
        reach = LAG_REFRESH_FACTOR if refreshes < LAG_EARLY_REFRESHES else 1.0
        near = res_m <= reach * settings.tol_m and res_f <= reach * settings.tol_f
        if since == settings.max_iter:  # Newton's budget spent: the entries made again here, or the end
            if refreshes == settings.lag_iterations:
                break
            same, entries, fr, e0, refreshed = _refresh(problem, lst, entries, fr, e0, lag, settings, phi, u, nodes, True)
            if not refreshed:
                break
            refreshes += 1
            since = 0
            near = True
            continue
        step, shift = direction(hs, grad, m, npc, settings.semi, max(SHIFT_WARM_START * shift, damp))
        if shift < 0:
            return LINE_SEARCH_FAILED, iters, res_m, res_f, entries, False, refreshes
        scale, whole, nodes1 = step_caps(problem, phi, nodes, step, max_move)
        slope = 0.0
        for i in range(step.shape[0]):
            slope += grad[i] * step[i]
        first = nodes1 if whole else np.empty((0, 2))
        trial = line_search(problem, fr, phi, u, nodes, e0, step, slope, scale, first, lst, rho)
        if not trial.accepted:
            return LINE_SEARCH_FAILED, iters, res_m, res_f, entries, False, refreshes
        iters += 1
        since += 1
        damp = _damping(damp, shift, trial.alpha, scale, hs, settings.semi)
        phi[:] = trial.phi
        u[:, :] = trial.u
        nodes = trial.nodes
        lst = trial.listing
        if drift(nodes, lst.anchor, u, lst.anchor_u) > max_move:
            # from every wall given, not only the caller's candidates: those were listed near the
            # start, and a body that moved this far may meet walls that were not among them
            rows = contacts(problem.chain, phi, problem.walls, problem.pieces.pc0, u, dhat, CANDIDATE_STEPS * max_move)
            lst = listing_at(rows, nodes, u, dhat)
            e0 = energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
        else:  # the same pairs at the accepted trial: its energy
            e0 = trial.energy
    return MAX_ITERATIONS, iters, res_m, res_f, entries, False, refreshes


@nb.njit(cache=True, nogil=True)
def segment_forces(problem: Problem, phi: np.ndarray, u: np.ndarray, wide: np.ndarray,
                   fr: Friction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The wall forces on the window at ``phi``: per segment the force (N, m x 2) and its moment about
    the origin (N m, m); and ``(F_tip, fx, fy, gap)``: the reaction against growth and the total force
    on the tip segment (N), and the tip segment's smallest gap to a candidate wall (m).  ``wide``: the
    candidates' contact rows at ``phi`` with a gap below ``dhat + 1`` m."""
    nodes = window_nodes(problem.chain, phi)
    m = phi.shape[0]
    pairs = rows_to_pairs(rows_where(wide, problem.contact.dhat))
    geo = np.empty((pairs.shape[0], GEO_COLUMNS))
    pair_geometry(nodes, pairs, problem, poses(problem.pieces.pc0, u), geo)
    acc = new_accumulators(m, u.shape[0], np.zeros((1, 1)), np.zeros((1, 3, 3)), np.zeros((0, 8)))
    contact_forces(acc, problem, u, nodes, pairs, fr, geo, False)
    tip = acc.tip
    for i in range(wide.shape[0]):  # the tip segment's clearance among the candidates (inf if none)
        if int(wide[i, 0]) == m - 1:
            tip[3] = min(tip[3], wide[i, 10])
    return acc.acc_f, acc.acc_m, tip


@nb.njit(cache=True, nogil=True)
def solve_increment(problem: Problem, phi: np.ndarray, phi_ref: np.ndarray, u: np.ndarray, u_ref: np.ndarray, s_nodes: np.ndarray,
                    robot_mu: np.ndarray, wall_mu: np.ndarray, entries: Entries, settings: SolveSettings) -> SolveResult:
    """One equilibrium of the window with lagged friction (:func:`solve`) and its wall forces.
    Friction resists slip from the configuration before the call, ``phi_ref`` and ``u_ref`` (``phi``
    and ``u`` may hold a predicted start); ``phi`` and ``u`` are updated in place.  ``robot_mu`` per segment and
    ``wall_mu`` per feature: the friction coefficients; ``entries`` the lagged friction at the start.
    The result says whether the normal forces stopped changing (``lag_converged``): a lag cut short
    leaves friction from forces one refresh old, an error of the order of the growth increment."""
    chain = problem.chain
    pc0 = problem.pieces.pc0
    dhat = problem.contact.dhat
    lag = LagSource(window_nodes(chain, phi_ref), u_ref.copy(), s_nodes, robot_mu, wall_mu)
    reach = CANDIDATE_STEPS * settings.max_move + dhat  # candidates for every pair a solve can reach
    wide = contacts(chain, phi, problem.walls, pc0, u, dhat, reach)  # their rows now
    status, iters, res_m, res_f, entries, lag_converged, refreshes = solve(problem, phi, u, entries, lag, settings, wide)
    if drift(window_nodes(chain, phi), lag.start_nodes, u, lag.u0) > WIDE_RELIST_FRACTION * reach:
        wide = contacts(chain, phi, problem.walls, pc0, u, dhat, reach)
    wide = pair_rows(chain, phi, problem.walls, pc0, u, rows_to_pairs(wide), dhat, WIDE_REACH_M)
    acc_f, acc_m, tip = segment_forces(problem, phi, u, wide, _resolved(problem, entries, lag))
    return SolveResult(status, iters, res_m, res_f, entries, acc_f, acc_m, tip, rows_where(wide, dhat), lag_converged, refreshes)
