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
import statistics

import numpy as np

from evertgym.sim.simulator import EversionSim


def _wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def _bodies_in_contact(sim: EversionSim) -> list[int]:
    """Indices of the dynamic robot bodies that touch something (walls; the chain's own
    shapes never collide)."""
    touching = []
    for j in range(sim.active_start, len(sim.bodies)):
        hit = []
        sim.bodies[j].each_arbiter(lambda arb: hit.append(arb))
        if hit:
            touching.append(j)
    return touching


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
    tip = len(sim.bodies) - 1
    ratios = np.abs(sim.joint_moments()) / np.maximum(sim.collapse_moments(), 1e-12)
    touching = [j for j in _bodies_in_contact(sim) if j < tip]
    last = touching[-1] if touching else sim.active_start - 1
    span_start = float(sim.nodes[last]) + sim.ds if last >= 0 else 0.0
    span_joints = range(max(last + 1, 0), tip + 1)

    s_tip, _ = scene.project(sim.tip_position)
    s_tip = float(np.atleast_1d(s_tip)[0])
    heading = float(np.interp(s_tip, scene.arclength, scene.heading))
    tip_heading = float(sim.bodies[-1].angle)
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


def _median(values: list[float]) -> float | None:
    return round(statistics.median(values), 2) if values else None


def summarise_jams(jams: list[dict]) -> dict:
    """Medians over a group of :func:`jam_anatomy` results (None for an empty group), the
    number of jams with a band inside the free span, and the nearest everted band's
    distance behind the tip."""
    with_bands = [j for j in jams if any(b["everted"] for b in j["bands"])]
    return {
        "jams": len(jams),
        "jam_channel_turn_deg": _median([j["channel_turn_deg"] for j in jams]),
        "jam_heading_error_deg": _median([j["heading_error_deg"] for j in jams]),
        "jam_free_span_mm": _median([j["free_span_mm"] for j in jams]),
        "jam_span_peak_moment_ratio": _median([j["span_peak_moment_ratio"] for j in jams]),
        "jam_band_peak_moment_ratio": _median([max(b["peak_moment_ratio"] for b in j["bands"]) for j in jams if j["bands"]]),
        "jams_with_band_in_span": sum(any(b["in_free_span"] for b in j["bands"]) for j in jams),
        "jam_nearest_band_behind_tip_mm": _median([min(b["behind_tip_mm"] for b in j["bands"] if b["everted"]) for j in with_bands]),
        "jam_pressure_margin_kpa": _median([j["pressure_margin_kpa"] for j in jams]),
    }


JAM_COLUMNS = (
    ("turn at jam (deg)", "jam_channel_turn_deg"),
    ("tip heading error (deg)", "jam_heading_error_deg"),
    ("free span (mm)", "jam_free_span_mm"),
    ("span max M/Mc", "jam_span_peak_moment_ratio"),
    ("band max M/Mc", "jam_band_peak_moment_ratio"),
    ("nearest band behind tip (mm)", "jam_nearest_band_behind_tip_mm"),
    ("jams with a band in the span", "jams_with_band_in_span"),
    ("pressure margin (kPa)", "jam_pressure_margin_kpa"),
)


def jam_table(rows: list[dict], lead: tuple[tuple[str, str], ...]) -> str:
    """A markdown table of ``rows``: the ``lead`` columns (header, key), then the
    :func:`summarise_jams` columns; '-' where a median is undefined."""
    cols = tuple(lead) + JAM_COLUMNS
    head = "| " + " | ".join(c for c, _ in cols) + " |\n|" + "---|" * len(cols) + "\n"
    body = "".join("| " + " | ".join("-" if r.get(k) is None else str(r[k]) for _, k in cols) + " |\n" for r in rows)
    return head + body
