"""The paper's virtual tensile test, run in pymunk on the segment chain.

The last ``free_length`` of the everted body is a clamped chain (joint stiffness from
:mod:`evertgym.sim.discretize`, the non-linear joint law, mass scaling and compensated
damping as in the simulator).  The tip is held on a horizontal groove at
``y = displacement`` (free to slide along x and to rotate, like the tester's pure lateral
pull); the chain starts in the small-deflection shape and relaxes to equilibrium.  The
lateral force is the groove's constraint impulse over the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk

from evertgym.design import TubeDesign
from evertgym.model.params import ModelParams, load_params
from evertgym.model.section import TubeSection
from evertgym.sim.config import SimConfig
from evertgym.sim.discretize import joint_law, segment_inertia
from evertgym.sim.links import make_link


@dataclass
class TensileResult:
    force_n: float
    n_per_m: float
    tip_x_m: float
    tip_angle_rad: float
    steps: int
    converged: bool
    kinked_joints: int


def sim_tensile_test(
    design: TubeDesign,
    displacement_m: float = 0.02,
    pressure_pa: float = 6900.0,
    free_length_m: float | None = None,
    config: SimConfig | None = None,
    params: ModelParams | None = None,
    max_steps: int = 60000,
    tol: float = 2e-6,
) -> TensileResult:
    """Lateral force (N) holding the tip ``displacement_m`` off the clamp line, in pymunk."""
    cfg = config or SimConfig()
    params = params or load_params()
    L = params.free_length_m if free_length_m is None else free_length_m
    s_base, s_tip = design.length_m - L, design.length_m
    n = max(2, int(round(L / cfg.segment_length_m)))
    ds = L / n
    nodes = s_base + ds * np.arange(n)
    section = TubeSection(design, pressure_pa, params)
    law = joint_law(section, nodes, s_tip)
    beta = cfg.damping**cfg.dt_s

    space = pymunk.Space()
    space.iterations = cfg.iterations
    space.damping = cfg.damping
    k_max = np.maximum(law.stiffness, np.append(law.stiffness[1:], law.stiffness[-1]))
    ks_max = np.maximum(law.shear_stiffness, np.append(law.shear_stiffness[1:], law.shear_stiffness[-1]))
    # small-deflection start: y = d (3 xi^2 - xi^3) / 2
    xi = np.arange(n + 1) / n
    y = displacement_m * (3 * xi**2 - xi**3) / 2
    x = np.concatenate(([0.0], np.cumsum(np.sqrt(np.maximum(ds**2 - np.diff(y) ** 2, 1e-30)))))
    bodies, springs = [], []
    prev, prev_anchor = space.static_body, (0.0, 0.0)
    for j in range(n):
        inertia, mass = segment_inertia(cfg, k_max[j], ks_max[j], ds)
        body = pymunk.Body(mass, inertia)
        body.center_of_gravity = (ds / 2, 0.0)  # first: later it would move the origin
        body.angle = math.atan2(y[j + 1] - y[j], x[j + 1] - x[j])  # then the angle, then the origin
        body.position = (x[j], y[j])
        link = make_link(prev, body, prev_anchor, (0.0, 1.0), ds, float(law.stiffness[j]), float(law.shear_stiffness[j]), beta)
        space.add(body, *link.constraints)
        bodies.append(body)
        springs.append(link.bend)
        prev, prev_anchor = body, (ds, 0.0)
    groove = pymunk.GrooveJoint(space.static_body, bodies[-1], (-10.0, displacement_m), (10.0, displacement_m), (ds, 0.0))
    space.add(groove)

    force, last, steps, converged = 0.0, None, 0, False
    window = 100
    for steps in range(1, max_steps + 1):
        space.step(cfg.dt_s)
        if steps % cfg.law_interval == 0:
            ang = np.array([b.angle for b in bodies])
            phi = ang - np.concatenate(([0.0], ang[:-1]))
            m = law.moment(phi)
            sec = np.where(np.abs(phi) > 1e-12, m / np.where(phi == 0, 1, phi), law.stiffness)
            for s, kk in zip(springs, sec):
                s.stiffness = float(kk) / beta
        if steps % window == 0:
            force = groove.impulse / cfg.dt_s
            if last is not None and abs(force - last) <= tol * max(abs(force), 1e-9):
                omega = max(abs(b.angular_velocity) for b in bodies)
                if omega * ds < 1e-7:
                    converged = True
                    break
            last = force
    ang = np.array([b.angle for b in bodies])
    phi = ang - np.concatenate(([0.0], ang[:-1]))
    tip = bodies[-1].local_to_world((ds, 0.0))
    # the groove impulse is signed along its normal; report the force pulling the tip to +y
    f = abs(force) * (1 if displacement_m >= 0 else -1)
    return TensileResult(
        force_n=f,
        n_per_m=f / displacement_m if displacement_m else float("nan"),
        tip_x_m=float(tip.x),
        tip_angle_rad=float(ang[-1]),
        steps=steps,
        converged=converged,
        kinked_joints=int(np.sum(law.kinked(law.moment(phi)))),
    )
