"""Scene specifications: a family name, its parameters (mm and degrees) and a seed.

A :class:`SceneSpec` is plain data, so an environment preset can name a scene in a file::

    {"family": "ubend", "params": {"radius_mm": 25.0}, "seed": null}

Every parameter is declared by a :class:`Param` (default, allowed range, unit); a spec is
validated when it is constructed and raises :class:`SceneError` (a ``ValueError``) naming
the field and its allowed range, e.g. ``radius_mm = 10 is out of range: allowed [20, 40] mm``.
Parameters left out take the family's defaults.  Inside the package everything is SI;
only the parameters carry mm and degrees, with the unit in the key.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from evertgym.scenes.registry import FAMILIES


class SceneError(ValueError):
    """An invalid scene family, parameter or seed; the message names the field and what is allowed."""


def fmt_value(v: Any) -> str:
    """A parameter value as shown in messages: `%g` numbers, `[a, b]` pairs, quoted strings."""
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt_value(x) for x in v) + "]"
    return repr(v) if isinstance(v, str) else str(v)


@dataclass(frozen=True)
class Param:
    """Declaration of one scene parameter.

    ``kind`` is one of ``"float"``, ``"int"``, ``"bool"``, ``"choice"``, ``"float_range"``
    and ``"int_range"``; a range parameter is a ``[min, max]`` pair whose ends both lie in
    ``[lo, hi]`` (a single number ``v`` stands for ``[v, v]``).  ``lo_open`` makes the lower
    bound exclusive (an angle in ``(0, 180]``).
    """

    default: Any
    kind: str = "float"
    lo: float | None = None
    hi: float | None = None
    unit: str = ""
    lo_open: bool = False
    choices: tuple[str, ...] = ()
    doc: str = ""

    def allowed(self) -> str:
        """Human-readable allowed set, e.g. ``[20, 40] mm``."""
        if self.kind == "bool":
            return "true or false"
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        lo = "-inf" if self.lo is None else fmt_value(float(self.lo))
        hi = "inf" if self.hi is None else fmt_value(float(self.hi))
        text = f"{'(' if self.lo_open else '['}{lo}, {hi}]"
        if self.kind.endswith("_range"):
            text = f"[min, max] with both in {text}"
        return f"{text} {self.unit}".rstrip()

    def _scalar(self, name: str, value: Any, integer: bool, shown: Any) -> float | int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise SceneError(f"{name} = {fmt_value(shown)} is not a number: allowed {self.allowed()}")
        try:
            v = float(value)
        except OverflowError:  # an integer beyond float range
            v = math.inf
        if not math.isfinite(v):
            raise SceneError(f"{name} = {fmt_value(shown)} is not a finite number: allowed {self.allowed()}")
        if integer and v != round(v):
            raise SceneError(f"{name} = {fmt_value(shown)} is not an integer: allowed {self.allowed()}")
        below = self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo)
        above = self.hi is not None and v > self.hi
        if below or above:
            raise SceneError(f"{name} = {fmt_value(shown)} is out of range: allowed {self.allowed()}")
        return int(round(v)) if integer else v

    def validate(self, name: str, value: Any) -> Any:
        """Return ``value`` in canonical form (float, int, bool, str or a tuple pair) or raise."""
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise SceneError(f"{name} = {fmt_value(value)} is not a boolean: allowed {self.allowed()}")
            return bool(value)
        if self.kind == "choice":
            if value not in self.choices:
                raise SceneError(f"{name} = {fmt_value(value)} is not allowed: allowed {self.allowed()}")
            return str(value)
        if self.kind in ("float", "int"):
            return self._scalar(name, value, self.kind == "int", value)
        if self.kind in ("float_range", "int_range"):
            if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)):
                value = (value, value)  # a single number is a degenerate range
            if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
                raise SceneError(f"{name} = {fmt_value(value)} is not a [min, max] pair: allowed {self.allowed()}")
            shown = [float(x) if isinstance(x, (float, np.floating)) else x for x in value]
            pair = tuple(self._scalar(name, x, self.kind == "int_range", shown) for x in value)
            if pair[0] > pair[1]:
                raise SceneError(f"{name} = {fmt_value(shown)} has min > max: allowed {self.allowed()}")
            return pair
        raise AssertionError(f"unknown parameter kind {self.kind!r}")


def to_jsonable(value: Any) -> Any:
    """Canonical parameter value as JSON data (tuples become lists)."""
    return list(value) if isinstance(value, tuple) else value


def _check_seed(seed: Any) -> int | None:
    if seed is None:
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SceneError(f"seed = {fmt_value(seed)} is not allowed: allowed None or an integer >= 0")
    return int(seed)


@dataclass(frozen=True)
class SceneSpec:
    """A scene as data: ``family`` (a key of :data:`FAMILIES`), ``params`` (mm/deg) and ``seed``.

    Validated on construction.  ``params`` holds only the values given (canonicalised); the
    family defaults fill the rest when the scene is made (:func:`resolved_params`).  With
    ``seed=None`` a random family draws fresh entropy; :func:`make_scene` records the seed it
    used in ``Scene.spec``, so every scene made can be rebuilt exactly.
    """

    family: str
    params: Mapping[str, Any]
    seed: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.family, str) or self.family not in FAMILIES:
            raise SceneError(
                f"unknown scene family {self.family!r}: allowed families are {', '.join(sorted(FAMILIES))}"
            )
        fam = FAMILIES[self.family]
        if not isinstance(self.params, Mapping):
            raise SceneError(f"params = {self.params!r} is not a mapping of parameter names to values")
        canon = {}
        for name, value in self.params.items():
            if name not in fam.params:
                raise SceneError(
                    f"unknown parameter {name!r} for family {self.family!r}: "
                    f"allowed parameters are {', '.join(sorted(fam.params))}"
                )
            canon[name] = fam.params[name].validate(name, value)
        object.__setattr__(self, "params", MappingProxyType(dict(sorted(canon.items()))))
        object.__setattr__(self, "seed", _check_seed(self.seed))
        # cross-field checks on the resolved values; a random family's draws always respect
        # the given values, so resolving with any generator finds every inconsistency
        fam.resolve(dict(canon), np.random.default_rng(0))

    def __hash__(self) -> int:
        return hash((self.family, json.dumps(self.to_dict()["params"], sort_keys=True), self.seed))

    def to_dict(self) -> dict:
        """JSON-ready form: ``{"family": ..., "params": {...}, "seed": ...}``."""
        return {
            "family": self.family,
            "params": {k: to_jsonable(v) for k, v in self.params.items()},
            "seed": self.seed,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SceneSpec:
        """Inverse of :meth:`to_dict`; ``params`` and ``seed`` may be omitted."""
        if not isinstance(d, Mapping) or "family" not in d:
            raise SceneError(f"a scene spec needs a 'family' key: got {d!r}")
        unknown = set(d) - {"family", "params", "seed"}
        if unknown:
            raise SceneError(
                f"unknown scene spec keys {sorted(unknown)}: allowed keys are family, params, seed"
            )
        params = d.get("params") or {}
        if not isinstance(params, Mapping):
            raise SceneError(f"params = {params!r} is not a mapping of parameter names to values")
        return cls(family=d["family"], params=dict(params), seed=d.get("seed"))

    def with_params(self, **params: Any) -> SceneSpec:
        """A copy with some parameters replaced or added."""
        return SceneSpec(self.family, {**self.params, **params}, self.seed)


def resolved_params(family_params: Mapping[str, Param], given: Mapping[str, Any]) -> dict[str, Any]:
    """Family defaults overlaid with the given (already canonical) values."""
    out = {name: p.default for name, p in family_params.items()}
    out.update(given)
    return out


@dataclass(frozen=True)
class Family:
    """A scene family: its parameters, how to resolve them and how to make its geometry.

    ``resolve(given, rng)`` returns the full parameter set (defaults, then random draws for
    random variants, then the given values) after the cross-field checks; ``geometry(params,
    rng)`` returns a :class:`evertgym.scenes.scene.Channel`.
    """

    name: str
    params: Mapping[str, Param]
    geometry: Any
    check: Any = None
    draw: Any = None
    doc: str = ""

    @property
    def defaults(self) -> dict[str, Any]:
        """Default parameters (JSON-ready)."""
        return {k: to_jsonable(p.default) for k, p in self.params.items()}

    def resolve(self, given: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
        """Full parameters: defaults, overlaid by draws (``draw(given, rng)``) and the given values."""
        out = resolved_params(self.params, {})
        if self.draw is not None:
            out.update(self.draw(given, rng))
        out.update(given)
        if self.check is not None:
            self.check(out)
        return out
