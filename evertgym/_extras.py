"""Optional extras: which ``pip install 'evertgym[...]'`` brings a missing module.

Code that needs an optional dependency calls :func:`require` before importing it, so a
missing one is an ``ImportError`` that names the extra; the command line adds the same
hint to any other ``ModuleNotFoundError`` of a module in :data:`EXTRA_OF`
(:func:`install_hint`).
"""

from __future__ import annotations

import importlib.util

#: top-level module -> the extra of pyproject.toml that installs it
EXTRA_OF: dict[str, str] = {
    "torch": "rl", "stable_baselines3": "rl", "tensorboard": "rl", "rl_zoo3": "zoo", "optuna": "design",
    "dask": "cluster", "distributed": "cluster", "elastica": "bench", "mujoco": "bench", "pdoc": "docs",
}


def install_hint(module: str) -> str | None:
    """``"the design extra: pip install 'evertgym[design]'"`` for a module of an extra (its top-level
    name decides), else None."""
    extra = EXTRA_OF.get(module.split(".")[0])
    return None if extra is None else f"the {extra} extra: pip install 'evertgym[{extra}]'"


def require(what: str, *modules: str) -> None:
    """Raise ``ImportError`` naming the extra when one of ``modules`` cannot be imported;
    ``what`` names the feature (``"evertgym optimize"``).  Imports nothing itself."""
    for module in modules:
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            hint = install_hint(module) or f"the module {module}"
            raise ImportError(f"{what} needs {hint} (No module named {module!r})")
