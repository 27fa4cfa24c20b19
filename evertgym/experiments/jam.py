"""Tables of jams: medians over groups of :func:`evertgym.sim.diagnostics.jam_anatomy` results.

``evertgym reproduce ubend --anatomy`` and ``python -m evertgym.experiments.ubend_jams`` print them.
"""

from __future__ import annotations

import statistics


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
