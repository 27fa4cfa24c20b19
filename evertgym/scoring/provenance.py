"""Run metadata stored beside every result: the command, package versions, platform, code revision.

Versions are those of the process that writes the store (the runner's parent process); on a
remote Dask cluster the workers are assumed to run the same environment.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import subprocess
import sys
import uuid
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

from evertgym._version import __version__
from evertgym.env.presets import preset_files

#: The installed ``evertgym`` package folder.
_PACKAGE_DIR = Path(__file__).resolve().parents[1]

#: Packages whose versions are recorded, when installed.
VERSIONED_PACKAGES = ("evertgym", "numpy", "scipy", "pymunk", "dask", "distributed")


def utc_now() -> str:
    """The current time as ISO 8601 UTC with milliseconds, e.g. ``2026-01-31T12:00:00.000+00:00``."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        if name == "evertgym":  # a source checkout on PYTHONPATH, not installed
            return __version__
        return None


def _git_revision() -> dict[str, Any] | None:
    """The git commit of the evertgym checkout and whether it has uncommitted changes, if any."""
    root = _PACKAGE_DIR.parent
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        status = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, timeout=10, check=True,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": head, "dirty": bool(status.strip())}


@functools.cache
def code_fingerprint() -> str:
    """SHA-256 (first 16 hex digits) of the installed evertgym's Python sources, data files
    and env presets: two runs with the same fingerprint ran the same simulator."""
    pkg = _PACKAGE_DIR
    files = sorted(p for p in pkg.rglob("*") if p.is_file() and p.suffix in (".py", ".json", ".toml"))
    files += sorted(Path(p).resolve() for p in preset_files().values())
    digest = hashlib.sha256()
    for f in dict.fromkeys(files):
        digest.update(f.name.encode())
        digest.update(f.read_bytes())
    return digest.hexdigest()[:16]


def run_metadata(**extra: Any) -> dict[str, Any]:
    """Metadata of the current run: a fresh ``run_id``, start time, command line, versions, platform.

    ``extra`` keys (e.g. ``backend``, ``workers``) are added as given; they must be JSON-able.
    """
    versions: dict[str, str | None] = {name: _version(name) for name in VERSIONED_PACKAGES}
    versions["python"] = platform.python_version()
    return {
        "run_id": uuid.uuid4().hex,
        "started_at": utc_now(),
        "command": list(sys.orig_argv),
        "cwd": os.getcwd(),
        "versions": versions,
        "git": _git_revision(),
        "code_fingerprint": code_fingerprint(),
        "platform": platform.platform(),
        "hostname": platform.node(),
        **extra,
    }
