"""Peer comparison: the banded tensile-test cantilever solved by evertgym, PyElastica and MuJoCo.

The problem (SI inside)
    The paper's tensile test on the prototype with three 50% bands 50, 100 and 150 mm
    from the tip (:data:`BANDS_FROM_TIP_MM`): the clamped free length (about 200.7 mm,
    ``load_params().free_length_m``) at 6.9 kPa, its tip held 20 mm off the clamp line
    by a purely lateral force, free to slide along the clamp line and to rotate.  The
    answer is the lateral tip force ``tip_force_n``; the reference is the Cosserat rod
    (:func:`evertgym.model.stiffness.virtual_tensile_test`, shear and extension included).
    Three bands rather than one: the stiffness then jumps six times along the cantilever,
    which is what a discretisation has to get right.
Constitutive law
    Linear, ``EI(s)``, ``GA(s)`` and ``EA(s)`` of the section, in all engines: the peers
    have no wrinkling law.  It is the whole law here: the rod's largest moment is 23% of
    the collapse moment, below wrinkling onset at 50% (:func:`reference` checks it), so
    evertgym's non-linear joints stay on their linear branch.
Discretisations (each engine's own, fed the same ``EI(s)``, ``GA(s)``, ``EA(s)``)
    evertgym: the pymunk chain of :func:`evertgym.sim.tensile.sim_tensile_test`; joint
    stiffness ``k_j = 1 / int h_j / EI ds`` (hat functions, :mod:`evertgym.sim.discretize`).
    PyElastica: a ``CosseratRod`` whose bend matrix at each Voronoi node is the
    compliance-consistent mean ``B_i = D_i / int_{V_i} ds / EI`` and whose shear and
    stretch entries per element are ``l_e / int_e ds / GA`` and ``l_e / int_e ds / EA``
    (twist ``GJ = 2 G I``; no Timoshenko factor: the rod model has none); clamped by
    ``OneEndFixedBC`` (node 0 and element 0), the tip on a constraint holding its y.
    MuJoCo: a planar chain of rigid segments, one body per segment, with at each node a
    slide joint along the proximal segment's normal (the shear spring) and a hinge, of
    exactly evertgym's joint stiffnesses (:func:`evertgym.sim.discretize.joint_law`); the
    tip site is held by a near-hard ``connect`` equality to a carriage sliding along x at
    ``y = displacement``.  A hinge-only chain cannot reach 1%: shear is 1.6% of the tip
    compliance here.
Start and convergence (the same for every engine)
    Each starts from the small-deflection shape ``y = d (3 xi^2 - xi^3) / 2`` (PyElastica's
    clamped element laid along the clamp line) and relaxes by damped dynamics.  Every
    :data:`WINDOW_STEPS` steps the tip force is read; the solve has converged when it
    changed by at most :data:`FORCE_TOL` (relative) over the window and every segment
    (element) turns slower than :data:`SPEED_TOL_M_PER_S` / its length: the criterion that
    :func:`~evertgym.sim.tensile.sim_tensile_test` applies (its speed bound is fixed at
    1e-7 m/s), applied to the peers by :func:`relax`.
Accuracy and timing
    ``tip_force_error = F / F_rod - 1``.  Each engine's discretisation is the coarsest of
    its sweep (run at the engine's sweep setting) from which every finer one converged
    within :data:`ERROR_BUDGET` (1%).  There, each setting of the engine's tuning grid (its
    solver knobs: evertgym's solver passes and damping; PyElastica's step, up to the
    largest stable one, and damping constant; MuJoCo's step and joint-damping time
    constant) is timed :data:`REPEATS` times, and ``wall_s`` is the best time of the fastest
    setting that converged within the budget, for a whole solve (build the model, relax,
    read the force), after a warm-up (PyElastica's numba compilation is excluded).
    The peers' masses are physical (:data:`FILM_DENSITY_KG_PER_M3`); evertgym's are its
    own scaled ones (``SimConfig.inertia_factor``, ``mass_ratio``), part of its solver.
    Neither chain models extension (0.03% of the tip deflection); PyElastica does.  Wall
    times depend on the machine and its load: compare the rows of one run.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from evertgym.design import TubeDesign
from evertgym.model.params import load_params
from evertgym.model.section import TubeSection
from evertgym.model.stiffness import (
    PAPER_DISPLACEMENT_M,
    PAPER_PRESSURE_PA,
    paper_prototype,
    virtual_tensile_test,
)
from evertgym.sim.config import SimConfig
from evertgym.sim.discretize import joint_law
from evertgym.sim.tensile import sim_tensile_test

#: The design: 50% bands at these distances (mm) from the tip.
BANDS_FROM_TIP_MM = (50.0, 100.0, 150.0)
REDUCTION = 0.5
#: Largest |tip_force_error| a chosen discretisation (and every finer one) may have.
ERROR_BUDGET = 0.01
#: Convergence: steps between force readings, relative force change allowed over them,
#: and bound on every segment's turning speed times its length (m/s; the simulator's).
WINDOW_STEPS = 100
FORCE_TOL = 2e-6
SPEED_TOL_M_PER_S = 1e-7
#: Timed repeats of the chosen setting (the best counts).
REPEATS = 3
#: Physical masses of the peers: a polyethylene film (kg/m^3) of the design's wall.
FILM_DENSITY_KG_PER_M3 = 920.0
#: Step cap of one peer solve; a force this many times the first reading is a divergence.
MAX_STEPS = 300_000
DIVERGED_FACTOR = 100.0
#: A tuning trial is cut off past this many times the steps of the sweep setting.
TRIAL_STEPS_FACTOR = 2
#: Quadrature points per interval of the compliance integrals.
_QUAD = 64

#: Sweeps, coarse to fine: evertgym segment lengths (m), PyElastica elements, MuJoCo
#: segments (the segment counts of evertgym's sweep: the two chains share their lumping).
EVERTGYM_SEGMENTS_M = (0.05, 0.04, 0.03, 0.025, 0.02, 0.015, 0.0125, 0.01, 0.0075, 0.005)
PYELASTICA_ELEMENTS = (8, 10, 12, 16, 20, 24, 32, 40, 48)
MUJOCO_SEGMENTS = (4, 5, 7, 8, 10, 13, 16, 20, 27, 40)
#: Tuning grids of each engine's solver knobs, and the setting its sweep runs.
#: evertgym: ``SimConfig.iterations`` and ``SimConfig.damping`` (velocity kept after 1 s);
#: the sweep runs the SimConfig defaults.
EVERTGYM_ITERATIONS = (1, 3, 10)
EVERTGYM_DAMPING = (1e-6, 1e-9, 1e-12, 1e-15, 1e-20)
#: PyElastica: step per element length (s/m; its stable step scales with the element: 6e-3
#: diverges) and ``AnalyticalLinearDamper``'s uniform damping constant (1/s).
PYELASTICA_SWEEP = (3e-3, 800.0)
PYELASTICA_DT_PER_M = (3e-3, 4e-3, 5e-3)
PYELASTICA_DAMPING = (300.0, 400.0, 600.0, 800.0, 1200.0, 1600.0)
#: MuJoCo: step per squared segment length (s/m^2; the hinges' explicit springs limit it)
#: and the time constant tau (s) of joint damping ``tau x stiffness``, joint by joint.
MUJOCO_SWEEP = (0.1, 4e-3)
MUJOCO_DT_PER_M2 = (0.1, 0.2, 0.4, 0.8, 1.6)
MUJOCO_TAU_S = (1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2)

PIP_EXTRA = "pip install -e '.[bench]'"


# ---- the problem ------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """The tensile test: clamp at body coordinate ``s_base`` (m), tip at ``s_tip``, lateral
    tip displacement ``displacement_m`` (m) at ``pressure_pa`` (Pa)."""

    design: TubeDesign
    free_length_m: float
    displacement_m: float = PAPER_DISPLACEMENT_M
    pressure_pa: float = PAPER_PRESSURE_PA

    @property
    def s_tip(self) -> float:
        return self.design.length_m

    @property
    def s_base(self) -> float:
        return self.design.length_m - self.free_length_m

    @cached_property
    def section(self) -> TubeSection:
        return TubeSection(self.design, self.pressure_pa)

    @property
    def line_density_kg_per_m(self) -> float:
        """Mass per length of the tube's film (kg/m), the peers' physical mass."""
        return 2 * math.pi * self.design.radius_m * self.design.wall_thickness_m * FILM_DENSITY_KG_PER_M3


def default_case() -> Case:
    """The paper prototype with :data:`BANDS_FROM_TIP_MM` at :data:`REDUCTION`, paper's test."""
    return Case(paper_prototype(BANDS_FROM_TIP_MM, REDUCTION), load_params().free_length_m)


