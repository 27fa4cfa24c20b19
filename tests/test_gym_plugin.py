"""Gymnasium finds the environments without ``import evertgym``, and making any current one prints
no Gymnasium warning (a superseded version gets Gymnasium's own out-of-date warning).  Gymnasium 1.x
reads no ``gymnasium.envs`` entry points; every wheel of this project carries a start-up hook
(``_backend/evertgym_gymnasium_hook.py`` and its ``.pth``) that registers the environments when
Gymnasium is imported.  The slow wheel test in ``tests/test_package.py`` installs a real wheel and
makes an env that way."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.envs.registration import find_highest_version, parse_env_id

import evertgym

ROOT = Path(__file__).resolve().parents[1]


def _fresh(code: str) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter that ran the hook as its ``.pth`` does (project first on the path)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "_backend")])}
    pre = "import evertgym_gymnasium_hook\n"
    return subprocess.run([sys.executable, "-W", "error", "-c", pre + code], capture_output=True, text=True, timeout=120,
                          env=env, cwd=ROOT)


def test_gym_make_works_in_a_fresh_interpreter_without_import_evertgym():
    done = _fresh(
        "import sys\n"
        "assert 'gymnasium' not in sys.modules and 'evertgym' not in sys.modules  # the hook imports nothing at start-up\n"
        "import gymnasium as gym\n"
        "env = gym.make('evertgym/UBend-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(type(env.unwrapped).__name__, obs.shape)\n"
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["EversionEnv", "(15,)"]


def test_without_the_hook_gymnasium_1_does_not_find_them():
    """What the hook is for: Gymnasium 1.x alone reads no entry points, so the namespace is not found
    (skipped where the installed evertgym already carries the hook)."""
    import importlib.util

    if importlib.util.find_spec("evertgym_gymnasium_hook") is not None:
        pytest.skip("this environment's evertgym was installed with the hook")
    code = "import gymnasium as gym\ntry:\n    gym.make('evertgym/UBend-v0')\nexcept gym.error.NamespaceNotFound:\n    print('not found')\n"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    assert done.stdout.strip() == "not found", done.stderr[-2000:]


def test_making_every_current_id_prints_no_gymnasium_warning_and_a_superseded_one_names_its_successor():
    ids = evertgym.register_envs()
    assert len(ids) >= 5
    superseded = []
    for env_id in ids:
        ns, name, version = parse_env_id(env_id)
        latest = find_highest_version(ns, name)  # Gymnasium's convention: a newer version supersedes this one
        if latest is not None and version is not None and latest > version:
            superseded.append(env_id)
            with pytest.warns(DeprecationWarning, match=f"{env_id} is out of date.*version `v{latest}`"):
                gym.make(env_id).close()
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            gym.make(env_id).close()
    assert superseded == ["evertgym/Colon-v0"]


def test_every_wheel_of_the_backend_carries_the_hook(tmp_path):
    sys.path.insert(0, str(ROOT / "_backend"))
    try:
        import evertgym_build
    finally:
        sys.path.remove(str(ROOT / "_backend"))
    wheel = tmp_path / "x-1.0-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as z:
        z.writestr("x/__init__.py", "")
        z.writestr("x-1.0.dist-info/RECORD", "x/__init__.py,,\n")
    evertgym_build._add_hook(wheel)
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        record = z.read("x-1.0.dist-info/RECORD").decode()
        pth = z.read("evertgym_gymnasium_hook.pth").decode()
    assert {"evertgym_gymnasium_hook.py", "evertgym_gymnasium_hook.pth"} <= names
    assert "evertgym_gymnasium_hook.py,sha256=" in record and "evertgym_gymnasium_hook.pth,sha256=" in record
    assert pth == "import evertgym_gymnasium_hook\n"
    for build in ("build_wheel", "build_editable"):
        assert "_add_hook" in getattr(evertgym_build, build).__code__.co_names, build
