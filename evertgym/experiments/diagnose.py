"""Diagnostics a physicist asks for, for one U-bend trial: the section law over time.

``evertgym diagnose`` plays one trial of ``evertgym reproduce ubend`` (the same spec: radius,
band reduction, trial seed) and samples :func:`evertgym.sim.diagnostics.section_state` at every
control step: each active joint's wall tension ``T_wall`` and ``|M| / M_c``, and the tip's wall
force against the capacity of the weakest section behind it.  :func:`plot_trace` draws it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from evertgym.agents.evaluate import run_episode
from evertgym.agents.policies import make_policy
from evertgym.experiments.paper import ubend_specs
from evertgym.experiments.plots import _pyplot, save_figure
from evertgym.experiments.trial import GIVE_UP_S, make_trial_env
from evertgym.sim.diagnostics import section_state


def trace_ubend(radius_mm: float, reduction: float = 0.0, seed: int = 0, sim: dict | None = None,
                scene_params: dict | None = None) -> dict[str, Any]:
    """The section-law trace of one ``reproduce ubend`` trial (JSON-ready); ``sim`` overrides
    :class:`~evertgym.sim.config.SimConfig` fields, ``scene_params`` the U-bend's parameters."""
    spec = ubend_specs(trials=seed + 1, radii=(radius_mm,), reductions=(reduction,), sim=sim, scene_params=scene_params)[seed]
    env = make_trial_env(spec)
    policy = make_policy(dict(spec.policy))
    samples: list[dict] = []
    stalled_s = 0.0

    def record(env: Any, info: dict) -> bool:
        nonlocal stalled_s
        samples.append(section_state(env.sim))
        stalled_s = stalled_s + env.control_dt if env.sim.stalled else 0.0
        return stalled_s >= GIVE_UP_S

    info = run_episode(env, policy, int(spec.seed), stop=record)
    bands = [b.position_m * 1e3 for b in env.sim.design.bands]
    return {"radius_mm": radius_mm, "reduction": reduction, "seed": seed, "success": bool(info["success"]),
            "section_law": env.sim.cfg.section_law, "engine": env.sim.cfg.engine,
            "casing_friction": float(env.scene.params["wall_friction"]),
            "bands_mm": [round(b, 1) for b in bands], "bend_start_mm": float(env.scene.params["pipe_length_mm"]),
            "samples": samples}


def plot_trace(trace: dict[str, Any], path: str | Path) -> Path:
    """Three panels over time: the tip's wall force against its capacity; ``|M| / M_c`` along
    the body (colour); the wall tension along the body (colour), bands and bend start marked."""
    plt = _pyplot()
    s = trace["samples"]
    t = np.array([x["t_s"] for x in s])
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    ax = axes[0]
    ax.plot(t, [x["tip_force_n"] for x in s], label="wall force on the tip")
    if s and s[0].get("push_capacity_n") is not None:  # the quasi-static engine: the push the growth law allows
        ax.plot(t, [x["tip_axial_force_n"] for x in s], label="its part against growth")
        ax.plot(t, [x["push_capacity_n"] for x in s], "--", label="push the tip can deliver at this pressure")
    else:
        ax.plot(t, [x["tip_capacity_n"] for x in s], "--", label="capacity of the weakest section")
    ax.set_ylabel("N")
    ax.legend(fontsize=8)
    outcome = "passed" if trace["success"] else "jammed"
    design = "no bands" if trace["reduction"] == 0 else f"3 x {round(trace['reduction'] * 100)}%"
    engine = trace.get("engine", "dynamic")
    model = "quasi-static" if engine == "quasistatic" else ("dynamic, section law" if trace["section_law"] else "dynamic, rigid column")
    ax.set_title(f"U-bend {trace['radius_mm']:g} mm, {design}, trial {trace['seed']} ({model}, casing "
                 f"{trace['casing_friction']:g}): {outcome}")
    for ax, key, label, vmin, vmax, cmap in ((axes[1], "moment_ratio", "|M| / M_c", 0.0, 1.0, "viridis"),
                                             (axes[2], "wall_tension_n", "T_wall (N)", None, None, "coolwarm")):
        xs, ys, cs = [], [], []
        for x in s:
            xs += [x["t_s"]] * len(x["joint_mm"])
            ys += x["joint_mm"]
            cs += x[key]
        sc = ax.scatter(xs, ys, c=cs, s=4, marker="s", cmap=cmap, vmin=vmin, vmax=vmax)
        fig.colorbar(sc, ax=ax, label=label)
        for b in trace["bands_mm"]:
            ax.axhline(b, color="k", lw=0.6, ls=":")
        ax.axhline(trace["bend_start_mm"], color="tab:red", lw=0.8, ls="--")
        ax.set_ylabel("body position (mm)")
    axes[2].set_xlabel("time (s)")
    return save_figure(fig, path)
