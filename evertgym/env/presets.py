"""Environment presets: data files in the repository's ``envs/`` folder.

A preset names a scene distribution, a band design, the control period, the episode
limit, the observation flags and the reward weights; adding one needs no code.  Scene
parameters may be fixed values or distributions drawn per episode from the env's
``np_random``::

    [scene]
    family = "ubend"
    [scene.params]
    radius_mm = { uniform = [25.0, 40.0] }     # or { choice = [25.0, 30.0] }

``seed = "episode"`` (the default) gives every episode a fresh scene seed for random
families.  The design table has the layout of a design file (:mod:`evertgym.design`),
and ``band_offset_mm = [lo, hi]`` shifts all bands by a uniform draw per episode (the
paper's randomisation of band position against the bend).
"""

from __future__ import annotations

import sys
from functools import cache
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

import numpy as np

#: The repository's presets folder (installed as the package ``evertgym.presets``).
PRESET_DIR = Path(__file__).resolve().parents[2] / "envs"


def _preset_dir() -> Path:
    if PRESET_DIR.is_dir():
        return PRESET_DIR
    from importlib.resources import files

    return Path(str(files("evertgym.presets")))


@cache
def preset_files() -> dict[str, Path]:
    """Registered env id -> preset file."""
    out = {}
    for path in sorted(_preset_dir().glob("*.toml")):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        out[data["id"]] = path
    return out


def load_preset(env_id: str) -> dict:
    """The preset of a registered id, as a dict."""
    files = preset_files()
    if env_id not in files:
        raise ValueError(f"unknown env id {env_id!r}: registered ids are {sorted(files)}")
    return tomllib.loads(files[env_id].read_text(encoding="utf-8"))


def sample_params(params: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """Draw every distribution-valued scene parameter; fixed values pass through."""
    out = {}
    for key, value in params.items():
        if isinstance(value, dict):
            if set(value) == {"uniform"}:
                lo, hi = value["uniform"]
                out[key] = float(rng.uniform(lo, hi))
            elif set(value) == {"choice"}:
                choices = value["choice"]
                out[key] = choices[int(rng.integers(len(choices)))]
            else:
                raise ValueError(f"scene.params.{key} = {value!r}: a distribution is {{uniform = [lo, hi]}} or {{choice = [...]}}")
        else:
            out[key] = value
    return out