def reference(case: Case) -> dict:
    """The Cosserat rod's answer: ``tip_force_n`` (N), ``max_moment_fraction`` (largest
    ``|M| / M_c``) and ``wrinkled``; raises if the linear law would not be the whole law."""
    sol = virtual_tensile_test(case.design, case.displacement_m, case.pressure_pa, case.free_length_m)
    if sol.wrinkled:
        raise ValueError("the reference rod wrinkles: the peers' linear law does not apply")
    return {"tip_force_n": float(sol.force[1]), "max_moment_fraction": sol.max_moment_fraction, "wrinkled": sol.wrinkled}


def force_error(force_n: float, reference_n: float) -> float:
    """Signed relative tip-force error ``F / F_rod - 1``."""
    return force_n / reference_n - 1.0


def start_shape(case: Case, n: int, flat_first: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Node coordinates (m, ``n + 1`` each) of ``n`` equal segments on the small-deflection
    curve ``y = d (3 xi^2 - xi^3) / 2``; ``flat_first`` lays the first along the clamp line."""
    ds = case.free_length_m / n
    xi = np.arange(n + 1) / n
    y = case.displacement_m * (3 * xi**2 - xi**3) / 2
    if flat_first:
        y[1] = 0.0
    x = np.concatenate(([0.0], np.cumsum(np.sqrt(np.maximum(ds**2 - np.diff(y) ** 2, 0.0)))))
    return x, y


def mean_stiffness(stiffness: Callable[[np.ndarray], np.ndarray], a: float, b: float,
                   breakpoints: Sequence[float] = ()) -> float:
    """Compliance-consistent mean of a stiffness over ``[a, b]`` (m): ``(b - a) / int_a^b ds / K``,
    the integral taken piecewise between the ``breakpoints`` (m) of the section."""
    cuts = [a, *sorted(p for p in breakpoints if a < p < b), b]
    compliance = 0.0
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        s = np.linspace(lo, hi, _QUAD + 1)
        s[0], s[-1] = lo + 1e-12 * (hi - lo), hi - 1e-12 * (hi - lo)  # each piece from its own side
        compliance += float(np.trapezoid(1.0 / stiffness(s), s)) * (hi - lo) / (s[-1] - s[0])
    return (b - a) / compliance


def pyelastica_stiffness(case: Case, n: int) -> dict[str, np.ndarray]:
    """PyElastica's stiffness arrays for ``n`` elements (SI): ``bend`` (N m^2, the ``n - 1``
    Voronoi nodes), ``shear`` and ``stretch`` (N, the ``n`` elements)."""
    sec, ds = case.section, case.free_length_m / n
    cuts = sec.breakpoints()
    nodes = case.s_base + ds * np.arange(n + 1)
    elements = list(zip(nodes[:-1], nodes[1:]))
    return {
        "bend": np.array([mean_stiffness(sec.bending_stiffness, s - ds / 2, s + ds / 2, cuts) for s in nodes[1:-1]]),
        "shear": np.array([mean_stiffness(sec.shear_stiffness, a, b, cuts) for a, b in elements]),
        "stretch": np.array([mean_stiffness(sec.axial_stiffness, a, b, cuts) for a, b in elements]),
    }


# ---- convergence ------------------------------------------------------------------------
@dataclass(frozen=True)
class Relaxed:
    """End of a relaxation: tip force (N), steps taken, whether the criterion was met."""

    force_n: float
    steps: int
    converged: bool


def relax(advance: Callable[[int], None], tip_force: Callable[[], float], speed: Callable[[], float],
          max_steps: int = MAX_STEPS) -> Relaxed:
    """Step ``advance(WINDOW_STEPS)`` until the tip force (N) changed by at most
    ``FORCE_TOL`` of itself over a window and ``speed()`` (m/s) is below
    ``SPEED_TOL_M_PER_S``, or ``max_steps``, or divergence: a non-finite force or one above
    ``DIVERGED_FACTOR`` times the first reading."""
    first, last, force, steps = None, None, math.nan, 0
    while steps < max_steps:
        advance(WINDOW_STEPS)
        steps += WINDOW_STEPS
        force = float(tip_force())
        first = force if first is None else first
        if not math.isfinite(force) or abs(force) > DIVERGED_FACTOR * abs(first):
            return Relaxed(force, steps, False)
        if last is not None and abs(force - last) <= FORCE_TOL * max(abs(force), 1e-9) and speed() < SPEED_TOL_M_PER_S:
            return Relaxed(force, steps, True)
        last = force
    return Relaxed(force, steps, False)


# ---- the engines --------------------------------------------------------------------------
def solve_evertgym(case: Case, segment_length_m: float, max_steps: int = MAX_STEPS, **setting: float) -> Relaxed:
    """evertgym's pymunk chain of ``segment_length_m`` (m) segments; ``setting`` overrides
    other :class:`SimConfig` fields (``iterations``, ``damping``)."""
    default = SimConfig(engine="dynamic")  # the initial length only matters to growth; it may not be below a segment
    config = replace(default, segment_length_m=segment_length_m,
                     initial_length_m=max(default.initial_length_m, segment_length_m), **setting)  # type: ignore[arg-type]
    res = sim_tensile_test(case.design, case.displacement_m, case.pressure_pa, case.free_length_m, config=config,
                           max_steps=max_steps, tol=FORCE_TOL)
    return Relaxed(res.force_n, res.steps, res.converged)


def solve_pyelastica(case: Case, n: int, dt_s: float, damping_per_s: float, max_steps: int = MAX_STEPS) -> Relaxed:
    """A PyElastica ``CosseratRod`` of ``n`` elements, position-Verlet steps of ``dt_s`` (s),
    ``AnalyticalLinearDamper`` with uniform constant ``damping_per_s`` (1/s)."""
    import elastica as ea

    class TipOnLine(ea.ConstraintBase):
        """Holds the last node's y at ``y`` (m); x and the rotation stay free."""

        def __init__(self, y: float, **kwargs) -> None:
            super().__init__(**kwargs)
            self.y = y

        def constrain_values(self, system, time) -> None:
            system.position_collection[1, -1] = self.y

        def constrain_rates(self, system, time) -> None:
            system.velocity_collection[1, -1] = 0.0

    class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Damping):
        pass

    x, y = start_shape(case, n, flat_first=True)
    position = np.zeros((3, n + 1))
    position[0], position[1] = x, y
    theta = np.arctan2(np.diff(y), np.diff(x))
    directors = np.zeros((3, 3, n))  # rows: d1 (in-plane normal), d2 = z (bending axis), d3 (tangent)
    directors[0, 0], directors[0, 1] = -np.sin(theta), np.cos(theta)
    directors[1, 2] = 1.0
    directors[2, 0], directors[2, 1] = np.cos(theta), np.sin(theta)
    r = case.design.radius_m
    rod = ea.CosseratRod.straight_rod(
        n, np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), case.free_length_m, r,
        case.line_density_kg_per_m / (math.pi * r * r), youngs_modulus=1.0, shear_modulus=1.0,
        position=position, directors=directors,
    )
    k = pyelastica_stiffness(case, n)
    rod.bend_matrix[:] = 0.0
    rod.shear_matrix[:] = 0.0
    rod.bend_matrix[0, 0] = rod.bend_matrix[1, 1] = k["bend"]
    rod.bend_matrix[2, 2] = k["bend"] * 2 * case.section.g_eff_pa / case.section.e_eff_pa
    rod.shear_matrix[0, 0] = rod.shear_matrix[1, 1] = k["shear"]
    rod.shear_matrix[2, 2] = k["stretch"]
    sim = Simulator()
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    sim.constrain(rod).using(TipOnLine, y=case.displacement_m)
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=damping_per_s, time_step=dt_s)
    sim.finalize()
    stepper = ea.PositionVerlet()
    clock = [0.0]

    def advance(steps: int) -> None:
        for _ in range(steps):
            clock[0] = stepper.step(sim, clock[0], dt_s)

    return relax(advance, lambda: -rod.internal_forces[1, -1],
                 lambda: float(np.max(np.linalg.norm(rod.omega_collection, axis=0) * rod.lengths)), max_steps)


