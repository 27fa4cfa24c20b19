"""The scene-family registry (Gymnasium's ``register`` pattern).

A family module builds its :class:`~evertgym.scenes.spec.Family` and calls
:func:`register`; :class:`~evertgym.scenes.spec.SceneSpec` and
:func:`~evertgym.scenes.families.make_scene` look families up in :data:`FAMILIES`.
This module imports nothing of the package, so the data classes and the families that
use them do not import each other in a circle.  The built-in families register when
``evertgym.scenes`` is imported.
"""

from __future__ import annotations

from typing import Any

#: Registered families by name (values are :class:`evertgym.scenes.spec.Family`).
FAMILIES: dict[str, Any] = {}


def register(family: Any) -> Any:
    """Register a scene family under ``family.name``; returns it.  A name registers once."""
    name = family.name
    if not isinstance(name, str) or not name:
        raise ValueError(f"family name = {name!r}: must be a non-empty string")
    if name in FAMILIES and FAMILIES[name] is not family:
        raise ValueError(f"scene family {name!r} is already registered")
    FAMILIES[name] = family
    return family
