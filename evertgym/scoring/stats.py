"""Success rates with Wilson score intervals, and per-group summaries of scored trials.

The Wilson interval (Wilson 1927; method 3 in Newcombe, Stat. Med. 17:857, 1998) keeps its
coverage near nominal for the small trial counts of a sweep (tens per design) and stays
inside [0, 1], where the normal (Wald) interval collapses to a point at 0/n and n/n.
The difference of two independent success rates gets Newcombe's hybrid score interval
(method 10 of the same paper), built from the two Wilson intervals.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence
from typing import Any

from evertgym.scoring.store import TrialRecord

#: Result keys whose medians :func:`summarize` reports, and the output column of each.
MEDIAN_KEYS = {
    "time_s": "median_time_s",
    "peak_pressure_kpa": "median_peak_pressure_kpa",
    "max_contact_force_n": "median_max_contact_force_n",
    "stall_position_mm": "median_stall_position_mm",
}


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval ``(lo, hi)`` for ``successes`` out of ``n`` Bernoulli trials.

    ``z`` is the standard normal quantile (1.96 for 95%).  Requires ``n >= 1``,
    ``0 <= successes <= n`` and ``z > 0``; the bounds are exactly 0 at 0/n and 1 at n/n.
    """
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"n = {n!r} is out of range: allowed an integer >= 1")
    if isinstance(successes, bool) or int(successes) != successes or not 0 <= successes <= n:
        raise ValueError(f"successes = {successes!r} is out of range: allowed an integer in [0, {n}]")
    if not (math.isfinite(z) and z > 0):
        raise ValueError(f"z = {z!r} is out of range: allowed (0, inf)")
    p = successes / n
    z2n = z * z / n
    centre = (p + z2n / 2) / (1 + z2n)
    half = z / (1 + z2n) * math.sqrt(p * (1 - p) / n + z2n / (4 * n))
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def newcombe_interval(successes_a: int, n_a: int, successes_b: int, n_b: int, z: float = 1.96) -> tuple[float, float, float]:
    """The difference of two independent success rates, ``p_a - p_b``, with Newcombe's hybrid
    score interval (method 10 of Newcombe, Stat. Med. 17:873, 1998): ``(difference, lo, hi)``.

    With Wilson intervals ``(l_a, u_a)`` and ``(l_b, u_b)`` (quantile ``z``),
    ``lo = d - sqrt((p_a - l_a)^2 + (u_b - p_b)^2)`` and
    ``hi = d + sqrt((u_a - p_a)^2 + (p_b - l_b)^2)``; the bounds stay inside [-1, 1].
    Newcombe's Table II: 56/70 against 48/80 gives 0.2000 [0.0524, 0.3339].
    """
    l_a, u_a = wilson_interval(successes_a, n_a, z)
    l_b, u_b = wilson_interval(successes_b, n_b, z)
    p_a, p_b = successes_a / n_a, successes_b / n_b
    d = p_a - p_b
    lo = d - math.sqrt((p_a - l_a) ** 2 + (u_b - p_b) ** 2)
    hi = d + math.sqrt((u_a - p_a) ** 2 + (p_b - l_b) ** 2)
    return d, max(-1.0, lo), min(1.0, hi)


def compare_rates(name_a: str, successes_a: int, n_a: int, name_b: str, successes_b: int, n_b: int,
                  z: float = 1.96) -> dict[str, Any]:
    """``name_a`` against ``name_b``: the difference of their success rates with its Newcombe
    interval (:func:`newcombe_interval`) and a one-line verdict, which names a winner only
    when the interval excludes 0.  Keys: ``design``, ``other``, ``difference``, ``ci_lo``,
    ``ci_hi``, ``winner`` (a name or None) and ``verdict``."""
    d, lo, hi = newcombe_interval(successes_a, n_a, successes_b, n_b, z)
    winner = name_a if lo > 0 else name_b if hi < 0 else None
    if winner is None:
        verdict = (f"no clear winner between {name_a} and {name_b}: the 95% interval of the difference includes 0 "
                   "(more trials narrow it)")
    else:
        loser = name_b if winner == name_a else name_a
        verdict = f"{winner} succeeds more often than {loser}: the 95% interval of the difference excludes 0"
    return {"design": name_a, "other": name_b, "difference": d, "ci_lo": lo, "ci_hi": hi, "winner": winner, "verdict": verdict}


