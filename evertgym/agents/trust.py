"""Trust for model files: SB3 zips and VecNormalize ``.pkl`` files are code.

Loading a stable-baselines3 ``.zip`` unpickles objects with cloudpickle and a
``*_vecnormalize.pkl`` is a plain pickle: either can run arbitrary code the moment it is
read.  evertgym therefore loads such a file only when

* its SHA-256 is listed in the package's manifest of shipped policies
  (``evertgym/data/policy_manifest.json``, written by
  ``python -m evertgym.agents.trust --write``), or
* the caller opts in: ``trust=True`` in Python, ``--trust-model`` at the CLI.

The check hashes the bytes; it never opens the archive or unpickles anything first.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

#: The manifest of shipped model files: ``{"files": {relative path: sha256}}``.
MANIFEST_PATH = Path(__file__).resolve().parent.parent / "data" / "policy_manifest.json"
#: The folder the shipped policies live in (a source checkout's ``agents/``).
SHIPPED_DIR = Path(__file__).resolve().parents[2] / "agents"


class UntrustedModelError(ValueError):
    """A model file that is neither in the manifest nor explicitly trusted."""


def sha256_of(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def trusted_hashes() -> set[str]:
    """The SHA-256 digests of the shipped model files (empty without a manifest)."""
    if not MANIFEST_PATH.exists():
        return set()
    return set(json.loads(MANIFEST_PATH.read_text(encoding="utf-8"))["files"].values())


def check_trusted(path: str | Path, trust: bool = False, flag: str = "--trust-model") -> None:
    """Raise :class:`UntrustedModelError` unless ``path`` is a shipped file or ``trust`` is set.

    ``flag`` names the opt-in in the message (the CLI flag; ``trust=True`` in Python)."""
    if trust:
        return
    path = Path(path)
    if sha256_of(path) not in trusted_hashes():
        raise UntrustedModelError(
            f"model file = {str(path)!r} is not a shipped policy (its SHA-256 is not in the manifest): "
            f"model files are code (pickles) and run when loaded; pass {flag} only if you trust its source"
        )


def model_files(folder: str | Path) -> dict[str, str]:
    """``{relative path: sha256}`` of every ``.zip`` and ``.pkl`` under ``folder``."""
    folder = Path(folder)
    return {
        p.relative_to(folder).as_posix(): sha256_of(p)
        for p in sorted(folder.rglob("*"))
        if p.suffix in (".zip", ".pkl") and p.is_file()
    }


def write_manifest(folder: str | Path = SHIPPED_DIR, out: str | Path = MANIFEST_PATH) -> dict:
    """Write the manifest of the model files under ``folder`` (the shipped ``agents/``)."""
    data = {"source": "agents/", "files": model_files(folder)}
    Path(out).write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return data


if __name__ == "__main__":  # python -m evertgym.agents.trust --write
    import sys

    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python -m evertgym.agents.trust --write   (hash agents/**/*.zip|*.pkl into the manifest)")
    print(json.dumps(write_manifest(), indent=2))