def mujoco_stiffness(case: Case, n: int) -> dict[str, np.ndarray]:
    """Joint stiffnesses of the ``n``-segment MuJoCo chain: ``hinge`` (N m/rad) and ``slide``
    (N/m) at nodes ``0 .. n-1`` (node 0 the clamp): evertgym's hat lumping."""
    nodes = case.s_base + case.free_length_m / n * np.arange(n)
    law = joint_law(case.section, nodes, case.s_tip)
    return {"hinge": law.stiffness, "slide": law.shear_stiffness}


def mujoco_xml(case: Case, n: int, dt_s: float, tau_s: float) -> str:
    """MJCF of the chain (module docstring): segments of mass ``mu ds`` (kg); every joint
    (slide and hinge) damped by ``tau_s`` (s) times its stiffness, which MuJoCo's implicit
    integrator makes an overdamped, Jacobi-like relaxation."""
    ds = case.free_length_m / n
    k = mujoco_stiffness(case, n)
    mass = case.line_density_kg_per_m * ds
    inertia = mass * ds * ds / 12
    bodies = []
    for j in range(n):
        slide, hinge = float(k["slide"][j]), float(k["hinge"][j])
        bodies.append(
            f'<body pos="{0.0 if j == 0 else ds} 0 0">'
            f'<joint type="slide" axis="0 1 0" stiffness="{slide!r}" damping="{slide * tau_s!r}"/>'
            f'<joint type="hinge" axis="0 0 1" stiffness="{hinge!r}" damping="{hinge * tau_s!r}"/>'
            f'<inertial pos="{ds / 2} 0 0" mass="{mass!r}" diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>'
        )
    chain = "".join(bodies) + f'<site name="tip" pos="{ds} 0 0"/>' + "</body>" * n
    carriage = (f'<body pos="0 {case.displacement_m} 0"><joint type="slide" axis="1 0 0"/>'
                f'<inertial pos="0 0 0" mass="{mass!r}" diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>'
                '<site name="carriage"/></body>')
    return (f'<mujoco><option timestep="{dt_s!r}" gravity="0 0 0" integrator="implicitfast"/>'
            f"<worldbody>{chain}{carriage}</worldbody>"
            f'<equality><connect site1="tip" site2="carriage" solref="{2 * dt_s!r} 1" solimp="0.9999 0.9999 0.001"/>'
            "</equality></mujoco>")


