"""The quasi-static engine: the everted body in static equilibrium at every growth increment.

A real vine robot weighs about 9 g/m and grows at the rate its eversion allows: at every
length its shape is a static equilibrium.  This engine computes exactly that, with no mass,
inertia or damping to tune (``shared/notes/bend-physics.md``, sections 8-9):

* **Kinematics.** The body is the same chain of segments as the dynamic engine's (joint ``j``
  at material coordinate ``j ds``; the tip segment lengthens from ``ds`` to ``2 ds``, then
  splits), described by its joint rotations from the base clamp.  Growth is kinematic: it
  lengthens the tip segment along its heading.
* **Equilibrium.** After every growth increment and every pressure increment (``pressure_increment_fraction``) the joints within
  ``active_length_m`` of the tip (and any held joint that is out of balance, see below), with
  the compliant wall pieces near them, are put in equilibrium by Newton's method on the
  incremental potential of :mod:`evertgym.sim.kernel`: the calibrated joint law (the
  rod-derived stiffness scaled with ``E_eff(p)``, wrinkling at ``p pi r^3 / 2``, the
  tension-field law to the kink plateau), IPC log barriers on every robot-wall capsule gap
  (``barrier_gap_m``), Coulomb friction lagged per increment (the wall's normal force and
  tangent made again from the contacts at the Newton iterates near equilibrium until they stop changing,
  at most ``friction_lag_iterations`` times; a lag cut short is counted, ``friction_lag_unconverged``), sliding beyond
  ``friction_slip_fraction`` of the increment's growth in tangential travel; a contact sticks below ``mu N``) and
  the compliant wall's linear springs and travel stop.  The solve stops on a force criterion:
  every unbalanced joint moment below ``solver_tolerance p pi r^3`` and every unbalanced
  wall-piece force below ``solver_tolerance p pi r^2`` (with ``p`` at least 1 kPa).
* **Held joints.** Joints behind the window keep their angles; after every solve the moment
  each one must carry (from every contact force distal to it) is checked against its own
  moment, and a joint out of balance by more than the tolerance rejoins the solve.  A compliant
  wall piece that the held body touches is held with it.
* **Time** comes from the growth law alone (:mod:`evertgym.sim.growth`): the clock advances
  the regulator and the eversion rate ``v = K_g (p - p_req)`` by ``dt_s``, where ``p_req``
  holds the wall's reaction against growth ``F_tip = -dE/dL`` of the last equilibrium; the
  tip's growth is solved in increments of at most ``growth_increment_m``.  An increment after
  which the tip would need more pressure than it has is cut back (bisection) to the length at
  which the reaction balances the drive: a stall's position does not depend on the increment.

Contact geometry comes from the scene's pymunk shapes: the walls are read once from them
(static segments; the compliant wall's pieces with their outlines) and a bounding-box test
picks the walls near the window at every solve.  Every solve is counted; one that ends above the
tolerance is counted in :attr:`QuasiStaticSim.solve_stats` (``solve_failures``) and reported,
never hidden.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pymunk

from evertgym._blas import one_blas_thread
from evertgym.model.pressure import _END_SLOPE, KINK_MOMENT_FRACTION, wrinkled_moment_fraction
from evertgym.scenes.scene import Scene
from evertgym.sim import kernel as qk
from evertgym.sim.band_laws import axial_share, band_fold_pressure, flattening, fold_excess, hinged_band_near_tip
from evertgym.sim.discretize import RESIDUAL_STIFFNESS_FRACTION
from evertgym.sim.tube import EversionSim

#: Pressure (Pa) below which the solver's force scale stops shrinking (a limp tube).
_P_SCALE_FLOOR = 1000.0
#: Extra reach (m) of the wall query beyond the barrier gap: walls a solve can reach.
_QUERY_MARGIN_M = 0.012
#: Pieces of a compliant wall within this (m) of a segment, beyond the barrier's reach, are unknowns of a solve.
_PIECE_MARGIN_M = 0.003
_NO_ANGLES = np.zeros(0)  # the pieces' rotations' cosines and sines in a scene without pieces
#: Solves for which a window widened by an out-of-balance held joint stays wide.
_REJOIN_MEMORY = 50
#: Chord tolerance (m) of a compliant piece's outline as a contact feature.
_PIECE_OUTLINE_TOLERANCE_M = 1e-4
#: Runs of one solve, each seeing the walls as far as the last one moved a node (:meth:`QuasiStaticSim._solve_window`).
_RESELECTIONS = 4
#: Largest node displacement (m) of one Newton step (keeps the barrier's line search local).
_MAX_MOVE_M = 0.002
#: A solve that did not converge in ``max_newton_iterations`` and cannot be shortened (the shortest
#: growth increment, a cut-back, a pressure change) runs again from its start with this many times
#: the budget.  Near a snap-through the equilibrium lies far away and the step cap above makes Newton
#: walk there: one Colon-v0 episode's solves at the shortest increment needed 300-1000 iterations,
#: and at 60 they ended 0.2-36 p pi r^2 out of balance.
_ESCALATION = 20
#: A growth solve starts from the last solve's change of the joints scaled by the ratio of the two
#: growths (a secant predictor), the ratio at most this.
_PREDICTOR_MAX_SCALE = 2.0
#: Work one :meth:`QuasiStaticSim.step` call may spend, in units of about 13-20 us of one core (measured):
#: a Newton iteration weighs ``1 + m/32`` (``+ (m/40)^3`` on the dense solver) for a window of ``m``
#: unknowns, a solve's own setup :data:`_SOLVE_WORK`.  The budget is :data:`_WORK_MIN` plus
#: :data:`_WORK_PER_S` per simulated second of the call: 250,000 for a 0.1 s env step, 3-5 s of wall time.
#: The defaults stay far below it (Colon-v0's costliest step of 20 operator episodes: 49,700; their
#: answers are bit for bit those from before the budget: scripts/engine_digest.py).  A setting that would
#: spend more (a tolerance the solver cannot reach with a large Newton budget, a tiny growth increment) is
#: cut off there: the solve running when the budget ends, and every later solve of the call (one Newton
#: iteration each, no retries, the pending growth in one increment), ends unconverged and is counted
#: (``solve_failures``, ``solve_budget_cuts``), so no setting can hang a step.
_WORK_MIN = 50_000
_WORK_PER_S = 2_000_000
_SOLVE_WORK = 40
#: A compliant piece's rotation spring (N m/rad) as a multiple of its stiffest translational stiffness times its
#: length squared: the wall model lets a piece translate only, so its rotation is held by a spring far stiffer
#: than its translation, finite to keep the piece's block of the Hessian invertible.
_PIECE_ROTATION_STIFFNESS = 1e3
#: The tether stop (the compliant wall's travel limit) as a multiple of the stiffest piece's own translational
#: stiffness: two orders stiffer, so the stop, not the piece's springs, carries a push past the travel; a
#: numerical stop (a piece's overshoot is reported, not hidden).
_TRAVEL_STOP_STIFFNESS = 100.0
#: Slack (m) of a compliant piece's bounding box beyond its travel: the box is drawn around the piece at rest,
#: and a displaced piece must stay inside it for the wall query to find it.
_PIECE_BOX_MARGIN_M = 0.005
#: Widenings of one solve's window (at most): a held joint found out of balance after a solve rejoins it (the
#: window then starts at the most proximal one) and the window is solved again; a bound on the passes
#: (:meth:`QuasiStaticSim._solve`).
_WIDENINGS = 6
#: Root-finding steps (at most) that cut an increment back to the length where the drive balances the wall.
_BISECTIONS = 10
#: Largest change of the tip's reaction against growth over one increment, as a fraction of p pi r^2.
_FORCE_STEP_FRACTION = 0.05
#: Growth is not solved while the grown tip segment stays more than this many barrier gaps from every
#: wall (no wall force reaches it, so the equilibrium behind it cannot change: _grow_free).
_FREE_GAPS = 2.0
#: ... looked for up to this many segments ahead.
_FREE_SEGMENTS = 4


def _law_table(softening: float = 0.0, n: int = 6000, x_max: float = 1e4) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The joint law past wrinkling in normalised form, ``h(x) = M / M_c`` at ``x = phi / phi_w``
    (the tension-field law, never below the residual stiffness ``0.005 x``), on a uniform grid of
    ``ln x``, with its integral ``H(x) = int_1^x h``; and the slope used beyond ``x_max``.  With
    ``softening`` (candidate (b) of docs/bands.md) the moment falls past its peak (Brazier's ovalisation
    of a bent pressurised tube; Pastrana et al. 2024): from :data:`SOFTENING_ONSET` of ``M_c`` it drops
    by the fraction ``softening`` over :data:`SOFTENING_SPAN` times the onset's curvature."""
    u = np.linspace(0.0, math.log(x_max), n)
    x = np.exp(u)
    floor = 0.5 * RESIDUAL_STIFFNESS_FRACTION
    h = np.asarray(wrinkled_moment_fraction(x), float)
    if softening > 0:
        onset = float(x[np.argmax(h >= SOFTENING_ONSET)])
        t = np.clip(np.log(x / onset) / math.log(SOFTENING_SPAN), 0.0, 1.0)
        h = np.where(x > onset, SOFTENING_ONSET, h) * (1.0 - softening * t * t * (3.0 - 2.0 * t))
    h = np.maximum(h, floor * x)
    hi = np.concatenate(([0.0], np.cumsum(0.5 * (h[1:] + h[:-1]) * np.diff(x))))
    slope = max(1.0 / _END_SLOPE, floor)
    return u, h, hi, slope


