"""2-D pymunk simulation of an eversion robot growing from its tip.

The tube is a chain of rigid segments (pymunk bodies with ``Segment`` collision shapes
of the local tube radius, smaller at bands) joined at pivots by rotary springs whose
stiffness comes from the calibrated ``EI(s)`` of the rod model
(:mod:`evertgym.sim.discretize`), scaled with pressure as ``E_eff(p)`` is, and made
non-linear past each joint's wrinkling moment (secant stiffness updated every
``law_interval`` steps), so bands wrinkle and kink first.

Eversion: the base is pinned at ``base`` pointing along ``direction``; material appears
at the tip, whose segment lengthens continuously (between one and two segment lengths,
then splits), so the insertion length is not quantised.  The everted body never slides:
growth only moves the tip.  Growth follows :mod:`evertgym.sim.growth`.

Two models of the axial load (``SimConfig.section_law``).  The default, the rigid-column
model, keeps the chain axially rigid, sets the wrinkling and collapse moments from the
pressure alone (``p pi r^3 / 2``, ``p pi r^3``), pushes a blocked tip with a follower load
and multiplies the tip's whole resistance by the bend loss; it reproduces the paper's no-band
U-bend rows, but lets walls push the tip beyond what the tube can carry and its outcomes move
with the numerical knobs (docs/sim.md).  With ``section_law=True`` the joints carry
compression only up to each section's capacity ``p pi r^2 - T_tail`` and fold axially beyond
it, their moments follow the wall's tension (:mod:`evertgym.model.section_law`), the bend
loss acts on the tail only, tip forces are windowed impulses and each growth increment is
relaxed to rest: no wall pushes on the tip harder than the weakest section can carry.

Quasi-static regime: masses are scaled (see :class:`~evertgym.sim.config.SimConfig`);
only equilibria are physical.  Segments far behind the tip that are at rest become static
bodies and leave the active set, so a step costs in proportion to the active length.
Nothing renders here; use ``evertgym.scenes.render_rgb`` with :meth:`DynamicSim.centreline`.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from evertgym.model.pressure import KINK_MOMENT_FRACTION
from evertgym.model.section_law import compression_capacity, distal_compression, tail_tension, wall_tension
from evertgym.model.section_law import wrinkling_moment as wrinkling_moment_of_wall
from evertgym.sim.chipmunk import arbiter_impulses, body_angles, set_rotary_stiffness, set_spring_stiffness
from evertgym.sim.discretize import joint_moment, segment_inertia
from evertgym.sim.dormant import WALL_REST_SPEED_M_PER_S, DormantWalls
from evertgym.sim.links import Link, make_link
from evertgym.sim.tube import EversionSim, check_buildable, relax_step_budget

ROBOT_COLLISION_TYPE = 1
_ROBOT_GROUP = 1
#: Steps between active-set checks.
_FREEZE_INTERVAL = 25


__all__ = ["DynamicSim", "EversionSim", "NumericalInstabilityError", "ROBOT_COLLISION_TYPE", "check_buildable"]


class NumericalInstabilityError(RuntimeError):
    """The simulation produced non-finite or exploding state; the message names the setting to change."""


class DynamicSim(EversionSim):
    """The dynamic engine: a growing eversion robot as a chain of rigid pymunk bodies (the module's
    docstring), built by ``EversionSim(design, scene, SimConfig(engine="dynamic"))``; the parameters and the
    interface are :class:`~evertgym.sim.tube.EversionSim`'s."""

    engine = "dynamic"

    def _build_scene(self, scene):
        cfg = self.cfg
        self.space = space = pymunk.Space()
        space.iterations = cfg.iterations
        space.damping = cfg.damping
        space.collision_slop = 2e-4
        # resolve 20% of an overlap per step: the tip everts into contact geometrically
        space.collision_bias = (1.0 - 0.2) ** (1.0 / cfg.dt_s)
        return scene.build(space, dt=cfg.dt_s) if scene is not None else None

    def _build_body(self) -> None:
        cfg, design, space = self.cfg, self.design, self.space
        wall_bodies = getattr(self.scene_handles, "bodies", None)  # compliant wall pieces (an evertgym scene's handles)
        self._dormant = (DormantWalls(space, list(wall_bodies), cfg.wall_wake_margin_m, WALL_REST_SPEED_M_PER_S)
                         if cfg.dormant_walls and wall_bodies else None)
        self._beta = cfg.damping**cfg.dt_s  # spring impulse kept after Chipmunk's damping
        self._damping_rate = -math.log(cfg.damping)  # velocity decay rate (1/s)

        # the chain's state
        self.bodies: list[pymunk.Body] = []
        self.shapes: list[pymunk.Segment] = []
        self.springs: list[pymunk.DampedRotarySpring] = []
        self.links: list[Link] = []
        self._rest_since: list[float] = []
        self._last_pose: dict[int, tuple[float, float, float]] = {}
        self._frozen_turning = 0.0
        self._frontal = False
        self._rest_pressure: float | None = None  # the pressure (Pa) the rest lock holds at
        self.relax_steps = 0  # solver steps spent relaxing without advancing time
        self.relax_budget_cuts = 0  # relaxations the step's work bound ended before rest (unconverged_solves)
        self._relax_left = 0.0
        window = int(round(cfg.force_window_s / cfg.dt_s)) if cfg.section_law else 1
        self._tip_impulses = np.zeros((max(1, window), 2))  # ring buffer (N s)
        self._k_now = np.zeros(0)
        self._mw_now = np.zeros(0)
        #: the tail's drag at the base (N): the part of the eversion threshold that is tail
        #: tension, capstan-amplified over the body's bends (evertgym.sim.growth)
        self._tail_base_n = cfg.tail_drag_fraction * float(self.threshold(0.0)) * math.pi * design.radius_m**2 if cfg.section_law else None
        self._wall_tension = np.zeros(0)  # T_wall of the active joints at the last law update (N)
        self._capacity = np.zeros(0)  # N_max of the active joints (N)
        self._turning = 0.0

        self._anchor = space.static_body
        self._start_chain(cfg.initial_length_m)
        self._apply_pressure(0.0)

    # ---- construction ----------------------------------------------------------
    def _mass_props(self, j: int) -> tuple[float, float]:
        """Scaled (mass, inertia) for the stiffest state of the adjacent joints (8 kPa)."""
        nxt = min(j + 1, len(self._c_ref) - 1)
        top = self._law.effective_modulus(8000.0) / self._e_ref
        k = top / min(self._c_ref[j], self._c_ref[nxt])
        ks = top / min(self._cs_ref[j], self._cs_ref[nxt])
        inertia, mass = segment_inertia(self.cfg, k, ks, self.ds)
        return mass, inertia

    def _add_segment(self, j: int, length: float, origin: np.ndarray, angle: float, radius: float | None = None) -> None:
        """Segment ``j`` from node ``j`` (world point ``origin``) at ``angle``, joined to the
        previous body; its collision ``radius`` (m) defaults to its material's envelope."""
        mass, inertia = self._mass_props(j)
        body = pymunk.Body(mass, inertia)
        # the centre of gravity first: setting it later moves the body origin.  It stays
        # fixed while the tip segment lengthens for the same reason.
        body.center_of_gravity = (self.ds / 2, 0.0)
        body.angle = angle  # before the position: turning keeps the centre of gravity fixed
        body.position = tuple(origin)
        if radius is None:
            radius = self._radius_between(self.nodes[j], self.nodes[j] + length)
        shape = pymunk.Segment(body, (0.0, 0.0), (length, 0.0), radius)
        shape.friction = self.cfg.tip_friction  # the newest segment is the tip
        shape.elasticity = 0.0
        shape.collision_type = ROBOT_COLLISION_TYPE
        shape.filter = pymunk.ShapeFilter(group=_ROBOT_GROUP)
        if self.bodies:
            prev, anchor_prev, normal, rest = self.bodies[-1], (self.shapes[-1].b.x, 0.0), (0.0, 1.0), 0.0
        else:  # the clamp holds the base position and direction
            # Chipmunk measures a rotary spring angle as angle(a) - angle(b)
            prev, anchor_prev, rest = self._anchor, tuple(self.base), -self.base_angle
            normal = (-math.sin(self.base_angle), math.cos(self.base_angle))
        scale = self._law.effective_modulus(max(self._p_applied, 0.0)) / self._e_ref
        cap = None if self._tail_base_n is None else float(compression_capacity(max(self._p_applied, 0.0), self._r_cell[j], self._tail_base_n))
        link = make_link(prev, body, anchor_prev, normal, self.ds, scale / self._c_ref[j], scale / self._cs_ref[j], self._beta, rest,
                         axial_capacity=cap)
        self.space.add(body, shape, *link.constraints)
        self.bodies.append(body)
        self.shapes.append(shape)
        self.links.append(link)
        self.springs.append(link.bend)
        self._rest_since.append(math.inf)

    def _start_chain(self, length: float) -> None:
        n = max(1, int(math.floor(length / self.ds + 1e-9)))
        origin = self.base.copy()
        direction = np.array([math.cos(self.base_angle), math.sin(self.base_angle)])
        for j in range(n):
            seg = self.ds if j < n - 1 else length - (n - 1) * self.ds
            self._add_segment(j, seg, origin, self.base_angle)
            if j < n - 1:
                self.shapes[-1].friction = self.cfg.wall_friction
            origin = origin + seg * direction
        self.length = length

    # ---- pressure and joint law -------------------------------------------------
    def _apply_pressure(self, p: float) -> None:
        """Rescale joint stiffness and wrinkling moments to pressure ``p`` (Pa)."""
        scale = self._law.effective_modulus(p) / self._e_ref
        n = len(self.springs)
        self._k_now = scale / self._c_ref[:n]
        self._mw_now = 0.5 * max(p, 0.0) * math.pi * self._r3[:n]
        self._p_applied = p
        beta = self._beta
        cs = self._cs_ref
        a = self.active_start
        set_spring_stiffness((link.shear for link in self.links[a:n]), [scale / cs[j] / beta for j in range(a, n)])
        self._update_joint_law()

    def joint_angles(self, start: int = 0) -> np.ndarray:
        """Relative rotation of joints ``start..`` (rad); joint 0 is measured against the clamp."""
        first = start - 1 if start > 0 else 0
        ang = body_angles(self.bodies[first:])
        if start == 0:
            return ang - np.concatenate(([self.base_angle], ang[:-1]))
        return ang[1:] - ang[:-1]

    def joint_moments(self, start: int = 0) -> np.ndarray:
        """Joint moments (N m) of joints ``start..`` from the non-linear law at the current angles."""
        phi = self.joint_angles(start)
        return joint_moment(phi, self._k_now[start : start + len(phi)], self._mw_now[start : start + len(phi)])

    def collapse_moments(self, start: int = 0) -> np.ndarray:
        """Collapse (kink) moment ``M_c = p pi r^3`` (N m) of joints ``start..`` at the applied
        pressure; ``joint_moments() / collapse_moments()`` is each joint's distance to kinking."""
        return 2.0 * self._mw_now[start : len(self.bodies)]

    def _update_joint_law(self) -> None:
        """Secant stiffness of the active joints from the non-linear law, and kink events; under
        the section law the wrinkling moments and fold capacities are first updated from the
        wall tension (:meth:`_section_law`)."""
        a = self.active_start
        phi = self.joint_angles(a)
        if self._tail_base_n is not None:
            theta = self._frozen_turning + np.cumsum(np.abs(phi))  # turning from the base to each joint
            self._section_law(a, phi, theta, self._tail_base_n)
        k = self._k_now[a : a + len(phi)]
        moments = joint_moment(phi, k, self._mw_now[a : a + len(phi)])
        secant = np.array(k, dtype=float)
        np.divide(moments, phi, out=secant, where=np.abs(phi) > 1e-12)
        secant /= self._beta
        set_rotary_stiffness(self.springs[a:], secant.tolist())
        mc = 2.0 * self._mw_now[a : a + len(phi)]
        kinked = np.nonzero(np.abs(moments) >= KINK_MOMENT_FRACTION * mc)[0] + a if np.any(mc > 0) else ()
        self._kink_events(kinked, moments, mc, a)
        self._turning = self._frozen_turning + float(np.sum(np.abs(phi)))

    def _section_law(self, a: int, phi: np.ndarray, theta: np.ndarray, tail_base_n: float) -> None:
        """Wall tension, moments and fold capacity of the active joints ``a..`` (section law)."""
        p = max(self._p_applied, 0.0)
        r = self._r_cell[a : a + len(phi)]
        t_tail = tail_tension(tail_base_n, theta, self.growth.bend_loss)
        angles = body_angles(self.bodies[a : a + len(phi)])
        axes = np.column_stack((np.cos(angles), np.sin(angles)))
        t_wall = wall_tension(p, r, t_tail, distal_compression(self._contact_forces(a), axes))
        self._wall_tension = t_wall
        self._mw_now[a : a + len(phi)] = wrinkling_moment_of_wall(t_wall, r)
        capacity = compression_capacity(p, r, t_tail)
        if len(capacity) != len(self._capacity) or np.any(np.abs(capacity - self._capacity) > 1e-3 * (capacity + 1e-3)):
            for link, c in zip(self.links[a:], capacity.tolist()):
                if link.push is not None:
                    link.push.max_force = c
            self._capacity = capacity

    def _contact_forces(self, start: int) -> np.ndarray:
        """Wall forces (N) on bodies ``start..``, one row per body: the last step's impulses
        over the step, and for the tip its windowed force (:meth:`_tip_reaction`)."""
        out = np.zeros((len(self.bodies) - start, 2))
        row = out[0]

        def acc(arb: pymunk.Arbiter) -> None:
            imp = arb.total_impulse
            row[0] += imp.x
            row[1] += imp.y

        for i, body in enumerate(self.bodies[start:]):
            row = out[i]
            body.each_arbiter(acc)
        out /= self.cfg.dt_s
        out[-1] = self.tip_contact
        return out

    # ---- stepping ---------------------------------------------------------------
    @property
    def tip_position(self) -> np.ndarray:
        b, sh = self.bodies[-1], self.shapes[-1]
        return np.array(b.local_to_world(sh.b))

    @property
    def wall_tension(self) -> np.ndarray:
        """``T_wall`` (N) of the active joints ``active_start..`` at the last law update
        (:mod:`evertgym.model.section_law`); negative where the wall would have to push.  The
        rigid-column model's moments assume the unloaded ``p pi r^2``."""
        if self._tail_base_n is None:
            return max(self._p_applied, 0.0) * math.pi * self._r_cell[self.active_start : len(self.bodies)] ** 2
        return self._wall_tension.copy()

    @property
    def compression_capacity(self) -> np.ndarray:
        """``N_max = p pi r^2 - T_tail`` (N) of the active joints at the last law update: the
        compression each carries before it folds axially (unbounded in the rigid-column model)."""
        if self._tail_base_n is None:
            return np.full(len(self.bodies) - self.active_start, math.inf)
        return self._capacity.copy()

    @property
    def tip_capacity(self) -> float:
        """The most the wall may push on the tip (N): the smallest compression capacity
        between the tip and the first active joint."""
        cap = self.compression_capacity
        return float(np.min(cap)) if len(cap) else 0.0

    def _tip_reaction(self) -> None:
        """Wall force on the tip body (N) and its component against growth.

        The force is the wall's impulse on the tip over the last ``cfg.force_window_s``
        divided by that time: a force in the quasi-static sense, the same whatever the step.
        A single step's impulse over the step is not one: a contact that the growing tip
        meets with an overlap is resolved in one step by an impulse whose size depends on
        the step and the scaled masses."""
        rows = arbiter_impulses(self.bodies[-1])
        if not rows and len(self._tip_impulses) == 1:  # no contact: no force
            self.tip_contact = np.zeros(2)
            self._frontal = False
            self.tip_force = 0.0
            self._contact_update(0.0, False)
            return
        t = self.tip_direction
        total = [0.0, 0.0]
        touching = bool(rows)
        frontal = False
        for jx, jy, nx, ny in rows:
            total[0] += jx
            total[1] += jy
            if nx * t[0] + ny * t[1] > 0.2:  # the normal points from the tip's shape towards the other one
                frontal = True
        window = len(self._tip_impulses)
        if window == 1:
            f = np.array(total) / self.cfg.dt_s
        else:
            self._tip_impulses[self.steps % window] = total
            f = self._tip_impulses.sum(axis=0) / (window * self.cfg.dt_s)
        self.tip_contact = f
        self._frontal = frontal
        self.tip_force = max(0.0, -float(f @ t))
        mag = float(math.hypot(*f))
        self._contact_update(mag, touching)

    def _grow(self, v: float) -> None:
        if v <= 0:
            return
        dl = v * self.cfg.dt_s
        new_len = min(self.length + dl, self.design.length_m)
        dl = new_len - self.length
        if dl <= 0:
            return
        self.length = new_len
        self._band_events()  # bands reaching the tip
        j = len(self.bodies) - 1
        sh = self.shapes[-1]
        nodes = self._node_list
        seg = self.length - nodes[j]
        r_old = sh.radius
        if seg >= 2 * self.ds - 1e-12 and j + 1 < len(nodes):
            # split: the tip segment becomes a full segment and a new tip starts at node j+1
            sh.unsafe_set_endpoints((0.0, 0.0), (self.ds, 0.0))
            # a laid-down segment is never wider than the tip it was: widening it in place
            # would push it into a wall it already touches
            sh.unsafe_set_radius(min(self._radius_between(nodes[j], nodes[j] + self.ds), r_old))
            sh.friction = self.cfg.wall_friction  # no longer the tip: laid down
            body = self.bodies[-1]
            origin = np.array(body.local_to_world((self.ds, 0.0)))
            self._add_segment(j + 1, seg - self.ds, origin, body.angle, self._tip_radius(r_old, nodes[j + 1], dl))
            nb = self.bodies[-1]
            nb.velocity = body.velocity_at_local_point((self.ds, 0.0))
            nb.angular_velocity = body.angular_velocity
            n = len(self.springs)
            scale = self._law.effective_modulus(self._p_applied) / self._e_ref
            self._k_now = scale / self._c_ref[:n]
            self._mw_now = 0.5 * max(self._p_applied, 0.0) * math.pi * self._r3[:n]
            self.springs[-1].stiffness = float(self._k_now[-1]) / self._beta
        else:
            sh.unsafe_set_endpoints((0.0, 0.0), (seg, 0.0))
            if self._near_band(self.length):  # the tip's material changes radius as it grows
                sh.unsafe_set_radius(self._tip_radius(r_old, nodes[j], dl))

    def _tip_radius(self, r_old: float, start: float, dl: float) -> float:
        """Collision radius (m) of the tip segment starting at material coordinate ``start``
        after the tip grew by ``dl`` (m): the envelope of its newest ``ds`` of material (what
        has just everted, not a band it has left behind), widening by at most ``dl / 2`` per
        step so a tip leaving a band eases out from a wall instead of jumping into it."""
        target = self._radius_between(max(start, self.length - self.ds), self.length)
        return min(target, r_old + 0.5 * dl)

    def _push_tip(self, p: float, p_y: float, area: float) -> None:
        """Rigid-column model: the everting tip's force on an obstacle ahead,
        ``A (p exp(-mu_b Theta) - p_y)`` along the tip (a follower load), while a contact lies
        ahead (its normal within about 78 degrees of the tip axis)."""
        if self.length >= self.design.length_m or not self._frontal:
            return
        f = area * (p * math.exp(-self.growth.bend_loss * self._turning) - p_y)
        if f > 0:
            sh = self.shapes[-1]
            self.bodies[-1].apply_force_at_local_point((f, 0.0), (sh.b.x, 0.0))

    def _required_pressure(self, p_y: float, area: float) -> float:
        return self.growth.required_pressure(p_y, self.tip_force, area, self._turning, self._tail_weight(), self._tail_base_n)

    def required_pressure(self) -> float:
        """Pressure (Pa) the tip needs to grow now: its material's eversion threshold plus the
        tail's capstan losses over the body's bends and the wall's reaction against growth;
        below it the robot stalls."""
        p_y, area = self._tip_threshold()
        return self._required_pressure(p_y, area)

    def _freeze_check(self) -> None:
        """Move resting segments far behind the tip out of the active set.

        Candidates are the segments wholly more than ``active_length_m`` behind the tip;
        each keeps a rest timer; the contiguous run from the first active segment whose
        timers passed ``freeze_time_s`` becomes static (their joints are removed: the
        frozen part is rigid from then on, the first active joint is a clamp on it).
        """
        cut = self.length - self.cfg.active_length_m
        last = len(self.bodies) - 2
        j = self.active_start
        freeze_upto = self.active_start
        contiguous = True
        interval = _FREEZE_INTERVAL * self.cfg.dt_s
        while j < last and self.nodes[j] + self.ds < cut:
            b = self.bodies[j]
            pose = (b.position.x, b.position.y, b.angle * self.ds)
            before = self._last_pose.get(j)
            self._last_pose[j] = pose
            # mean speed over the check interval: contact jitter averages out
            speed = math.inf if before is None else sum(abs(u - w) for u, w in zip(pose, before)) / interval
            if speed < self.cfg.freeze_speed_m_per_s:
                if self._rest_since[j] == math.inf:
                    self._rest_since[j] = self.t
                if contiguous and self.t - self._rest_since[j] >= self.cfg.freeze_time_s:
                    freeze_upto = j + 1
                else:
                    contiguous = False
            else:
                self._rest_since[j] = math.inf
                contiguous = False
            j += 1
        if freeze_upto > self.active_start:
            a = self.active_start
            self._frozen_turning += float(np.sum(np.abs(self.joint_angles(a)[: freeze_upto - a])))
            for k in range(a, freeze_upto):
                b = self.bodies[k]
                self.space.remove(*self.links[k].constraints)
                b.velocity = (0.0, 0.0)
                b.angular_velocity = 0.0
                b.body_type = pymunk.Body.STATIC
                self._last_pose.pop(k, None)
            self.active_start = freeze_upto

    def step(self, n_steps: int = 1) -> None:
        """Advance ``n_steps`` pymunk steps of ``cfg.dt_s``.

        The finite-state check runs once per call (a chain that blew up is reported at the
        end of the call); :attr:`step_mean_pressure` and :attr:`step_max_contact_force`
        summarise the call's steps."""
        cfg = self.cfg
        dt = cfg.dt_s
        # relaxation steps this call may take: the dynamic engine's work bound over the call's simulated time
        # (:data:`~evertgym.sim.tube.MAX_DYNAMIC_WORK_PER_S`), so no max_relax_steps can hang a step
        self._relax_left = relax_step_budget(self.design, cfg, n_steps)
        p_sum, f_max = 0.0, 0.0
        for _ in range(n_steps):
            p = self.regulator.advance(dt)
            p_sum += p
            self.peak_pressure = max(self.peak_pressure, p)
            if self._rest_pressure is not None:
                if abs(p - self._rest_pressure) <= cfg.rest_pressure_tol_pa:
                    self.t += dt  # held in static equilibrium: nothing moves, nothing grows
                    self.steps += 1
                    self.growth_speed = 0.0
                    self._stall_update(0.0, dt)
                    f_max = max(f_max, self._tip_force_norm)
                    continue
                self._rest_pressure = None
            if self.steps % cfg.law_interval == 0:
                if abs(p - self._p_applied) > 0.005 * max(self._p_applied, 100.0):
                    self._apply_pressure(p)  # rescales the joints, then updates the law
                else:
                    self._update_joint_law()
            if self.steps % _FREEZE_INTERVAL == 0:
                self._freeze_check()
                if self._dormant is not None:
                    active = self.bodies[self.active_start:]
                    centres = np.array([tuple(b.position) for b in active]).reshape(-1, 2)
                    self._dormant.update(centres, max(sh.radius for sh in self.shapes) + self.ds)
            p_y, area = self._tip_threshold()
            if self._tail_base_n is None:
                self._push_tip(p, p_y, area)
            self.space.step(dt)
            self.t += dt
            self.steps += 1
            self._tip_reaction()
            v = self.growth.speed(p, self._required_pressure(p_y, area)) if self.length < self.design.length_m else 0.0
            self._grow(v)
            if v > 0 and cfg.section_law:  # relax after a growth increment (not between a user's own loads)
                self._relax()
            self.growth_speed = v
            self._stall_update(v, dt)
            if self._stalled and cfg.rest_speed_m_per_s > 0 and self.steps % _FREEZE_INTERVAL == 0 and self._at_rest(p):
                self._rest_pressure = p
            f_max = max(f_max, self._tip_force_norm)
        self._step_mean_pressure = p_sum / n_steps if n_steps > 0 else self.pressure
        self._step_max_contact = f_max
        self._check_finite()

    def _tip_region_residual(self) -> float:
        """How far the segments within ``cfg.relax_length_m`` of the tip are from rest: with
        ``relax_force_n`` > 0 the largest unbalanced force (N) their motion implies under
        Chipmunk's damping rate ``g`` (``m g |v|``, and ``I g |w| / ds`` for the rotation), which
        does not depend on the scaled masses; else their largest speed (m/s, ``|v| + |w| ds``)."""
        ds = self.ds
        first = max(self.active_start, len(self.bodies) - max(1, int(round(self.cfg.relax_length_m / ds))))
        if self.cfg.relax_force_n > 0:
            g = self._damping_rate
            return max((g * (b.mass * b.velocity.length + b.moment * abs(b.angular_velocity) / ds) for b in self.bodies[first:]),
                       default=0.0)
        return max((b.velocity.length + abs(b.angular_velocity) * ds for b in self.bodies[first:]), default=0.0)

    def _relax(self) -> None:
        """Quasi-static growth (section law): after material is added, step the chain without
        advancing time, growth or the regulator until the tip region is at rest by
        :meth:`_tip_region_residual` (at most ``cfg.max_relax_steps`` steps).

        Growth at up to 0.1 m/s drives the tip into walls faster than the chain relaxes (its
        damping time is about 70 ms), so the outcome of a first contact is decided by a
        transient whose course changes with the scaled mass, the inertia and the step.  This
        relaxation is meant to remove that dependence; measured, it does not yet (docs/sim.md:
        U-bend cells still move by up to 12 of 12 with ``mass_ratio`` or the step)."""
        cfg = self.cfg
        tol = cfg.relax_force_n if cfg.relax_force_n > 0 else cfg.relax_speed_m_per_s
        if tol <= 0:
            return
        for k in range(cfg.max_relax_steps):
            if self._tip_region_residual() <= tol:
                return
            if self._relax_left <= 0:  # the step's work bound: this relaxation ends short of rest, counted
                self.relax_budget_cuts += 1
                return
            self._relax_left -= 1
            if k % cfg.law_interval == cfg.law_interval - 1:
                self._update_joint_law()
            self.space.step(cfg.dt_s)
            self.relax_steps += 1
            self._tip_reaction()

    def _at_rest(self, p: float) -> bool:
        """Whether every dynamic body in the space (active segments, compliant wall pieces)
        moves slower than ``cfg.rest_speed_m_per_s`` at its far end, and the regulated
        pressure has settled on its command."""
        if abs(self.regulator.command - p) > self.cfg.rest_pressure_tol_pa:
            return False
        vmax = self.cfg.rest_speed_m_per_s
        reach = 2.0 * self.ds
        for b in self.space.bodies:
            if b.body_type != pymunk.Body.DYNAMIC:
                continue
            if b.velocity.length + abs(b.angular_velocity) * reach > vmax:
                return False
        return True

    @property
    def tip_angle(self) -> float:
        """Heading of the tip segment (rad)."""
        return float(self.bodies[-1].angle)

    def segments_in_contact(self) -> list[int]:
        """Active segments that touch a wall in the last step."""
        touching = []
        for j in range(self.active_start, len(self.bodies)):
            arbiters: list = []
            self.bodies[j].each_arbiter(arbiters.append)
            if arbiters:
                touching.append(j)
        return touching

    @property
    def solve_stats(self) -> dict:
        """Empty: the dynamic engine has no equilibrium solves to count; with the section law, relaxations
        the step's work bound ended before rest as ``{"solve_failures": n}`` once there is one."""
        return {"solve_failures": self.relax_budget_cuts} if self.relax_budget_cuts else {}

    @property
    def at_rest(self) -> bool:
        """Whether the robot is held in static equilibrium by the rest lock."""
        return self._rest_pressure is not None

    def _check_finite(self) -> None:
        b = self.bodies[-1]
        vals = (b.position.x, b.position.y, b.angle, b.velocity.x, b.velocity.y)
        if not all(math.isfinite(v) for v in vals) or abs(b.angular_velocity) * self.cfg.dt_s > 1.0:
            raise NumericalInstabilityError(
                f"the chain became unstable at t = {self.t:.3f} s: lower dt_s (now {self.cfg.dt_s}) or raise "
                f"inertia_factor (now {self.cfg.inertia_factor}) or iterations (now {self.cfg.iterations})"
            )

    def centreline(self) -> np.ndarray:
        """Node positions from the base to the tip (m), (n+1) x 2."""
        pts = [tuple(self.base)]
        for b, sh in zip(self.bodies, self.shapes):
            pts.append(tuple(b.local_to_world(sh.b)))
        return np.array(pts)

    def radii(self) -> np.ndarray:
        """Collision radius of each segment (m)."""
        return np.array([sh.radius for sh in self.shapes])
