"""Anatomy of a stalled robot: where it jammed and what holds it there.

A robot that stalls in a bend is held by a balance at its tip: the wall's reaction on the
tip cancels the pressure's push along the tip (growth needs ``p`` above the tip's required
pressure), and the reaction's sideways part has to turn the *free span*, the stretch of body
between the last wall contact behind the tip and the tip itself.  The span turns only as far
as its joints' moment allows; each joint kinks at its collapse moment ``M_c = p pi r^3``.
A band lowers ``M_c`` where it lies, so it can release a jam only from inside the span.

:func:`jam_anatomy` measures all of this on a finished simulation (SI inside, mm, degrees,
kPa and N in the keys).  Every failed scored trial records it under ``"jam"``;
:func:`summarise_jams` and :func:`jam_table` condense a group of them, as
``evertgym reproduce ubend --anatomy`` and ``scripts/ubend_jam_anatomy.py`` do.
"""

from __future__ import annotations

import math

import numpy as np

from evertgym.sim.simulator import EversionSim


def _wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def jam_anatomy(sim: EversionSim, scene) -> dict:
    """Measure the tip region of ``sim`` (in ``scene``) as it is now.

    Keys: ``insertion_mm``; ``channel_turn_deg`` (how far the channel has turned at the
    tip's projection, 0 at the entry); ``heading_error_deg`` (tip heading minus the
    channel's, positive to the left); ``tip_axial_force_n`` (the wall's push against growth)
    and ``tip_lateral_force_n`` (its sideways part, positive to the tip's left);
    ``free_span_mm`` (body from the last wall contact behind the tip to the tip);
    ``span_peak_moment_ratio`` (largest ``|M| / M_c`` of the joints in the free span);
    ``bands`` (each band's distance behind the tip, whether it lies in the free span, and
    its largest ``|M| / M_c``); ``pressure_margin_kpa`` (pressure minus the pressure the tip
    needs to grow: negative or zero while it is stalled).
    """
    tip = len(sim.radii()) - 1
    ratios = np.abs(sim.joint_moments()) / np.maximum(sim.collapse_moments(), 1e-12)
    touching = [j for j in sim.segments_in_contact() if j < tip]
    last = touching[-1] if touching else sim.active_start - 1
    span_start = float(sim.nodes[last]) + sim.ds if last >= 0 else 0.0
    span_joints = range(max(last + 1, 0), tip + 1)

    s_tip, _ = scene.project(sim.tip_position)
    s_tip = float(np.atleast_1d(s_tip)[0])
    heading = float(np.interp(s_tip, scene.arclength, scene.heading))
    tip_heading = float(sim.tip_angle)
    t = sim.tip_direction
    left = np.array([-t[1], t[0]])
    f = np.asarray(sim.tip_contact, float)

    bands = []
    for b in sim.design.bands:
        lo, hi = b.position_m - b.width_m / 2 - sim.ds, b.position_m + b.width_m / 2 + sim.ds
        joints = [j for j in range(len(ratios)) if lo <= sim.nodes[j] <= hi]
        bands.append(
            {
                "behind_tip_mm": round((sim.length - b.position_m) * 1e3, 1),
                "in_free_span": bool(span_start <= b.position_m <= sim.length),
                "everted": bool(b.position_m <= sim.length),
                "peak_moment_ratio": round(float(max(ratios[joints])) if joints else 0.0, 3),
            }
        )
    return {
        "insertion_mm": round(sim.length * 1e3, 1),
        "channel_turn_deg": round(math.degrees(heading - float(scene.heading[0])), 1),
        "heading_error_deg": round(_wrap_deg(math.degrees(tip_heading - heading)), 1),
        "tip_axial_force_n": round(sim.tip_force, 3),
        "tip_lateral_force_n": round(float(f @ left), 3),
        "free_span_mm": round((sim.length - span_start) * 1e3, 1),
        "span_peak_moment_ratio": round(float(max(ratios[j] for j in span_joints)), 3),
        "bands": bands,
        "pressure_margin_kpa": round((sim.pressure - sim.required_pressure()) / 1e3, 3),
    }


def section_state(sim: EversionSim) -> dict:
    """The section law's state of ``sim`` now (SI in, mm / N in the keys): per active joint its
    material position, wall tension ``T_wall``, ``|M| / M_c`` and fold capacity, and the tip's
    wall force against the capacity of the weakest section behind it."""
    a = sim.active_start
    ratios = np.abs(sim.joint_moments(a)) / np.maximum(sim.collapse_moments(a), 1e-12)
    n = min(len(ratios), len(sim.wall_tension))
    return {
        "t_s": round(sim.t, 4),
        "insertion_mm": round(sim.length * 1e3, 2),
        "pressure_kpa": round(sim.pressure / 1e3, 4),
        "joint_mm": [round(float(x) * 1e3, 2) for x in sim.nodes[a : a + n]],
        "wall_tension_n": [round(float(x), 4) for x in sim.wall_tension[:n]],
        "moment_ratio": [round(float(x), 4) for x in ratios[:n]],
        "capacity_n": [round(float(x), 4) for x in sim.compression_capacity[:n]],
        "tip_force_n": round(float(math.hypot(*sim.tip_contact)), 4),
        "tip_axial_force_n": round(sim.tip_force, 4),
        "tip_capacity_n": round(sim.tip_capacity, 4),
        "push_capacity_n": round(sim.push_capacity, 4) if hasattr(sim, "push_capacity") else None,
        "kinked_joints_mm": [round(float(sim.nodes[j]) * 1e3, 2) for j in sim.kinked_joints],
    }
