"""Build the API reference (HTML) from the docstrings with pdoc; any warning fails the build.

    python scripts/build_api_docs.py [OUT]        (default docs/api; needs the docs extra)

Every module of the package is listed explicitly: pdoc alone follows ``__all__``, which
would hide the submodules of packages that re-export a few names.
"""

from __future__ import annotations

import pkgutil
import sys
import warnings
from pathlib import Path

import evertgym

#: Modules left out: the CLI's entry point is documented by ``evertgym --help``.
SKIP = {"evertgym.__main__"}


def modules() -> list[str]:
    """Every importable module of the package, parents first."""
    names = ["evertgym"] + [m.name for m in pkgutil.walk_packages(evertgym.__path__, "evertgym.")]
    return [n for n in names if n not in SKIP and not n.startswith("evertgym.shipped") and not n.startswith("evertgym.presets")]


def _resolve_lazy_exports(names: list[str]) -> None:
    """Put each module's lazily exported names (``__all__`` entries served by a module
    ``__getattr__``, such as ``evertgym.env.EversionEnv``) into its namespace: pdoc reads
    module dictionaries, not ``__getattr__``."""
    import importlib

    for name in names:
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", ()):
            if attr not in vars(module):
                setattr(module, attr, getattr(module, attr))


def build(out: Path) -> list[str]:
    """Write the HTML reference to ``out``; returns the documented module names."""
    import pdoc

    names = modules()
    _resolve_lazy_exports(names)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # pdoc adds a package's submodules itself when it can; listing them again is harmless
        warnings.filterwarnings("ignore", message=".*has already been added", category=UserWarning)
        pdoc.pdoc(*names, output_directory=out)
    return names


if __name__ == "__main__":
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/api")
    print(f"{len(build(target))} modules -> {target}")