def solve_mujoco(case: Case, n: int, dt_s: float, tau_s: float, max_steps: int = MAX_STEPS) -> Relaxed:
    """The MuJoCo chain of ``n`` segments, ``implicitfast`` steps of ``dt_s`` (s)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mujoco_xml(case, n, dt_s, tau_s))
    data = mujoco.MjData(model)
    x, y = start_shape(case, n)
    theta = np.arctan2(np.diff(y), np.diff(x))
    qpos = np.zeros(2 * n + 1)
    qpos[1:2 * n:2] = np.diff(np.concatenate(([0.0], theta)))  # hinge angles; slides at 0
    qpos[-1] = x[-1]  # the carriage under the tip
    data.qpos[:] = qpos
    ds = case.free_length_m / n
    equality = mujoco.mjtConstraint.mjCNSTR_EQUALITY

    def advance(steps: int) -> None:
        mujoco.mj_step(model, data, nstep=steps)

    def tip_force() -> float:
        if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:  # diverged (MuJoCo reset the state)
            return math.nan
        # the connect's rows are the world x, y, z components of the force on the tip
        return data.efc_force[data.efc_type == equality][1]

    return relax(advance, tip_force, lambda: float(np.max(np.abs(data.cvel[1:n + 1, 2]))) * ds, max_steps)


# ---- the comparison -----------------------------------------------------------------------
@dataclass(frozen=True)
class Engine:
    """An engine: ``module`` is what it imports (None: evertgym itself); ``sweep`` its
    discretisations, coarse to fine; ``solve(case, discretisation, **setting)``;
    ``sweep_setting`` and ``grid`` give the solver settings of the sweep and of the tuning."""

    name: str
    module: str | None
    sweep: Sequence
    label: Callable[[Case, Any], str]
    solve: Callable[..., Relaxed]
    sweep_setting: Callable[[Case, Any], dict]
    grid: Callable[[Case, Any], list[dict]]

    def available(self) -> bool:
        return self.module is None or importlib.util.find_spec(self.module) is not None


def _product(**axes: Sequence[float]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = [{}]
    for key, values in axes.items():
        out = [dict(d, **{key: v}) for d in out for v in values]
    return out


ENGINES = (
    Engine("evertgym", None, EVERTGYM_SEGMENTS_M,
           lambda case, ds: f"segment_length_m={ds:g} ({max(2, round(case.free_length_m / ds))} segments)",
           solve_evertgym, lambda case, ds: {},
           lambda case, ds: _product(iterations=EVERTGYM_ITERATIONS, damping=EVERTGYM_DAMPING)),
    Engine("pyelastica", "elastica", PYELASTICA_ELEMENTS, lambda case, n: f"n_elements={n}", solve_pyelastica,
           lambda case, n: {"dt_s": PYELASTICA_SWEEP[0] * case.free_length_m / n, "damping_per_s": PYELASTICA_SWEEP[1]},
           lambda case, n: _product(dt_s=[c * case.free_length_m / n for c in PYELASTICA_DT_PER_M],
                                    damping_per_s=PYELASTICA_DAMPING)),
    Engine("mujoco", "mujoco", MUJOCO_SEGMENTS, lambda case, n: f"n_segments={n}", solve_mujoco,
           lambda case, n: {"dt_s": MUJOCO_SWEEP[0] * (case.free_length_m / n) ** 2, "tau_s": MUJOCO_SWEEP[1]},
           lambda case, n: _product(dt_s=[c * (case.free_length_m / n) ** 2 for c in MUJOCO_DT_PER_M2],
                                    tau_s=MUJOCO_TAU_S)),
)


def timed(solve: Callable[[], Relaxed], repeats: int = 1) -> tuple[Relaxed, float]:
    """A solve's result and its best wall-clock time (s) over ``repeats`` (at least one run)."""
    t0 = time.perf_counter()
    res = solve()
    best = time.perf_counter() - t0
    for _ in range(repeats - 1):
        t0 = time.perf_counter()
        res = solve()
        best = min(best, time.perf_counter() - t0)
    return res, best


