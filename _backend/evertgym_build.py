"""The project's build backend: setuptools' own, with one file more in an editable install.

``pip install -e .`` gets setuptools' editable finder, which Python asks only after its
search of ``sys.path``.  That search starts at the current folder, so from the folder that
holds a clone named ``evertgym`` it finds the clone's root (no ``__init__.py``) as an
empty namespace package, and ``import evertgym`` returns that: the environments are never
registered and ``gym.make("evertgym/UBend-v0")`` fails with ``NamespaceNotFound``.  This
backend adds ``__editable__.evertgym_root.pth`` to the editable wheel: it puts the project
root on ``sys.path``, where the search finds the real package (a regular package anywhere on
the path wins over a namespace portion found before it).  Every wheel, editable or not, also
carries ``evertgym_gymnasium_hook.py`` and the ``.pth`` that imports it at start-up: Gymnasium
1.x loads no ``gymnasium.envs`` entry points, and the hook registers the environments when
Gymnasium is imported.  Sdists are setuptools' unchanged (and carry the hook's source).
"""

from __future__ import annotations

import base64
import hashlib
import os
import zipfile
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F403 - every other hook is setuptools'

ROOT = Path(__file__).resolve().parents[1]
PTH = "__editable__.evertgym_root.pth"


#: Gymnasium 1.x reads no entry points: this module, imported by :data:`HOOK_PTH` at start-up, registers
#: the environments when Gymnasium is imported, so ``gymnasium.make("evertgym/UBend-v0")`` needs no ``import evertgym``
HOOK = "evertgym_gymnasium_hook.py"
HOOK_PTH = "evertgym_gymnasium_hook.pth"


def _add_hook(wheel: Path) -> None:
    _add_to_wheel(wheel, HOOK, (Path(__file__).resolve().parent / HOOK).read_bytes())
    _add_to_wheel(wheel, HOOK_PTH, b"import evertgym_gymnasium_hook\n")


def build_editable(wheel_directory: str, config_settings: dict | None = None, metadata_directory: str | None = None) -> str:
    """setuptools' editable wheel with :data:`PTH` (the project root) and the Gymnasium hook added and recorded."""
    name = _setuptools.build_editable(wheel_directory, config_settings, metadata_directory)
    _add_to_wheel(Path(wheel_directory) / name, PTH, f"{ROOT}\n".encode())
    _add_hook(Path(wheel_directory) / name)
    return name


def build_wheel(wheel_directory: str, config_settings: dict | None = None, metadata_directory: str | None = None) -> str:
    """setuptools' wheel with the Gymnasium hook (:data:`HOOK`, :data:`HOOK_PTH`) added and recorded."""
    name = _setuptools.build_wheel(wheel_directory, config_settings, metadata_directory)
    _add_hook(Path(wheel_directory) / name)
    return name


def _add_to_wheel(wheel: Path, arcname: str, data: bytes) -> None:
    """Rewrite ``wheel`` with ``arcname`` added and listed in its RECORD (hash and size)."""
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    tmp = wheel.with_suffix(".tmp")
    with zipfile.ZipFile(wheel) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            content = src.read(item)
            if item.filename.endswith(".dist-info/RECORD"):
                dst.writestr(arcname, data)
                content = f"{arcname},sha256={digest},{len(data)}\n".encode() + content
            dst.writestr(item, content)
    os.replace(tmp, wheel)