#: Candidate (b)'s softening law: the moment's peak, as a fraction of the collapse moment ``M_c`` (the
#: tension-field law reaches it at 3.5 times the wrinkling curvature) ...
SOFTENING_ONSET = 0.8
#: ... and the span of curvature (a factor on the peak's) over which it falls by ``joint_softening``.
SOFTENING_SPAN = 4.0


@functools.cache
def law_table(softening: float) -> qk.LawTable:
    """The kernel's bundle of :func:`_law_table` (built once per ``softening``)."""
    return qk.LawTable(*_law_table(softening), RESIDUAL_STIFFNESS_FRACTION)


@dataclass
class _Walls:
    """Every wall feature of a scene as arrays (SI): its segments, then their distinct end points
    (``vertex`` true; ``a == b``), for IPC's point-edge pairs.  End points ``a``, ``b`` are world
    coordinates for static walls and the piece's frame for compliant ones; ``piece`` (-1 static),
    ``radius`` (of the wall's shape), ``friction``."""

    a: np.ndarray
    b: np.ndarray
    piece: np.ndarray
    vertex: np.ndarray
    radius: np.ndarray
    friction: np.ndarray


def _read_walls(space: pymunk.Space, handles, piece_index: dict) -> _Walls:
    """The walls a scene built into ``space`` as features: its static segments as built, and each
    compliant piece's outline re-simplified at :data:`_PIECE_OUTLINE_TOLERANCE_M` (its shapes are
    drawn at 0.02 mm; the contact barrier acts over a millimetre)."""
    from evertgym.scenes.compliant import WALL_FRICTION
    from evertgym.scenes.geometry import simplify

    rows: list[tuple] = []  # (ax, ay, bx, by, piece, vertex, radius, friction)
    net = getattr(handles, "network", None)
    chains: list[tuple[list[tuple[float, float]], int, float, float]] = []
    for sh in space.shapes:
        body = sh.body
        if isinstance(sh, pymunk.Segment) and body is not None and body.body_type == pymunk.Body.STATIC and piece_index.get(id(body), -1) < 0:
            chains.append(([(sh.a.x, sh.a.y), (sh.b.x, sh.b.y)], -1, sh.radius, sh.friction))
    if net is not None:
        for i, outline in enumerate(net.outline):
            outline_pts = np.asarray(outline, float)
            kept = outline_pts[simplify(outline_pts, _PIECE_OUTLINE_TOLERANCE_M)]
            chains.append(([(float(q[0]), float(q[1])) for q in kept], i, net.shape_radius, WALL_FRICTION))
    vertices: dict[tuple, int] = {}
    for pts, p, rad, mu in chains:
        for a, b in zip(pts[:-1], pts[1:]):
            rows.append((a[0], a[1], b[0], b[1], p, False, rad, mu))
    for pts, p, rad, mu in chains:
        for q in pts:
            key = (p, round(q[0], 9), round(q[1], 9))
            if key not in vertices:
                vertices[key] = len(rows)
                rows.append((q[0], q[1], q[0], q[1], p, True, rad, mu))
    arr = np.array([r[:4] for r in rows], float).reshape(-1, 4)
    return _Walls(arr[:, :2].copy(), arr[:, 2:].copy(), np.array([r[4] for r in rows], np.int64),
                  np.array([r[5] for r in rows], np.bool_), np.array([r[6] for r in rows], float),
                  np.array([r[7] for r in rows], float))


@dataclass
class SolveStats:
    """Counters of the equilibrium solves (reported in ``info`` and trial records)."""

    solves: int = 0
    failures: int = 0
    newton_iterations: int = 0
    max_residual_ratio: float = 0.0
    rejoined: int = 0
    retried: int = 0
    escalated: int = 0
    reselected: int = 0
    budget_cuts: int = 0
    skipped: int = 0
    lag_unconverged: int = 0
    lag_refreshes: int = 0

    def to_dict(self) -> dict:
        return {"solves": self.solves, "solve_failures": self.failures, "newton_iterations": self.newton_iterations,
                "max_residual_ratio": self.max_residual_ratio, "rejoined_joints": self.rejoined,
                "solve_retries": self.retried, "solve_escalations": self.escalated, "solve_reselections": self.reselected,
                "solve_budget_cuts": self.budget_cuts, "solves_skipped": self.skipped,
                "friction_lag_unconverged": self.lag_unconverged, "friction_lag_refreshes": self.lag_refreshes}


class _Snapshot(NamedTuple):
    """The body's state at a growth increment's start (:meth:`QuasiStaticSim._snapshot`), restored if
    the increment is retried shorter or cut back."""

    phi: np.ndarray
    seg_len: np.ndarray
    seg_rad: np.ndarray
    length: float
    u: np.ndarray
    fric: dict
    seg_force: np.ndarray
    seg_moment: np.ndarray
    contact_segs: set
    tip_force: float
    tip_contact: np.ndarray
    tip_clearance: float
    active_start: int