def choose_discretisation(errors: Sequence[tuple[float, bool]], budget: float = ERROR_BUDGET) -> int | None:
    """Index of the coarsest entry of a coarse-to-fine sweep of ``(error, converged)`` from which
    every entry converged within ``budget``; None if the finest does not."""
    chosen = None
    for i in range(len(errors) - 1, -1, -1):
        err, ok = errors[i]
        if not (ok and abs(err) <= budget):
            break
        chosen = i
    return chosen


def bench_engine(engine: Engine, case: Case, reference_n: float, repeats: int = REPEATS) -> dict:
    """Sweep, choose, tune and time one engine: ``{"row": ..., "sweep": [...]}`` (see :func:`compare`)."""
    sweep: list[dict[str, Any]] = []
    for disc in engine.sweep:
        res = engine.solve(case, disc, **engine.sweep_setting(case, disc))  # the first also warms up
        sweep.append({"discretisation": engine.label(case, disc), "tip_force_error": force_error(res.force_n, reference_n),
                      "steps": res.steps, "converged": res.converged})
    i = choose_discretisation([(r["tip_force_error"], r["converged"]) for r in sweep])
    if i is None:
        return {"row": {"engine": engine.name, "discretisation": None, "tip_force_n": None, "tip_force_error": None,
                        "wall_s": None, "steps": None, "converged": False, "setting": None, "untuned_wall_s": None},
                "sweep": sweep}
    disc = engine.sweep[i]
    cap = TRIAL_STEPS_FACTOR * sweep[i]["steps"]  # a trial past this cannot be the fastest
    trials = []
    for setting in engine.grid(case, disc):
        res, wall = timed(functools.partial(engine.solve, case, disc, max_steps=cap, **setting), repeats)
        if res.converged and abs(force_error(res.force_n, reference_n)) <= ERROR_BUDGET:
            trials.append((wall, setting, res))
    if not trials:  # no tuned setting converged within the cap: the sweep setting, uncapped
        setting = engine.sweep_setting(case, disc)
        res, wall = timed(lambda: engine.solve(case, disc, **setting), repeats)
        trials.append((wall, setting, res))
    wall, setting, res = min(trials, key=lambda t: t[0])
    _, untuned = timed(lambda: engine.solve(case, disc, **engine.sweep_setting(case, disc)), repeats)
    row = {"engine": engine.name, "discretisation": engine.label(case, disc), "tip_force_n": res.force_n,
           "tip_force_error": force_error(res.force_n, reference_n), "wall_s": wall, "steps": res.steps,
           "converged": res.converged, "setting": setting, "untuned_wall_s": untuned}
    return {"row": row, "sweep": sweep}