_MISSING = object()


def _lookup(record: TrialRecord, path: str) -> Any:
    """A spec field or a dotted path into a spec dict, e.g. ``"scene.params.radius_mm"``."""
    head, *rest = path.split(".")
    value = record.spec.to_dict().get(head, _MISSING)
    for part in rest:
        value = value.get(part, _MISSING) if isinstance(value, dict) else _MISSING
    if value is _MISSING:
        raise ValueError(
            f"by = {path!r} is not in {record.spec.describe()}: allowed a TrialSpec field "
            "(design_name, group, seed, index, ...) or a dotted path into one, e.g. 'scene.params.radius_mm'"
        )
    return value


def _sort_key(values: tuple) -> tuple:
    """Order groups: numbers by value, then strings, then anything else by its repr."""
    return tuple(
        (0, v, "") if isinstance(v, (int, float)) and not isinstance(v, bool) else
        (1, 0, v) if isinstance(v, str) else (2, 0, repr(v))
        for v in values
    )


def _hashable(value: Any) -> Any:
    return repr(value) if isinstance(value, (dict, list)) else value


def summarize(
    records: Iterable[TrialRecord], by: str | Sequence[str] = "design_name", z: float = 1.96
) -> list[dict[str, Any]]:
    """Per group: trial count, success rate with its Wilson interval, and result medians.

    ``by`` names a :class:`TrialSpec` field (``design_name``, ``group``, ...) or a dotted
    path into one of its dicts (``"scene.params.radius_mm"``, ``"policy.pressure_kpa"``), or
    a sequence of those.  One dict per group, sorted by the group values, with the ``by``
    names as keys plus ``n``, ``successes``, ``success_rate``, ``success_ci_lo`` and
    ``success_ci_hi`` (Wilson, quantile ``z``), the medians of :data:`MEDIAN_KEYS` over the
    group's trials whose value is not ``None`` (``None`` when no trial has a value), and
    ``n_stalled`` (trials with a stall position), ``unconverged_solves`` (the quasi-static solves of
    the group's trials that ended above the tolerance) and ``trials_unconverged`` (trials with any).
    """
    names = [by] if isinstance(by, str) else list(by)
    if not names:
        raise ValueError("by = [] is not allowed: allowed a field name or a non-empty sequence of them")
    groups: dict[tuple, tuple[tuple, list[TrialRecord]]] = {}
    for rec in records:
        values = tuple(_lookup(rec, name) for name in names)
        groups.setdefault(tuple(map(_hashable, values)), (values, []))[1].append(rec)
    rows = []
    for values, recs in sorted(groups.values(), key=lambda g: _sort_key(g[0])):
        n = len(recs)
        k = sum(1 for r in recs if r.result["success"])
        lo, hi = wilson_interval(k, n, z)
        row: dict[str, Any] = dict(zip(names, values))
        row.update(n=n, successes=k, success_rate=k / n, success_ci_lo=lo, success_ci_hi=hi)
        for key, column in MEDIAN_KEYS.items():
            vals = [r.result[key] for r in recs if r.result.get(key) is not None]
            row[column] = statistics.median(vals) if vals else None
        row["n_stalled"] = sum(1 for r in recs if r.result.get("stall_position_mm") is not None)
        # the quasi-static engine's solves that ended above the tolerance, and the trials that had any
        # (their outcome may be the solver settings'): never hidden from a summary
        failed = [int(r.result.get("unconverged_solves", r.result.get("solve_failures", 0)) or 0) for r in recs]
        row["unconverged_solves"] = sum(failed)
        row["trials_unconverged"] = sum(1 for f in failed if f > 0)
        rows.append(row)
    return rows
