"""Tube and band designs: validated at construction, kept in human-editable files.

Inside the code everything is SI (m, Pa).  Files use the field's units with the unit in
the key (``diameter_mm``, ``position_mm``), in TOML or JSON::

    [tube]
    diameter_mm = 40.0
    wall_thickness_mm = 0.05
    length_mm = 600.0

    [pressure_law]          # optional; defaults come from the calibrated parameter file
    membrane_modulus_mpa = 23.8
    pressure_stiffening = 1.0

    [[bands]]
    position_mm = 450.0     # band centre, measured along the body from the base
    reduction = 0.1         # diameter reduction, 0 <= reduction < 0.6
    width_mm = 15.0         # width of the band strip

Band positions are material coordinates from the base (the first material to evert),
so a band reaches the tip when the insertion length equals its position.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

import tomli_w

from evertgym._validate import check_range

#: Reductions at or above this never everted in the paper (the seal ruptured first).
MAX_REDUCTION = 0.6
#: A tube is thin-walled (membrane theory) only while t / r stays below this.
MAX_THICKNESS_TO_RADIUS = 0.1
#: The shortest body the simulator builds and grows with its default settings: its 15 mm
#: initial chain plus one 7.5 mm segment (shorter ones abort inside Chipmunk).
MIN_LENGTH_M = 0.025
#: The thinnest wall accepted (m): 1 um, 50x thinner than the paper's 50 um TPU film.
#: Thinner walls (down to denormal floats) give segment masses Chipmunk aborts on.
MIN_WALL_THICKNESS_M = 1e-6
#: The narrowest tube accepted (m): 1 mm, 40x narrower than the paper's 40 mm.
MIN_DIAMETER_M = 1e-3
#: The most bands a design may carry.
MAX_BANDS = 1000


class DesignError(ValueError):
    """An invalid design field; the message names the field and its allowed range."""


def _finite(name: str, value: Any) -> float:
    if isinstance(value, (bool, str, bytes)) or value is None:  # no silent true -> 1.0 or "0.3" kept as text
        raise DesignError(f"{name} = {value!r} is not a number")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise DesignError(f"{name} = {value!r} is not a number") from None
    if not math.isfinite(v):
        raise DesignError(f"{name} = {value!r} is not finite")
    return v


def _in_range(name: str, value: Any, lo: float, hi: float, *, lo_open: bool, hi_open: bool, unit: str = "") -> float:
    return check_range(name, _finite(name, value), lo, hi, lo_open=lo_open, hi_open=hi_open, unit=unit, error=DesignError)


@dataclass(frozen=True)
class Band:
    """An inextensible constrictive band.

    Attributes
    ----------
    position_m: centre of the band strip along the body, from the base (m).
    reduction: diameter reduction ``rho``, in [0, 0.6) (in [0, 0.95) with ``must_evert=False``).
    width_m: width of the band strip (m); the paper's strips are 15 mm.
    """

    position_m: float
    reduction: float
    width_m: float = 0.015
    #: False admits reductions up to 0.95 for studies of bands that cannot evert (the
    #: paper's 60% band); designs meant to evert keep the default.
    must_evert: bool = field(default=True, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_m", _finite("position_m", self.position_m))
        object.__setattr__(self, "reduction", _in_range(
            "reduction", self.reduction, 0.0, MAX_REDUCTION if self.must_evert else 0.95, lo_open=False, hi_open=True))
        object.__setattr__(self, "width_m", _in_range("width_m", self.width_m, 0.0, 0.2, lo_open=True, hi_open=False, unit="m"))


@dataclass(frozen=True)
class TubeDesign:
    """A thin-walled eversion tube and its bands (SI).

    Attributes
    ----------
    diameter_m: inflated diameter (m), in (0, 0.5].
    wall_thickness_m: wall thickness (m), positive and below 0.1 r (thin-walled).
    length_m: total everting length (m), in (0, 20].
    bands: the constrictive bands, ordered by position; strips may not overlap and must
        lie inside the body.
    membrane_modulus_pa, pressure_stiffening: the pressure law; ``None`` takes the
        calibrated values of the parameter file.
    """

    diameter_m: float = 0.040
    wall_thickness_m: float = 0.05e-3
    length_m: float = 0.600
    bands: tuple[Band, ...] = field(default_factory=tuple)
    membrane_modulus_pa: float | None = None
    pressure_stiffening: float | None = None

    def __post_init__(self) -> None:
        d = _in_range("diameter_m", self.diameter_m, MIN_DIAMETER_M, 0.5, lo_open=False, hi_open=False, unit="m")
        t = _in_range(
            "wall_thickness_m",
            self.wall_thickness_m,
            MIN_WALL_THICKNESS_M,
            MAX_THICKNESS_TO_RADIUS * d / 2,
            lo_open=False,
            hi_open=True,
            unit="m (thin-walled: below 0.1 x radius)",
        )
        length = _in_range("length_m", self.length_m, MIN_LENGTH_M, 20.0, lo_open=False, hi_open=False, unit="m")
        for name, v in (("diameter_m", d), ("wall_thickness_m", t), ("length_m", length)):
            object.__setattr__(self, name, v)
        if self.membrane_modulus_pa is not None:
            object.__setattr__(self, "membrane_modulus_pa", _in_range(
                "membrane_modulus_pa", self.membrane_modulus_pa, 0.0, 1e10, lo_open=True, hi_open=False, unit="Pa"))
        if self.pressure_stiffening is not None:
            object.__setattr__(self, "pressure_stiffening", _in_range(
                "pressure_stiffening", self.pressure_stiffening, 0.0, 10.0, lo_open=False, hi_open=False))
        if not isinstance(self.bands, (tuple, list)) or len(self.bands) > MAX_BANDS:
            raise DesignError(f"bands = {self.bands!r:.60} is not allowed: allowed a list of at most {MAX_BANDS} Band")
        for i, b in enumerate(self.bands):
            if not isinstance(b, Band):
                raise DesignError(f"bands[{i}] = {b!r} is not a Band")
        bands = tuple(sorted(self.bands, key=lambda b: b.position_m))
        for i, b in enumerate(bands):
            half = b.width_m / 2
            if not (half <= b.position_m <= length - half):
                raise DesignError(
                    f"bands[{i}].position_m = {b.position_m!r} is out of range: allowed "
                    f"[{half:g}, {length - half:g}] m (the strip must lie inside the body)"
                )
        for i in range(1, len(bands)):
            a, b = bands[i - 1], bands[i]
            gap = b.position_m - a.position_m
            need = (a.width_m + b.width_m) / 2
            if gap < need:
                raise DesignError(
                    f"bands[{i}].position_m = {b.position_m!r} overlaps bands[{i - 1}] at "
                    f"{a.position_m!r}: allowed a centre spacing >= {need:g} m"
                )
        object.__setattr__(self, "bands", bands)

    @property
    def radius_m(self) -> float:
        return self.diameter_m / 2

    def with_bands_from_tip(self, distances_m: Iterable[float], reduction: float, width_m: float = 0.015) -> TubeDesign:
        """A copy whose bands sit at the given distances from the tip (m)."""
        bands = tuple(Band(self.length_m - d, reduction, width_m) for d in distances_m)
        return TubeDesign(
            self.diameter_m, self.wall_thickness_m, self.length_m, bands, self.membrane_modulus_pa, self.pressure_stiffening
        )

    # ---- files -------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The file structure (field units: mm, MPa)."""
        d: dict[str, Any] = {
            "tube": {
                "diameter_mm": self.diameter_m * 1e3,
                "wall_thickness_mm": self.wall_thickness_m * 1e3,
                "length_mm": self.length_m * 1e3,
            },
            "bands": [
                {"position_mm": b.position_m * 1e3, "reduction": b.reduction, "width_mm": b.width_m * 1e3}
                for b in self.bands
            ],
        }
        law = {}
        if self.membrane_modulus_pa is not None:
            law["membrane_modulus_mpa"] = self.membrane_modulus_pa / 1e6
        if self.pressure_stiffening is not None:
            law["pressure_stiffening"] = self.pressure_stiffening
        if law:
            d["pressure_law"] = law
        return d

    @classmethod
    def from_dict(cls, d: Any) -> TubeDesign:
        """Parse the file structure; every malformed field raises :class:`DesignError`."""
        if not isinstance(d, dict):
            raise DesignError(f"design file must hold a table/object, got {type(d).__name__}")
        unknown = set(d) - {"tube", "bands", "pressure_law"}
        if unknown:
            raise DesignError(f"unknown design section(s) {sorted(unknown)}: allowed tube, bands, pressure_law")
        tube = d.get("tube", {})
        if not isinstance(tube, dict):
            raise DesignError("tube must be a table with diameter_mm, wall_thickness_mm, length_mm")
        _no_unknown("tube", tube, {"diameter_mm", "wall_thickness_mm", "length_mm"})
        kw: dict[str, Any] = {}
        # ranges checked here in the file's own units, so errors name the file's fields
        if "diameter_mm" in tube:
            kw["diameter_m"] = _in_range("tube.diameter_mm", tube["diameter_mm"], MIN_DIAMETER_M * 1e3, 500.0, lo_open=False,
                                         hi_open=False,
                                         unit="mm") / 1e3
        if "wall_thickness_mm" in tube:
            radius_mm = kw.get("diameter_m", cls.diameter_m) * 1e3 / 2
            kw["wall_thickness_m"] = _in_range("tube.wall_thickness_mm", tube["wall_thickness_mm"],
                                               MIN_WALL_THICKNESS_M * 1e3, MAX_THICKNESS_TO_RADIUS * radius_mm,
                                               lo_open=False, hi_open=True,
                                               unit="mm (thin-walled: below 0.1 x radius)") / 1e3
        if "length_mm" in tube:
            kw["length_m"] = _in_range("tube.length_mm", tube["length_mm"], MIN_LENGTH_M * 1e3, 20e3, lo_open=False,
                                       hi_open=False, unit="mm") / 1e3
        law = d.get("pressure_law", {})
        if not isinstance(law, dict):
            raise DesignError("pressure_law must be a table with membrane_modulus_mpa, pressure_stiffening")
        _no_unknown("pressure_law", law, {"membrane_modulus_mpa", "pressure_stiffening"})
        if "membrane_modulus_mpa" in law:
            kw["membrane_modulus_pa"] = _finite("pressure_law.membrane_modulus_mpa", law["membrane_modulus_mpa"]) * 1e6
        if "pressure_stiffening" in law:
            kw["pressure_stiffening"] = _finite("pressure_law.pressure_stiffening", law["pressure_stiffening"])
        raw_bands = d.get("bands", [])
        if not isinstance(raw_bands, list):
            raise DesignError("bands must be a list of tables with position_mm, reduction, width_mm")
        bands = []
        for i, b in enumerate(raw_bands):
            if isinstance(b, dict):  # a misspelt key is named before the missing one it stands for
                _no_unknown(f"bands[{i}]", b, {"position_mm", "reduction", "width_mm"})
            if not isinstance(b, dict) or "position_mm" not in b or "reduction" not in b:
                raise DesignError(f"bands[{i}] must have position_mm and reduction (width_mm optional)")
            try:
                bands.append(
                    Band(
                        _finite(f"bands[{i}].position_mm", b["position_mm"]) / 1e3,
                        b["reduction"],
                        _finite(f"bands[{i}].width_mm", b.get("width_mm", 15.0)) / 1e3,
                    )
                )
            except DesignError as e:
                raise DesignError(f"bands[{i}].{e}") from None
        _check_band_places(bands, kw.get("length_m", cls.length_m))
        return cls(bands=tuple(bands), **kw)

    def save(self, path: str | Path) -> None:
        """Write the design as TOML (``.toml``) or JSON (any other suffix)."""
        path = Path(path)
        if path.suffix == ".toml":
            path.write_text(tomli_w.dumps(self.to_dict()), encoding="utf-8")
        else:
            path.write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")

    @classmethod
    def load(cls, path: str | Path) -> TubeDesign:
        """Read a TOML or JSON design file."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise DesignError(f"design file = {str(path)!r}: cannot read it as UTF-8 text ({e})") from None
        try:
            data = tomllib.loads(text) if path.suffix == ".toml" else json.loads(text)
        except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
            raise DesignError(f"{path}: malformed design file: {e}") from None
        if data == {}:  # not silently the default design
            raise DesignError(f"design file = {str(path)!r} is empty: allowed sections tube, bands, pressure_law")
        try:
            return cls.from_dict(data)
        except DesignError as e:
            raise DesignError(f"{path}: {e}") from None


def _check_band_places(bands: list[Band], length_m: float) -> None:
    """Each band inside the body and clear of the others, in a design file's terms: its
    index in the file and ``position_mm``."""
    length_mm = length_m * 1e3
    for i, b in enumerate(bands):
        half = b.width_m * 1e3 / 2
        pos = b.position_m * 1e3
        if not (half <= pos <= length_mm - half):
            raise DesignError(f"bands[{i}].position_mm = {pos:g} is out of range: allowed [{half:g}, {length_mm - half:g}] mm "
                              f"(the {2 * half:g} mm strip must lie inside the {length_mm:g} mm body)")
    order = sorted(range(len(bands)), key=lambda k: bands[k].position_m)
    for j, i in zip(order, order[1:]):  # neighbours along the body
        a, b = bands[j], bands[i]
        need = (a.width_m + b.width_m) / 2 * 1e3
        if (b.position_m - a.position_m) * 1e3 < need:
            raise DesignError(f"bands[{i}].position_mm = {b.position_m * 1e3:g} overlaps bands[{j}] at {a.position_m * 1e3:g}: "
                              f"allowed a centre spacing >= {need:g} mm")


def _no_unknown(section: str, table: dict, allowed: set[str]) -> None:
    extra = set(table) - allowed
    if extra:
        raise DesignError(f"{section}: unknown field(s) {sorted(extra)}: allowed {sorted(allowed)}")