def compare(case: Case | None = None, engine_names: Sequence[str] | None = None, repeats: int = REPEATS) -> dict:
    """The peer comparison.

    Returns ``{"case", "rows", "sweeps", "ratios", "criterion"}``: ``case`` the problem and the
    rod's ``reference_tip_force_n`` (N); a row per engine with ``engine``, ``discretisation``,
    ``tip_force_n`` (N), ``tip_force_error`` (relative, signed), ``wall_s`` (s, best of
    ``repeats``), ``steps``, ``converged``, ``setting`` (the tuned solver settings, SI) and
    ``untuned_wall_s`` (s, the same at the engine's sweep setting: evertgym's defaults), or
    ``{"engine", "skipped": pip command}`` when the engine is not installed; ``sweeps`` each
    engine's discretisation sweep; ``ratios`` ``pyelastica_over_evertgym`` and
    ``mujoco_over_evertgym`` (wall-time ratios, None when either side is missing).
    """
    case = case or default_case()
    ref = reference(case)
    rows, sweeps = [], {}
    for engine in ENGINES:
        if engine_names is not None and engine.name not in engine_names:
            continue
        if not engine.available():
            rows.append({"engine": engine.name, "skipped": f"not installed: {PIP_EXTRA}"})
            continue
        out = bench_engine(engine, case, ref["tip_force_n"], repeats)
        rows.append(out["row"])
        sweeps[engine.name] = out["sweep"]
    wall: dict[str, Any] = {r["engine"]: r.get("wall_s") for r in rows}

    def ratio(peer: str) -> float | None:
        a, b = wall.get(peer), wall.get("evertgym")
        return a / b if a and b else None

    return {
        "case": {"bands_from_tip_mm": list(BANDS_FROM_TIP_MM), "reduction": REDUCTION,
                 "free_length_m": case.free_length_m, "displacement_m": case.displacement_m,
                 "pressure_pa": case.pressure_pa, "reference_tip_force_n": ref["tip_force_n"],
                 "max_moment_fraction": ref["max_moment_fraction"], "wrinkled": ref["wrinkled"]},
        "rows": rows,
        "sweeps": sweeps,
        "ratios": {"pyelastica_over_evertgym": ratio("pyelastica"), "mujoco_over_evertgym": ratio("mujoco")},
        "criterion": {"error_budget": ERROR_BUDGET, "window_steps": WINDOW_STEPS, "force_tol": FORCE_TOL,
                      "speed_tol_m_per_s": SPEED_TOL_M_PER_S, "repeats": repeats},
    }


