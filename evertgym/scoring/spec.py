"""Trial identity and trial results: what one scored trial is, and what it must return.

A :class:`TrialSpec` is plain JSON-able data (a design-file dict, a scene spec dict, a policy
dict, a seed, an index and a group label).  Its :attr:`TrialSpec.key` is the SHA-256 of the
canonical JSON of all fields, so the same trial always has the same key, in any process and
on any machine; the result store and the resuming runner use nothing else to tell trials
apart.  Canonical JSON sorts keys and keeps JSON's types, so ``3`` and ``3.0`` are different
values (and different keys): build specs from the same source when a run is resumed.

A trial result is a ``dict`` with at least the keys of :data:`REQUIRED_RESULT_KEYS` (units in
the names, mm/kPa/N/s at this edge) and any further JSON-able keys.
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any

#: A trial's result: :data:`REQUIRED_RESULT_KEYS` plus free extra keys (JSON-able values).
TrialResult = dict[str, Any]

#: Required result keys and what each may hold.
REQUIRED_RESULT_KEYS: dict[str, str] = {
    "success": "a bool",
    "time_s": "a finite number (s)",
    "peak_pressure_kpa": "a finite number (kPa)",
    "max_contact_force_n": "a finite number (N)",
    "stall_position_mm": "a finite number (mm) or None",
}

#: Largest seed or index: SQLite stores integers as signed 64-bit.
MAX_INT = 2**63 - 1


class TrialSpecError(ValueError):
    """An invalid trial spec field; the message names the field and what is allowed."""


class TrialResultError(ValueError):
    """A trial result that lacks a required key or holds a wrong value; the message names it."""


def _json_default(value: Any) -> Any:
    """Convert numpy scalars and arrays (without importing numpy) for :func:`json.dumps`."""
    if hasattr(value, "tolist") and callable(value.tolist):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def canonical_json(value: Any) -> str:
    """Deterministic compact JSON: sorted keys, no NaN/inf, numpy values as Python values.

    Raises ``ValueError`` (NaN/inf) or ``TypeError`` (non-JSON object) for values that have
    no canonical JSON form.
    """
    return json.dumps(
        value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False, default=_json_default
    )


def _plain(field: str, value: Any, err: type[ValueError]) -> Any:
    """``value`` as plain JSON data (a deep copy), or ``err`` naming ``field``."""
    try:
        return json.loads(canonical_json(value))
    except (TypeError, ValueError) as exc:
        raise err(f"{field} = {value!r} is not JSON data (finite numbers, strings, lists, dicts): {exc}") from None


def _check_int(field: str, value: Any, allow_none: bool = False) -> int | None:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 0 <= int(value) <= MAX_INT:
        allowed = f"an integer in [0, {MAX_INT}]" + (" or None" if allow_none else "")
        raise TrialSpecError(f"{field} = {value!r} is not allowed: allowed {allowed}")
    return int(value)


def _check_str(field: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise TrialSpecError(f"{field} = {value!r} is not allowed: allowed a non-empty string")
    return value


def _check_dict(field: str, value: Any) -> dict:
    if not isinstance(value, Mapping):
        raise TrialSpecError(f"{field} = {value!r} is not allowed: allowed a dict")
    return _plain(field, dict(value), TrialSpecError)


@dataclass(frozen=True)
class TrialSpec:
    """One trial: a design on a scene under a policy, with a seed.

    Fields (validated on construction; the dicts are deep-copied to plain JSON data, so later
    changes to the caller's dicts do not change the trial; treat them as read-only):

    - ``design``: a design-file dict (``evertgym.design`` units: mm in the keys).
    - ``design_name``: a label for the design (non-empty string).
    - ``scene``: ``{"family": str, "params": dict (mm, deg), "seed": int >= 0 or None}`` plus
      any further keys the trial function reads (e.g. an ``episode`` table).
    - ``policy``: ``{"name": str, ...}``, e.g. ``{"name": "constant", "pressure_kpa": 3.0}``.
    - ``seed``: the trial's seed, an integer in ``[0, 2**63 - 1]``.
    - ``index``: the trial's number within its sweep, same range.
    - ``group``: a grouping label, e.g. ``"r25"`` for a bend radius (non-empty string).
    """

    design: dict
    design_name: str
    scene: dict
    policy: dict
    seed: int
    index: int
    group: str

    def __post_init__(self) -> None:
        scene = _check_dict("scene", self.scene)
        missing = sorted({"family", "params", "seed"} - set(scene))
        if missing:
            raise TrialSpecError(
                f"scene = {self.scene!r} lacks keys {missing}: allowed a dict with family, params, seed "
                "and optional further keys"
            )
        _check_str("scene.family", scene["family"])
        _check_dict("scene.params", scene["params"])
        _check_int("scene.seed", scene["seed"], allow_none=True)
        policy = _check_dict("policy", self.policy)
        _check_str("policy.name", policy.get("name"))
        object.__setattr__(self, "design", _check_dict("design", self.design))
        object.__setattr__(self, "scene", scene)
        object.__setattr__(self, "policy", policy)
        object.__setattr__(self, "design_name", _check_str("design_name", self.design_name))
        object.__setattr__(self, "group", _check_str("group", self.group))
        object.__setattr__(self, "seed", _check_int("seed", self.seed))
        object.__setattr__(self, "index", _check_int("index", self.index))

    def to_dict(self) -> dict[str, Any]:
        """All fields as a JSON-ready dict (the inverse of :meth:`from_dict`)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TrialSpec:
        """A spec from :meth:`to_dict` output; every field is required, no other key allowed."""
        names = {f.name for f in fields(cls)}
        if not isinstance(d, Mapping) or set(d) != names:
            got = sorted(d) if isinstance(d, Mapping) else repr(d)
            raise TrialSpecError(f"trial spec keys {got}: allowed exactly {', '.join(sorted(names))}")
        return cls(**d)

    @cached_property
    def key(self) -> str:
        """SHA-256 hex digest of the canonical JSON of all fields: the trial's identity."""
        return hashlib.sha256(canonical_json(self.to_dict()).encode("utf-8")).hexdigest()

    def __hash__(self) -> int:
        return hash(self.key)

    def describe(self) -> str:
        """A short human label: index, design, group, seed and the key's first 12 hex digits."""
        return (
            f"trial {self.index} (design {self.design_name!r}, group {self.group!r}, "
            f"seed {self.seed}, key {self.key[:12]})"
        )


def check_result(result: Any) -> TrialResult:
    """Validate a trial result and return it as plain JSON data (a deep copy).

    ``success`` must be a bool (numpy's bool is accepted), ``time_s``, ``peak_pressure_kpa``
    and ``max_contact_force_n`` finite numbers, ``stall_position_mm`` a finite number or
    ``None``; extra keys must be JSON-able (numpy values are converted).  Raises
    :class:`TrialResultError` naming the offending key.
    """
    if not isinstance(result, Mapping):
        raise TrialResultError(f"a trial result must be a dict, got {type(result).__name__}")
    missing = [k for k in REQUIRED_RESULT_KEYS if k not in result]
    if missing:
        raise TrialResultError(f"the trial result lacks required keys {missing}: got keys {sorted(map(str, result))}")
    for name, allowed in REQUIRED_RESULT_KEYS.items():
        v = result[name]
        if name == "success":
            ok = isinstance(v, bool) or getattr(getattr(v, "dtype", None), "kind", None) == "b"
        elif v is None:
            ok = name == "stall_position_mm"
        else:
            ok = isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
        if not ok:
            raise TrialResultError(f"{name} = {v!r} is not allowed: allowed {allowed}")
    plain = _plain("result", {str(k): v for k, v in result.items()}, TrialResultError)
    for name in ("time_s", "peak_pressure_kpa", "max_contact_force_n", "stall_position_mm"):
        if plain[name] is not None:
            plain[name] = float(plain[name])
    return plain
