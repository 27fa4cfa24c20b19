"""The one set of checks of the package: every boundary (design, model, simulator settings,
scenes, env, policies, CLI) reports a bad value the same way, in one line that names the
field, the value and the allowed range.  It imports nothing of the package, so every layer
may use it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def check_number(field: str, value: Any, error: type[ValueError] = ValueError) -> float:
    """``value`` as a finite float; bools, strings, complex and out-of-float-range integers raise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise error(f"{field} = {value!r:.80} is not a number")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v):
        raise error(f"{field} = {value!r:.80} is not a finite number")
    return v


def check_range(
    field: str,
    value: Any,
    lo: float,
    hi: float,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    error: type[ValueError] = ValueError,
) -> float:
    """``value`` as a float if it is a finite real number in the interval, else ``error``.

    The interval is ``[lo, hi]``, opened at either end by ``lo_open`` / ``hi_open``; ``unit``
    is appended to the message (``"mm"``, ``"kPa"``).  Booleans are not numbers here.
    Message: ``"<field> = <value> is out of range: allowed [lo, hi] unit"``.
    """
    try:
        v = check_number(field, value, error)
        ok = (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    except ValueError:
        ok = False
    if not ok:
        lb, rb = ("(" if lo_open else "["), (")" if hi_open else "]")
        u = f" {unit}" if unit else ""
        raise error(f"{field} = {value!r:.80} is out of range: allowed {lb}{lo:g}, {hi:g}{rb}{u}")
    return v


def check_int(field: str, value: Any, lo: int, hi: int, unit: str = "", error: type[ValueError] = ValueError) -> int:
    """``value`` as an int in [lo, hi] (bools refused), else one line naming the field."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise error(f"{field} = {value!r:.80} is out of range: allowed integers in [{lo}, {hi}] {unit}".rstrip())
    return int(value)


def check_bool(field: str, value: Any, error: type[ValueError] = ValueError) -> bool:
    """``value`` if it is a bool (``"no"`` is not false: it is refused)."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{field} = {value!r:.80} is not allowed: allowed true or false")
    return bool(value)


def check_pair(field: str, value: Any, lo: float, hi: float, unit: str = "", error: type[ValueError] = ValueError) -> tuple[float, float]:
    """A ``(lo, hi)`` pair of numbers in [lo, hi] with ``pair[0] <= pair[1]``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise error(f"{field} = {value!r:.80} is not a [lo, hi] pair: allowed both in [{lo:g}, {hi:g}] {unit}".rstrip())
    a, b = (check_range(field, v, lo, hi, unit=unit, error=error) for v in value)
    if a > b:
        raise error(f"{field} = {value!r} has lo > hi: allowed [lo, hi] with lo <= hi, both in [{lo:g}, {hi:g}] {unit}".rstrip())
    return a, b
