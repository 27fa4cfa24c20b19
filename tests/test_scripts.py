"""Every script in scripts/ starts from outside the checkout on the installed package alone (no
``PYTHONPATH=.``, no working folder of its own): ``--help`` runs in a fresh interpreter from an empty
folder.  And no script imports a private name of the package."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p for p in (ROOT / "scripts").glob("*.py"))
#: scripts without flags, run by their own tests
NO_FLAGS: dict[str, str] = {}


@pytest.mark.parametrize("script", [p for p in SCRIPTS if p.name not in NO_FLAGS], ids=lambda p: p.name)
def test_a_script_starts_from_an_empty_folder_without_pythonpath(script, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    installed = subprocess.run([sys.executable, "-c", "import evertgym; print(evertgym.__file__)"], capture_output=True,
                               text=True, cwd=tmp_path, env=env).stdout.strip()
    if not installed or Path(installed).resolve().parents[1] != ROOT:  # another checkout is installed: this one's
        (tmp_path / "pkg").mkdir()                                      # package alone, not its scripts/ or tests/
        (tmp_path / "pkg" / "evertgym").symlink_to(ROOT / "evertgym")
        env["PYTHONPATH"] = str(tmp_path / "pkg")
    done = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "usage:" in done.stdout


def test_the_scripts_without_flags_are_run_by_their_tests():
    for name, test in NO_FLAGS.items():
        assert name in (ROOT / test).read_text(), (name, test)


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_no_script_imports_a_private_name(script):
    for node in ast.walk(ast.parse(script.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("evertgym"):
            private = [a.name for a in node.names if a.name.startswith("_")]
            assert not private, f"{script.name}: from {node.module} import {private}"
            assert not any(part.startswith("_") for part in node.module.split(".")), f"{script.name}: {node.module}"
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("evertgym"):
                    assert not any(part.startswith("_") for part in a.name.split(".")), f"{script.name}: import {a.name}"
