"""The one range check of the package: every boundary (design, model, simulator settings,
env, policies, CLI) reports a bad number the same way, in one line that names the field,
the value and the allowed range.  It imports nothing of the package, so every layer may use it.
"""

from __future__ import annotations

import math
import numbers


def check_range(
    name: str,
    value: object,
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
    Message: ``"<name> = <value> is out of range: allowed [lo, hi] unit"``.
    """
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if ok:
        v = float(value)  # type: ignore[arg-type]
        ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        lb, rb = ("(" if lo_open else "["), (")" if hi_open else "]")
        u = f" {unit}" if unit else ""
        raise error(f"{name} = {value!r} is out of range: allowed {lb}{lo:g}, {hi:g}{rb}{u}")
    return v