def _setting_text(setting: dict | None) -> str:
    return ", ".join(f"{k}={v:.3g}" for k, v in (setting or {}).items()) or "defaults"


def format_table(result: dict) -> list[str]:
    """The rows and ratios of :func:`compare`'s result as fixed-width text."""
    ref = result["case"]["reference_tip_force_n"]
    lines = [f"reference (Cosserat rod): tip_force_n = {ref:.6f}",
             f"{'engine':<11}{'discretisation':<38}{'tip_force_n':>12}{'tip_force_error':>16}{'wall_s':>9}"
             f"{'steps':>7}{'converged':>10}{'untuned_wall_s':>15}  setting"]
    for r in result["rows"]:
        if "skipped" in r:
            lines.append(f"{r['engine']:<11}skipped: {r['skipped']}")
        elif r["discretisation"] is None:
            lines.append(f"{r['engine']:<11}no discretisation of the sweep reached the {ERROR_BUDGET:.0%} budget")
        else:
            lines.append(f"{r['engine']:<11}{r['discretisation']:<38}{r['tip_force_n']:>12.6f}"
                         f"{r['tip_force_error']:>+15.2%} {r['wall_s']:>9.4f}{r['steps']:>7d}"
                         f"{'yes' if r['converged'] else 'no':>10}{r['untuned_wall_s']:>15.4f}  "
                         f"{_setting_text(r['setting'])}")
    for key, value in result["ratios"].items():
        peer = key.split("_over_")[0]
        lines.append(f"wall-time ratio {peer} / evertgym: " + (f"{value:.2f}" if value else "n/a"))
    return lines