class QuasiStaticSim(EversionSim):
    """The quasi-static engine (the default): a growing eversion robot as a sequence of static equilibria
    (the module's docstring), built by ``EversionSim(design, scene, config)`` with ``config.engine`` left at
    ``"quasistatic"``; the parameters and the interface are :class:`~evertgym.sim.tube.EversionSim`'s.
    """

    engine = "quasistatic"

    def _build_scene(self, scene):
        """The scene's walls in a pymunk space that is never stepped: their shapes are read once
        (:func:`_read_walls`) and the compliant pieces' bodies show the solved displacements; the scene builds
        neither the pieces' springs and tethers nor their scaled masses (``dynamics=False``; an own scene class
        keeps the scenes' protocol, ``build(space)``)."""
        self.space = pymunk.Space()
        if scene is None:
            return None
        if isinstance(scene, Scene):
            return scene.build(self.space, dynamics=False)
        return scene.build(self.space)

    def _build_body(self) -> None:
        cfg, design = self.cfg, self.design
        # walls: arrays for the kernel; the compliant wall's pieces and linear springs
        handles = self.scene_handles
        self._piece_bodies: list[pymunk.Body] = list(getattr(handles, "bodies", []) or [])
        piece_index = {id(b): i for i, b in enumerate(self._piece_bodies)}
        self._walls = _read_walls(self.space, handles, piece_index)
        w = self._walls
        net = getattr(handles, "network", None)
        travel = float(net.mechanics.max_travel_m) if net is not None else 0.0
        ends = [w.a, w.b]
        if len(self._piece_bodies):  # a piece's features in world coordinates at rest
            pos = np.array([tuple(b.position) for b in self._piece_bodies], float)
            moving = w.piece >= 0
            ends = [np.where(moving[:, None], e + pos[np.maximum(w.piece, 0)], e) for e in ends]
        grow = (w.radius + (travel + _PIECE_BOX_MARGIN_M) * (w.piece >= 0))[:, None]  # a piece's box covers its travel
        self._feature_boxes = (np.minimum(*ends) - grow, np.maximum(*ends) + grow)
        # the kernel's bundle of the scene's walls: fixed once built (a solve gathers its window from it)
        self._scene_walls = qk.SceneWalls(qk.Walls(w.a, w.b, w.piece, w.vertex, w.radius), *self._feature_boxes, w.friction)
        n_p = len(self._piece_bodies)
        self._pc0 = np.array([tuple(b.position) for b in self._piece_bodies], float).reshape(-1, 2)
        self._u_all = np.zeros((n_p, 3))
        self._u_shown = np.zeros((n_p, 3))  # the displacements the pymunk bodies show
        self._u_solved = np.zeros((n_p, 3))  # the displacements of the last solve
        # each piece an independent spring that translates: the inverse of its own 2 x 2 translational
        # compliance (its point stiffness with its neighbours and its own rotation free to follow;
        # the coupling between pieces is dropped); its rotation is held (a stiff spring)
        self._k_piece = np.zeros((n_p, 3, 3))
        if net is not None:
            comp = np.asarray(net.compliance_matrix)
            for i in range(n_p):
                k2 = np.linalg.inv(comp[3 * i:3 * i + 2, 3 * i:3 * i + 2])
                self._k_piece[i, :2, :2] = 0.5 * (k2 + k2.T)
                self._k_piece[i, 2, 2] = _PIECE_ROTATION_STIFFNESS * float(np.max(k2)) * net.mechanics.piece_length_m**2
        self._travel = travel
        # the tether stop: stiffer than the stiffest piece's own springs (a numerical stop, reported)
        self._k_travel = _TRAVEL_STOP_STIFFNESS * float(np.max(self._k_piece[:, :2, :2])) if n_p else 0.0

        # the body's state: per segment its joint rotation (joint j against segment j - 1; joint 0
        # against the clamp), length and collision radius
        self.phi = np.zeros(0)  # rad
        self._turn: float | None = None  # sum |phi| (rad), cached until the joints change
        self._excess: float | None = None  # the excess fold angle (rad), cached with it
        self._band_turn: list[float] | None = None  # per band: the turning (rad) from the base to it, cached with it
        # the last required pressure: (tip force N, length m, the turning it read, p_req Pa)
        self._req_key: tuple[float, float, float, float] | None = None
        self.seg_len = np.zeros(0)  # m
        self.seg_rad = np.zeros(0)  # m
        self._start_chain(cfg.initial_length_m)

        # the growth and the solves (the clock, outputs and events are EversionSim's)
        self._pending = 0.0
        self._p_solved = -1.0
        # the tip's required pressure (Pa) just past where the last growth attempt stopped short (0: it
        # did not; inf: any further growth overlaps a wall): the material about to evert needs it
        self._req_ahead = 0.0
        self._stats = SolveStats()
        self._retry_ok = self._retry_wanted = False  # set around a growth increment's solve (_advance)
        self._work_left = float(_WORK_MIN)  # work the current step may still spend (_step sets it)
        # the lagged friction entries, arrays: ``s`` the robot point's material coordinate (m; -1 for the
        # tip's cap, which is always the newest material), ``wall`` its wall feature, ``wl`` the wall
        # point in the wall's frame, ``t`` the tangent, ``ml`` mu times the lagged normal force (N)
        self._fric = {"s": np.zeros(0), "wall": np.zeros(0, np.int64), "wl": np.zeros((0, 2)), "t": np.zeros((0, 2)), "ml": np.zeros(0)}
        self._seg_force = np.zeros((0, 2))  # per segment: sum of wall forces (N), sum of p x f (N m)
        self._seg_moment = np.zeros(0)
        self._contact_segs: set[int] = set()
        self._tip_clearance = math.inf
        self._free_until = -1.0  # the length (m) up to which the tip grows without a solve (-1: not known)
        self._grown = 0.0  # growth (m) the next solve follows (0: a solve in place), for its friction slip
        # the last committed solve's change of every joint's rotation (rad), of every wall piece's displacement
        # (m, m, rad), and its growth (m): the predictor
        self._last_change: tuple[np.ndarray, np.ndarray, float] | None = None
        self._rejoin: tuple[int, int] | None = None  # (joint, solves since) of the last widening
        # barrier stiffness: 0.1 x the largest drive (8 kPa pi r^2) per barrier gap (N/m)
        self._kappa = qk.barrier_stiffness(design.radius_m, cfg.barrier_gap_m)
        self._flat = np.zeros(len(self.nodes))  # per joint: the cross-section's flattening f (band_laws.flattening)
        self._joint_law = law_table(self.cfg.joint_softening)  # the joints' law (candidate (b): softening past the peak)
        self._tip_mu = cfg.tip_friction  # the tip's friction coefficient now (band_hinge_relief lowers it)
        # per band: the joints inside its strip and its centre (m), for the band-hinge law
        self._band_joints = [np.nonzero(np.abs(self.nodes - b.position_m) <= 0.5 * b.width_m + 0.5 * self.ds)[0]
                             for b in design.bands]
        self._band_centres = np.array([b.position_m for b in design.bands], float)
        self._band_ends = [b.position_m + 0.5 * b.width_m for b in design.bands]  # (m) where each band is wholly everted
        self._band_first_joints = [int((b.position_m - 0.5 * b.width_m) / self.ds) for b in design.bands]  # each band's first joint
        self._moments = np.zeros(0)  # the joints' moments (N m) last published
        self._seg_r0: dict[int, float] = {}  # per full segment: its radius unflattened (m)
        self._apply_pressure(0.0)
        with one_blas_thread():
            self._solve()
        self._publish()
        self._show_pieces()

    # ---- construction -----------------------------------------------------------
    def _start_chain(self, length: float) -> None:
        n = max(1, int(math.floor(length / self.ds + 1e-9)))
        lens = [self.ds if j < n - 1 else length - (n - 1) * self.ds for j in range(n)]
        self.phi = np.zeros(n)
        self._turn = None
        self.seg_len = np.array(lens)
        self.seg_rad = np.array([self._radius_between(self.nodes[j], self.nodes[j] + lens[j]) for j in range(n)])
        self.length = length

    # ---- the joint law at the applied pressure -----------------------------------
    def _apply_pressure(self, p: float) -> None:
        """Joint stiffness (N m/rad) and wrinkling moments (N m) of every node at pressure ``p`` (Pa)."""
        scale = self._law.effective_modulus(max(p, 0.0)) / self._e_ref * self.cfg.stiffness_factor
        self._k_all = scale / self._c_ref
        self._p_applied = p
        self._mw_all = self._wrinkling_moments()

    def _wrinkling_moments(self) -> np.ndarray:
        """Wrinkling moment (N m) of every node at the applied pressure, ``p pi r^3 / 2``, less the cross-section's
        flattening (``flattening``) and times the wall's share left by the axial load (``axial_load``)."""
        mw = 0.5 * max(self._p_applied, 0.0) * math.pi * self._r3
        if self.cfg.flattening > 0:
            mw = mw * (1.0 - self._flat)
        if self.cfg.axial_load:
            mw = mw * self._axial_factors()
        return mw

    def _axial_factors(self) -> np.ndarray:
        """Per node, the share of the wall's tension left after the axial load, ``1 - N / (p pi r(s)^2)``
        (floored at 5%; :func:`~evertgym.sim.band_laws.axial_share`): ``N`` the tip's push against the wall
        (the last equilibrium's) and the tail's tension, the bare threshold's force times the capstan loss
        of the body's turning."""
        tail = self._bare_threshold[0] * self._bare_threshold[1] * math.exp(self.cfg.bend_loss_per_rad * self._turning())
        return axial_share(max(self.tip_force, 0.0) + tail, max(self._p_applied, 0.0), self._r_cell)

    def _scales(self) -> tuple[float, float]:
        """Force (N) and moment (N m) scales of the convergence test: ``p pi r^2`` and ``p pi r^3``."""
        r = self.design.radius_m
        f = max(self._p_applied, _P_SCALE_FLOOR) * math.pi * r * r
        return f, f * r

    # ---- geometry ------------------------------------------------------------------
    def _all_nodes(self) -> tuple[np.ndarray, np.ndarray]:
        return qk.chain_nodes(self.base_angle, self.base, self.phi, self.seg_len)

    def centreline(self) -> np.ndarray:
        """Node positions from the base to the tip (m), (n+1) x 2."""
        return self._all_nodes()[0]

    def radii(self) -> np.ndarray:
        """Collision radius of each segment (m)."""
        return self.seg_rad.copy()

    @property
    def tip_position(self) -> np.ndarray:
        return self._all_nodes()[0][-1].copy()

    @property
    def tip_angle(self) -> float:
        """Heading of the tip segment (rad)."""
        return self.base_angle + float(np.sum(self.phi))

    def joint_angles(self, start: int = 0) -> np.ndarray:
        return self.phi[start:].copy()

    def joint_moments(self, start: int = 0) -> np.ndarray:
        """Joint moments (N m) of joints ``start..`` from the law at the current angles."""
        n = len(self.phi)
        return qk.joint_moments(self.phi[start:], qk.Joints(self._k_all[start:n], self._mw_all[start:n]), self._joint_law)

    def collapse_moments(self, start: int = 0) -> np.ndarray:
        return 2.0 * self._mw_all[start : len(self.phi)]

    @property
    def wall_tension(self) -> np.ndarray:
        """``p pi r^2`` (N) of the joints from ``active_start`` (this engine's moments assume no axial load)."""
        return max(self._p_applied, 0.0) * math.pi * self._r_cell[self.active_start : len(self.phi)] ** 2

    @property
    def compression_capacity(self) -> np.ndarray:
        return np.full(len(self.phi) - self.active_start, math.inf)

    @property
    def tip_capacity(self) -> float:
        return math.inf

    def segments_in_contact(self) -> list[int]:
        """Segments that touch a wall (a gap within the barrier's reach) at the last solve."""
        return sorted(self._contact_segs)

    @property
    def solve_stats(self) -> dict:
        """Counts of the equilibrium solves: ``solves``, ``solve_failures`` (ended above the
        tolerance), ``newton_iterations``, ``max_residual_ratio`` (largest final residual over the
        tolerance's scale), ``rejoined_joints``, ``solve_retries`` (growth increments whose solve
        did not converge and were retried at half the length; not failures), ``solve_escalations``
        (solves that could not be shortened, a shortest increment, a cut-back or a pressure
        change, and were run again from their start with :data:`_ESCALATION` times the Newton
        budget), ``solve_budget_cuts`` (solves ended by the step's work budget, :data:`_WORK_PER_S`;
        each is also a failure), ``solves_skipped`` (growth of at most a segment that no wall
        reached, not solved: :meth:`_free_ahead`), ``friction_lag_unconverged`` (committed solves whose
        normal forces were still changing after ``friction_lag_iterations`` refreshes) and
        ``friction_lag_refreshes`` (how many times the solves made the lagged normal forces and tangents
        again)."""
        return self._stats.to_dict()

    # ---- pressure, growth, clock -----------------------------------------------------
    def _turning(self) -> float:
        """Total turning of the body, ``sum |phi|`` (rad): the bend loss's angle."""
        if self._turn is None:
            self._turn = float(np.add.reduce(np.abs(self.phi)))  # np.sum's own reduction, without its dispatch
            self._excess = None
            self._band_turn = None
        return self._turn

    def _required(self, tip_force: float) -> float:
        """Pressure (Pa) the tip needs against the wall's reaction ``tip_force`` (N): the growth law
        (:mod:`evertgym.sim.growth`) with the band-mechanism laws switched on in ``cfg``
        (:mod:`evertgym.sim.band_laws`)."""
        key = self._req_key
        if key is not None and key[0] == tip_force and key[1] == self.length and key[2] is self._turn:
            return key[3]  # nothing it reads has changed since (the clock asks at every step)
        cfg = self.cfg
        p_y, area, tail = self._tip_terms()
        turn = self._turning()
        req = self.growth.required_pressure(p_y, tip_force, area, turn, tail, None)
        if cfg.fold_pinch_per_rad > 0:
            req *= math.exp(cfg.fold_pinch_per_rad * self._fold_excess())
        for r_b, t_band in self._folding_bands():
            req = max(req, band_fold_pressure(tip_force, t_band, r_b))
        self._req_key = (tip_force, self.length, turn, req)
        return req

    def _tip_terms(self) -> tuple[float, float, float]:
        """The growth law's tip terms: the threshold (Pa) and area (m^2) of the material at the tip
        (the bare material's without ``band_eversion_threshold``), and the tail's weight (Pa)."""
        p_y, area = self._tip_threshold() if self.cfg.band_eversion_threshold else self._bare_threshold
        return p_y, area, self._tail_weight()

    def _folding_bands(self) -> list[tuple[float, float]]:
        """With ``band_fold``: each wholly everted band's radius (m) and the tail's tension at it (N),
        the bare threshold's force times the capstan loss of the turning from the base to the band
        (:mod:`evertgym.sim.band_laws`); none without it."""
        if not self.cfg.band_fold:
            return []
        self._turning()
        if self._band_turn is None:
            turns = np.abs(self.phi)
            self._band_turn = [float(np.add.reduce(turns[:k])) for k in self._band_first_joints]  # (np.sum's reduction)
        tail_base = self._bare_threshold[0] * self._bare_threshold[1]
        mu_b = self.cfg.bend_loss_per_rad
        return [(self.design.radius_m * (1.0 - b.reduction), tail_base * math.exp(mu_b * turn))
                for b, turn, end in zip(self.design.bands, self._band_turn, self._band_ends) if end <= self.length]

    @property
    def push_capacity(self) -> float:
        """The wall reaction against growth (N) at which the tip stops growing at the present
        pressure: the growth law's drive, and with ``band_fold`` the push an everted band passes on
        before it goes slack (the smaller); 0 when the pressure cannot evert the tip at all."""
        cfg = self.cfg
        p = max(self.pressure, 0.0)
        p_y, area, tail = self._tip_terms()
        loss = math.exp(cfg.bend_loss_per_rad * self._turning() + cfg.fold_pinch_per_rad * self._fold_excess())
        cap = (p / loss - p_y - tail) * area
        for r_b, t_band in self._folding_bands():
            cap = min(cap, p * math.pi * r_b * r_b - t_band)
        return max(cap, 0.0)

    @property
    def fold_excess_rad(self) -> float:
        """The body's excess fold angle now (rad, :func:`~evertgym.sim.band_laws.fold_excess`)."""
        return self._fold_excess()

    def _fold_excess(self) -> float:
        """The excess fold angle, cached with the turning until the joints change."""
        self._turning()
        if self._excess is None:
            self._excess = fold_excess(self.phi, self.seg_len, self._r_cell[: len(self.phi)])
        return self._excess

    def required_pressure(self) -> float:
        """Pressure (Pa) the tip needs to grow now (threshold, bend loss, the wall's reaction)."""
        return self._required(self.tip_force)

    def step(self, n_steps: int = 1) -> None:
        """Advance the clock by ``n_steps`` steps of ``cfg.dt_s``: the regulator and the growth law
        advance every step; the body is re-solved whenever the tip has grown by the increment or the
        pressure has moved by ``cfg.pressure_increment_fraction`` since the last solve (of that pressure,
        at least 1 kPa), and once more when the pressure has settled within a tenth of that of its
        command: a held pressure is solved to within a tenth of the increment.  Growth that no wall
        reaches is not solved (:meth:`_free_ahead`), nor is a pressure change while no wall acts on the
        body.  Nothing depends on how the steps are split into calls.

        A Ctrl-C (SIGINT) whose handler runs inside a compiled solve (numba calls back into Python to
        build the exceptions it raises and catches) surfaces, when the solve returns, as a chain of
        ``SystemError`` caused by the ``KeyboardInterrupt``: it is raised here as the interrupt it is,
        so that a resumable command stops and says how to resume.  The solves run with one BLAS
        thread (:mod:`evertgym._blas`): the answers do not depend on the cores."""
        try:
            with one_blas_thread():
                self._step(n_steps)
        except SystemError as e:
            cause: BaseException | None = e
            while cause is not None and not isinstance(cause, KeyboardInterrupt):
                cause = cause.__cause__
            if cause is not None:
                raise KeyboardInterrupt from None
            raise

    def _step(self, n_steps: int) -> None:
        cfg = self.cfg
        dt = cfg.dt_s
        self._work_left = _WORK_MIN + _WORK_PER_S * n_steps * dt
        p_sum, f_max = 0.0, 0.0
        for _ in range(n_steps):
            p = self.regulator.advance(dt)
            p_sum += p
            self.peak_pressure = max(self.peak_pressure, p)
            v = 0.0
            if self.length < self.design.length_m:  # as fast as the material about to evert allows
                v = self.growth.speed(p, max(self._required(self.tip_force), self._req_ahead))
            self._pending = min(self._pending + v * dt, self.design.length_m - self.length)
            # re-solve after a pressure increment; and once the regulator has (nearly) reached its
            # command, at the pressure it settles at (a plateau is solved within a tenth of the increment)
            step_pa = cfg.pressure_increment_fraction * max(self._p_solved, _P_SCALE_FLOOR)
            off = abs(p - self._p_solved)
            moved = off > step_pa or (off > 0.1 * step_pa and abs(self.regulator.command - p) <= 0.1 * step_pa)
            walls_act = bool(self._contact_segs) or self._req_ahead > 0
            if self._pending >= self._increment() or (moved and (walls_act or self._pending > 0)) or (
                    self._pending > 0 and self.length + self._pending >= self.design.length_m - 1e-12):
                # grow the pending length: without a solve if no wall can reach the tip and the pressure
                # moves nothing (_free_ahead), else in solved increments
                if (moved and walls_act) or not 0 < self._pending <= self._free_ahead() or not self._grow_free(p, self._pending):
                    self._advance(p)
                elif moved:
                    self._apply_pressure(p)
                    self._p_solved = p
            elif moved:
                self._apply_pressure(p)
                self._p_solved = p
            self.t += dt
            self.steps += 1
            self.growth_speed = v
            self._stall_update(v, dt)
            f_max = max(f_max, self._tip_force_norm)
        self._step_mean_pressure = p_sum / n_steps if n_steps > 0 else self.pressure
        self._step_max_contact = f_max
        self._show_pieces()

    def _show_pieces(self) -> None:
        """The scene's pymunk pieces (those that moved) take the displacements of the last solve
        (nothing reads them during a step: once per step, not once per solve)."""
        for i in np.nonzero(np.any(self._u_solved != self._u_shown, axis=1))[0]:
            pc, uu = self._pc0[i], self._u_solved[i]
            self._piece_bodies[i].position = (pc[0] + uu[0], pc[1] + uu[1])
            self._piece_bodies[i].angle = float(uu[2])
        self._u_shown[:] = self._u_solved

    def _increment(self) -> float:
        """Growth increment (m): ``growth_increment_m`` near a wall, up to a segment in free space
        (no wall within a segment of the tip)."""
        inc = self.cfg.growth_increment_m
        if self._tip_clearance > self.ds + self.cfg.barrier_gap_m:
            return max(inc, min(self.ds, 0.5 * (self._tip_clearance - self.cfg.barrier_gap_m)))
        return inc

    # ---- one growth increment ----------------------------------------------------------
    def _snapshot(self) -> _Snapshot:
        return _Snapshot(self.phi.copy(), self.seg_len.copy(), self.seg_rad.copy(), self.length, self._u_all.copy(), dict(self._fric),
                self._seg_force.copy(), self._seg_moment.copy(), set(self._contact_segs), self.tip_force, self.tip_contact.copy(),
                self._tip_clearance, self.active_start)

    def _restore(self, snap: _Snapshot) -> None:
        (phi, seg_len, seg_rad, self.length, u, fric, seg_force, seg_moment, contact_segs, self.tip_force,
         tip_contact, self._tip_clearance, self.active_start) = snap
        self.phi, self.seg_len, self.seg_rad, self._fric = phi.copy(), seg_len.copy(), seg_rad.copy(), dict(fric)
        self._turn = None
        self._u_all = u.copy()
        self._seg_force, self._seg_moment, self._contact_segs = seg_force.copy(), seg_moment.copy(), set(contact_segs)
        self.tip_contact = tip_contact.copy()
        self._free_until = -1.0

    def _advance(self, p: float) -> None:
        """Grow by the pending length at pressure ``p`` in increments of at most
        ``growth_increment_m``, each solved to equilibrium.  An increment across which the wall's
        reaction against growth changes by more than :data:`_FORCE_STEP_FRACTION` of ``p pi r^2``
        is halved (down to 1/64 of the increment), so that a narrow rise of the reaction is seen
        whatever the increment, and so is one whose straight extension would overlap a wall (the
        body then bends away in smaller steps, as IPC's continuous collision step would).  An
        increment after which the tip needs more pressure than ``p`` is cut back to the length where
        the two meet (:meth:`_cut_back`), and growth stops there."""
        self._apply_pressure(p)
        self._p_solved = p
        self._req_ahead = 0.0
        remaining = self._pending
        self._pending = 0.0
        if remaining <= 0:
            self._solve_in_place()
            self._publish()
            return
        f_step = _FORCE_STEP_FRACTION * self._scales()[0]
        dl_max = self._increment()
        dl_min = self.cfg.growth_increment_m / 64.0
        dl = dl_max
        cut = False
        while remaining > 1e-12:
            dl = min(dl, remaining) if self._work_left > 0 else remaining  # (the budget is spent: the rest at once)
            start = self._snapshot()
            f0 = self.tip_force
            self._retry_ok, self._retry_wanted = dl > dl_min and self._work_left > 0, False
            ok = self._grow(dl) and self._solve()
            self._retry_ok = False
            # a wall ahead, or an increment whose equilibrium did not converge: smaller steps
            if dl > dl_min and self._work_left > 0 and (not ok or self._retry_wanted or abs(self.tip_force - f0) > f_step):
                self._restore(start)
                dl = max(0.5 * dl, dl_min)
                continue
            if ok and self._required(self.tip_force) <= p * (1 + 1e-9):
                remaining -= dl
                dl = min(2.0 * dl, dl_max)
                self._publish()
                continue
            self._cut_back(start, dl, p, self._required(self.tip_force) if ok else math.inf)
            cut = True
            break
        if cut or self.cfg.flattening > 0:  # (else the state was published as it stands: publishing is idempotent)
            self._publish()

    def _free_ahead(self) -> float:
        """How far (m) the tip can grow without a solve: growth that cannot change the equilibrium, the
        grown tip segment straight ahead of its base node staying more than :data:`_FREE_GAPS` barrier
        gaps from every wall (no wall force on it before or after, and nothing else moves).  0 while a
        wall touches the tip.  Found for :data:`_FREE_SEGMENTS` segments ahead, one, or an increment,
        and kept until a solve or a restore changes the body."""
        if self._free_until < 0:
            self._free_until = self.length
            if (len(self.seg_len) - 1) not in self._contact_segs and self.tip_force <= 0:
                for dl in (_FREE_SEGMENTS * self.ds, self.ds, self.cfg.growth_increment_m):
                    if self._gap_ahead(dl) > _FREE_GAPS * self.cfg.barrier_gap_m:
                        self._free_until = self.length + dl
                        break
        return max(0.0, self._free_until - self.length)

    def _grow_free(self, p: float, length: float) -> bool:
        """Grow by ``length`` (m, at most :meth:`_free_ahead`) without a solve, if the tip's required
        pressure stays within ``p`` (else nothing changes and it returns False: a band's threshold
        reached the tip, and the growth is solved, to cut it back where the two meet).  The pressure of
        the last solve is kept (a pressure that moves is solved by :meth:`_step`).  Counted in
        ``solves_skipped``."""
        start = None
        if self._required_may_change(self.length, self.length + length):
            start = self._snapshot()
        elif self._required(0.0) > p * (1 + 1e-9):  # (the same before and after this growth)
            return False
        grown, chunks = 0.0, 0
        while grown < length - 1e-12:  # (at most a segment at a time: _grow splits once)
            dl = min(self.ds, length - grown)
            self._grow(dl)
            grown += dl
            chunks += 1
        if start is not None and self._required(0.0) > p * (1 + 1e-9):  # a band reached the tip: grow with solves
            self._restore(start)
            return False
        self._stats.skipped += chunks
        self._pending -= length
        self._req_ahead = 0.0
        self._tip_clearance = self._gap_ahead(0.0)  # (the increment near a wall reads it: _increment)
        self._publish_growth()
        return True

    def _required_may_change(self, a: float, b: float) -> bool:
        """Whether the tip's required pressure with no wall force may differ between lengths ``a`` and ``b``
        (m): a band's strip or the end of one lies between them, or the tail's weight or the fold's pinch counts."""
        return (self.vertical_tail or self.cfg.fold_pinch_per_rad > 0 or any(lo <= b and hi >= a for lo, hi in self._band_zones)
                or any(a < end <= b for end in self._band_ends))

    def _publish_growth(self) -> None:
        """:meth:`_publish` after growth that moved nothing: the joints, the wall forces and the tip's contact
        are those published last, so only what reads the length is updated (the band events and the band
        hinge's reach; a new joint carries no moment).  With flattening or the axial load, all of it."""
        if self.cfg.flattening > 0 or self.cfg.axial_load:
            self._publish()
            return
        self._band_events()
        n = len(self.phi)
        moments = self._moments[:n]
        self._update_tip_mu(np.concatenate([moments, np.zeros(n - len(moments))]))  # (a new joint carries no moment)

    def _update_tip_mu(self, moments: np.ndarray) -> None:
        """The tip's friction coefficient for the next solve: lowered by ``band_hinge_relief`` while a wrinkled band
        lies within ``band_hinge_reach_m`` behind the tip (``moments``: the joints' moments, N m)."""
        if self.cfg.band_hinge_relief > 0:
            hinged = hinged_band_near_tip(moments, self._mw_all[:len(moments)], self._band_joints, self._band_centres, self.length,
                                          self.cfg.band_hinge_reach_m)
            self._tip_mu = self.cfg.tip_friction * (1.0 - self.cfg.band_hinge_relief) if hinged else self.cfg.tip_friction

    def _gap_ahead(self, dl: float) -> float:
        """Smallest gap (m) between the walls and the tip segment grown straight by ``dl`` (m), at the
        larger of its radius and the tube's; inf if no wall is within a segment of it."""
        j = len(self.seg_len) - 1
        nodes, theta = self._all_nodes()
        reach = self.seg_len[j] + dl
        seg = np.array([nodes[j], nodes[j] + reach * np.array([math.cos(theta[j]), math.sin(theta[j])])])
        rad = max(float(self.seg_rad[j]), self.design.radius_m)
        sel = self._query_walls(seg, rad + self.ds)
        w = self._walls
        return qk.segment_gap(seg, 0, rad, sel, qk.Walls(w.a, w.b, w.piece, w.vertex, w.radius), self._pc0, self._u_all)

    def _cut_back(self, start: _Snapshot, dl: float, p: float, req_end: float) -> None:
        """Find, from state ``start``, the growth in ``(0, dl)`` at which the tip's required pressure
        meets ``p`` (regula falsi, Illinois variant, on ``p_req(L) - p``; a length whose solve
        overlaps a wall counts as too far) and leave the body there: within ``dl / 128`` of it or
        with ``|p_req - p|`` below 0.2% of ``p``.  ``req_end``: the required pressure at ``dl``
        (inf if it overlaps).  The required pressure at the shortest length found too far is kept
        (``_req_ahead``): where it jumps (a band's eversion threshold at the tip) the tip stands at
        the jump, and the growth law reads that pressure, not the lower one behind it."""
        lo, hi = 0.0, dl
        g_lo = self._required(start.tip_force) - p
        g_hi = math.inf
        req_hi = req_end
        best, side = None, 0
        for _ in range(_BISECTIONS):
            if math.isfinite(g_hi) and g_hi > g_lo:
                mid = lo + (hi - lo) * (-g_lo) / (g_hi - g_lo)
                mid = min(max(mid, lo + 0.05 * (hi - lo)), hi - 0.05 * (hi - lo))
            else:
                mid = 0.5 * (lo + hi)
            self._restore(start)
            ok = self._grow(mid) and self._solve()
            g = self._required(self.tip_force) - p if ok else math.inf
            if g <= 0:
                lo, g_lo, best = mid, g, self._snapshot()
                if side == -1 and math.isfinite(g_hi):
                    g_hi *= 0.5  # Illinois: the end that stays put is halved
                side = -1
                if -g <= 2e-3 * p:
                    break
            else:
                hi, g_hi, req_hi = mid, g, g + p
                if side == 1:
                    g_lo *= 0.5
                side = 1
            if hi - lo <= dl / 128.0:
                break
        if best is None:
            self._restore(start)
            self._solve_in_place()
        else:
            self._restore(best)
        self._req_ahead = req_hi

    def _friction_slip(self) -> float:
        """The tangential travel (m) past which a contact slides in the next solve (IPC's ``eps_v h``):
        ``friction_slip_fraction`` of the growth the solve follows (of ``growth_increment_m`` for a solve
        in place), so that static friction's creep per metre of growth does not depend on the
        increment; ``friction_slip_m`` instead if it is set."""
        cfg = self.cfg
        if cfg.friction_slip_m is not None:
            return cfg.friction_slip_m
        return cfg.friction_slip_fraction * (self._grown if self._grown > 0 else cfg.growth_increment_m)

    def _solve_in_place(self) -> None:
        """Solve the body where it stands (a pressure change, a cut-back to an increment's start).
        A state that overlaps a wall cannot be solved: each such solve is counted as failed and
        recorded as a ``solve_failed`` event (status ``INFEASIBLE_START``), never skipped silently."""
        self._grown = 0.0
        if not self._solve():
            self._count_failed(qk.INFEASIBLE_START)

    def _count_failed(self, status: int, **detail) -> None:
        """A solve that could not be made (nothing committed): counted as failed, a ``solve_failed`` event."""
        self._stats.solves += 1
        self._stats.failures += 1
        self._event("solve_failed", status=int(status), residual=math.inf, **detail)

    def _grow(self, dl: float) -> bool:
        """Lengthen the tip segment by ``dl`` (m), splitting it past two segments; the tip's radius
        follows its newest material, widening at most halfway into its clearance.  False if the
        grown tip would overlap a wall."""
        ds = self.ds
        self._grown = min(dl, self.design.length_m - self.length)
        self.length = min(self.length + dl, self.design.length_m)
        j = len(self.seg_len) - 1
        seg = self.length - self.nodes[j]
        if seg >= 2 * ds - 1e-12 and j + 1 < len(self.nodes):
            self.seg_len[j] = ds
            self.seg_rad[j] = min(self._radius_between(self.nodes[j], self.nodes[j] + ds), self.seg_rad[j])
            self.phi = np.append(self.phi, 0.0)
            self._turn = None
            self.seg_len = np.append(self.seg_len, seg - ds)
            self.seg_rad = np.append(self.seg_rad, self.seg_rad[j])
            self._seg_force = np.vstack([self._seg_force, np.zeros((1, 2))])
            self._seg_moment = np.append(self._seg_moment, 0.0)
            j += 1
        else:
            self.seg_len[j] = seg
        if self._near_band(self.length) or self.seg_rad[j] != self._radius_between(self.nodes[j], self.length):
            target = self._radius_between(max(self.nodes[j], self.length - ds), self.length)
            if target > self.seg_rad[j]:
                gap = self._segment_gap(j)
                self.seg_rad[j] = min(target, self.seg_rad[j] + max(0.0, 0.5 * gap)) if math.isfinite(gap) else target
            else:
                self.seg_rad[j] = target
        return True  # an overlap is found by the solve (its start is then infeasible)

    def _flatten(self) -> None:
        """Cross-section flattening (``cfg.flattening``, :func:`~evertgym.sim.band_laws.flattening`) of
        the window's joints from the accepted state, for the next solve: their collapse moments and the
        collision radii of their full segments (a radius that grows back does so at most halfway into
        its clearance, as the tip's does)."""
        n, a = len(self.phi), self.active_start
        mw0 = 0.5 * max(self._p_applied, 0.0) * math.pi * self._r3[a:n]
        f = flattening(self.phi[a:], self._k_all[a:n], mw0, self._r_cell[a:n], self.design.radius_m, self.cfg.flattening)
        self._flat[a:n] = f
        self._mw_all[a:n] = mw0 * (1.0 - f)
        for k in range(a, n - 1):
            r0 = self._seg_r0.get(k)
            if r0 is None:
                r0 = self._seg_r0[k] = self._radius_between(self.nodes[k], self.nodes[k] + self.ds)
            target = r0 * (1.0 - max(f[k - a], f[k + 1 - a]))
            if target < self.seg_rad[k]:
                self.seg_rad[k] = target
            elif target > self.seg_rad[k]:
                gap = self._segment_gap(k)
                self.seg_rad[k] = min(target, self.seg_rad[k] + max(0.0, 0.5 * gap)) if math.isfinite(gap) else target

    def _publish(self) -> None:
        """Outputs and events after an accepted state."""
        if self.cfg.flattening > 0:
            self._flatten()
        if self.cfg.axial_load:  # the tip's push of the accepted state, for the next solve
            self._mw_all = self._wrinkling_moments()
        tc = self.tip_contact
        mag = float(math.hypot(tc[0], tc[1]))
        self._contact_update(mag, (len(self.seg_len) - 1) in self._contact_segs)
        self._band_events()
        n = len(self.phi)
        moments, kinked = qk.kinked_joints(self.phi, qk.Joints(self._k_all[:n], self._mw_all[:n]), self._joint_law, KINK_MOMENT_FRACTION)
        self._moments = moments
        self._kink_events(kinked, moments, 2.0 * self._mw_all[:n])
        self._update_tip_mu(moments)

    # ---- geometry queries ---------------------------------------------------------------------
    def _query_walls(self, pts: np.ndarray, reach: float) -> np.ndarray:
        """Indices of the wall features whose boxes come within ``reach`` (m) of ``pts``' box: the
        pymunk shapes' boxes at rest, grown by the compliant wall's travel (a compiled box test,
        cheaper than pymunk's callback per shape)."""
        if not len(self._walls.a):
            return np.zeros(0, np.int64)
        lo = pts.min(axis=0) - reach
        hi = pts.max(axis=0) + reach
        return qk.boxes_near(*self._feature_boxes, lo, hi)

    def _segment_gap(self, k: int) -> float:
        """Smallest gap (m) between segment ``k`` and a wall within a segment's length of it."""
        nodes, _ = self._all_nodes()
        sel = self._query_walls(nodes[k:k + 2], self.seg_rad[k] + self.ds)
        w = self._walls
        return qk.segment_gap(nodes, k, float(self.seg_rad[k]), sel, qk.Walls(w.a, w.b, w.piece, w.vertex, w.radius), self._pc0, self._u_all)

    # ---- the equilibrium solve ------------------------------------------------------------
    def _window_start(self) -> int:
        """The joints within ``active_length_m`` of the tip, widened to the most proximal joint that a
        recent solve had to take back (a free span behind the window stays in for
        :data:`_REJOIN_MEMORY` solves after it was last needed)."""
        n = len(self.phi)
        nominal = max(0, n - max(2, int(math.ceil(self.cfg.active_length_m / self.ds))))
        if self._rejoin is None:
            return nominal
        start, age = self._rejoin
        if age >= _REJOIN_MEMORY:
            self._rejoin = None
            return nominal
        self._rejoin = (start, age + 1)
        return min(nominal, start)

    def _solve(self) -> bool:
        """Put the window, and any held joint out of balance, in equilibrium; False if the
        configuration overlaps a wall (the increment is then cut back).  Counts every solve."""
        f_ref, m_ref = self._scales()
        tol_m, tol_f = self.cfg.solver_tolerance * m_ref, self.cfg.solver_tolerance * f_ref
        a = self._window_start()
        for _ in range(_WIDENINGS):  # a held joint out of balance widens the window
            if not self._solve_window(a, tol_m, tol_f):
                return False
            if self._retry_wanted:
                return True
            worst = self._held_imbalance(a, tol_m)
            if worst is None:
                break
            self._stats.rejoined += a - worst
            a = worst
            self._rejoin = (a, 0)
        self.active_start = a
        return True

    def _held_imbalance(self, a: int, tol_m: float) -> int | None:
        """The most proximal held joint (< ``a``) whose moment differs from the moment of the wall
        forces distal to it by more than ``tol_m``; None if all balance."""
        if a == 0:
            return None
        nodes, _ = self._all_nodes()
        sf = np.cumsum(self._seg_force[::-1], axis=0)[::-1]
        sm = np.cumsum(self._seg_moment[::-1])[::-1]
        ext = sm[:a] - (nodes[:a, 0] * sf[:a, 1] - nodes[:a, 1] * sf[:a, 0])
        own = qk.joint_moments(self.phi[:a], qk.Joints(self._k_all[:a], self._mw_all[:a]), self._joint_law)
        bad = np.nonzero(np.abs(own - ext) > tol_m)[0]
        return int(bad[0]) if len(bad) else None

    def _solve_window(self, a: int, tol_m: float, tol_f: float) -> bool:
        """Solve joints ``a..`` with the compliant wall pieces near them; commit the result.  False
        (nothing committed) if the configuration overlaps a wall.

        A solve sees the walls within ``_QUERY_MARGIN_M`` of the window; one that moved a node
        farther (a snap-through) could have passed walls it did not see, so it runs again from its
        start seeing as far as it went (``solve_reselections``).  If after :data:`_RESELECTIONS`
        such runs it still goes farther than it sees, nothing is committed and the solve counts as
        failed (a ``solve_failed`` event): a committed state never overlaps a wall."""
        margin = _QUERY_MARGIN_M
        for _ in range(_RESELECTIONS):
            out = self._solve_window_at(a, tol_m, tol_f, margin)
            if isinstance(out, bool):
                return out
            self._stats.reselected += 1
            margin = out + _QUERY_MARGIN_M
        self._count_failed(qk.LINE_SEARCH_FAILED, reach_mm=round(1e3 * out, 3))
        return False

    def _predict(self, phi: np.ndarray, u: np.ndarray, a: int, pieces: np.ndarray) -> bool:
        """Move ``phi``, the window's joints from ``a``, and ``u``, its wall pieces' displacements
        (``pieces`` their indices), to the start a growth solve predicts: the last solve's change of
        each times the ratio of this growth to its (at most :data:`_PREDICTOR_MAX_SCALE`; a joint added
        since has none).  False (nothing moved) for a solve without growth or after one.  Friction
        still resists slip from the configuration before."""
        last = self._last_change
        if last is None or self._grown <= 0 or last[2] <= 0:
            return False
        change, change_u, grown = last
        scale = min(self._grown / grown, _PREDICTOR_MAX_SCALE)
        n = min(len(change), len(self.phi))
        if n > a:
            phi[:n - a] += scale * change[a:n]
        if len(pieces):
            u += scale * change_u[pieces]
        return True

    def _solve_window_at(self, a: int, tol_m: float, tol_f: float, margin: float) -> bool | float:
        """:meth:`_solve_window` seeing the walls within ``margin`` (m) of the window: its result, or
        (nothing committed) the largest distance (m) a node moved if that is more than ``margin``."""
        cfg = self.cfg
        nodes, theta = self._all_nodes()
        theta0 = self.base_angle if a == 0 else float(theta[a - 1])
        fric = self._fric
        if len(self._piece_bodies):
            cos_u, sin_u = np.cos(self._u_all[:, 2]), np.sin(self._u_all[:, 2])
        else:
            cos_u = sin_u = _NO_ANGLES
        fric_entries = qk.Entries(fric["s"], fric["wall"], fric["wl"], fric["t"], fric["ml"])
        win = qk.window_setup(
            qk.Body(nodes, self.phi, self.seg_len, self.seg_rad, self.nodes, self.length, qk.Joints(self._k_all, self._mw_all)),
            self._scene_walls,
            qk.ScenePieces(self._pc0, self._u_all, cos_u, sin_u, self._k_piece, self._travel, self._k_travel), fric_entries,
            qk.WindowQuery(a, theta0, self.ds, cfg.barrier_gap_m + margin, cfg.barrier_gap_m + _PIECE_MARGIN_M, cfg.wall_friction,
                           self._tip_mu))
        if win.overlap:  # (the features an overlap can involve are all within the margin)
            return False
        phi, u, pieces = win.phi, win.u, win.pieces
        problem = qk.Problem(win.chain, win.joints, self._joint_law, win.walls, win.piece_data,
                             qk.ContactLaw(cfg.barrier_gap_m, self._kappa, self._friction_slip()))
        phi_ref, u_ref = phi.copy(), u.copy()
        predicted = self._predict(phi, u, a, pieces)
        iters = refreshes = 0
        # one Newton iteration's work: O(m) with the semiseparable solver, O(m^3) with the dense one
        m = len(phi) + 3 * len(pieces)
        per_iteration = 1.0 + m / 32.0 + ((m / 40.0) ** 3 if cfg.linear_solver == "dense" else 0.0)
        self._work_left -= _SOLVE_WORK
        for budget in (cfg.max_newton_iterations, _ESCALATION * cfg.max_newton_iterations):
            affordable = int(self._work_left / per_iteration)
            cut = budget > affordable  # the step's work budget ends this solve (_WORK_PER_S)
            budget = max(1, min(budget, affordable))
            settings = qk.SolveSettings(tol_m, tol_f, budget, _MAX_MOVE_M, cfg.friction_lag_iterations,
                                        cfg.linear_solver == "semiseparable")
            res = qk.solve_increment(problem, phi, phi_ref, u, u_ref, win.s_nodes, win.robot_mu, win.wall_mu, win.entries, settings)
            if res.status == qk.INFEASIBLE_START and predicted:  # the predicted start overlaps a wall: from the last one
                predicted = False
                phi[:] = phi_ref
                u[:] = u_ref
                res = qk.solve_increment(problem, phi, phi_ref, u, u_ref, win.s_nodes, win.robot_mu, win.wall_mu, win.entries, settings)
            status, it, res_m, res_f = res.status, res.iterations, res.residual_m, res.residual_f
            iters += it
            refreshes += res.refreshes
            self._work_left -= it * per_iteration
            if cut and status != qk.CONVERGED:
                self._retry_ok = False  # no budget left to retry it shorter either
            if status in (qk.CONVERGED, qk.INFEASIBLE_START) or self._retry_ok:
                break  # (a growth increment that can still be halved is retried shorter by the caller)
            if cut:  # no budget left to escalate: it ends unconverged (counted below)
                self._stats.budget_cuts += 1
                break
            # the increment cannot be shortened: the same solve again, from the same start, with a larger budget
            self._stats.escalated += 1
            phi[:] = phi_ref
            u[:] = u_ref
        self._stats.newton_iterations += iters
        self._stats.lag_refreshes += refreshes
        if status == qk.INFEASIBLE_START:
            return False
        reach = qk.max_node_shift(win.chain, phi, nodes[a:])
        if reach > margin:  # it went past the walls it saw: again, seeing farther (_solve_window)
            return reach
        self._stats.solves += 1
        ratio = max(res_m / tol_m, res_f / tol_f) * cfg.solver_tolerance  # largest residual over p pi r^2 (r^3)
        if status != qk.CONVERGED and self._retry_ok:  # the caller retries the increment at half its length
            self._stats.retried += 1
            self._retry_wanted = True
            return True
        self._stats.max_residual_ratio = max(self._stats.max_residual_ratio, ratio)
        self._stats.lag_unconverged += not res.lag_converged
        if status != qk.CONVERGED:
            self._stats.failures += 1
            self._event("solve_failed", status=int(status), residual=round(ratio, 6))
        # commit the window
        change, change_u = np.zeros(len(self.phi)), np.zeros(self._u_all.shape)
        change[a:] = phi - phi_ref
        if len(pieces):
            change_u[pieces] = u - u_ref
        self._last_change = (change, change_u, self._grown)
        self.phi[a:] = phi
        self._turn = None
        # the solved pieces take their equilibrium (at rest if nothing pushes them); the others stay
        # where the held body holds them (putting them back at rest would push them into it)
        if len(pieces):
            self._u_all[pieces] = u
        if len(self._piece_bodies):  # what the scene's pymunk pieces show after the step (_show_pieces)
            self._u_solved = self._u_all.copy()
        merged = qk.merge_friction(fric_entries, win.in_window, win.sel, res.entries)
        self._fric = dict(zip(("s", "wall", "wl", "t", "ml"), merged))
        self._commit_forces(a, res)
        return True

    def _commit_forces(self, a: int, res: qk.SolveResult) -> None:
        """The wall forces of a committed solve of joints ``a..``: per segment (N; moments N m), the
        segments in contact, the tip's reaction (N), its contact force and its clearance (m)."""
        n = len(self.phi)
        if len(self._seg_force) != n:
            self._seg_force = np.vstack([self._seg_force, np.zeros((n - len(self._seg_force), 2))])[:n]
            self._seg_moment = np.concatenate([self._seg_moment, np.zeros(n - len(self._seg_moment))])[:n]
        self._seg_force[a:] = res.seg_force
        self._seg_moment[a:] = res.seg_moment
        self._contact_segs = {s for s in self._contact_segs if s < a} | set((res.rows[:, 0].astype(np.int64) + a).tolist())
        self.tip_force = max(0.0, float(res.tip[0]))
        self.tip_contact = np.array([res.tip[1], res.tip[2]])
        self._tip_clearance = float(res.tip[3])
        self._free_until = -1.0

    # ---- events, stalls ---------------------------------------------------------------------
    @property
    def at_rest(self) -> bool:
        """Always true between steps: every state this engine shows is an equilibrium."""
        return True

