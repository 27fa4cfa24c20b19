"""Build the API reference (HTML) from the docstrings with pdoc; any warning fails the build.

    python -m evertgym.apidocs [OUT]        (default docs/api; needs the docs extra)

Every module of the package is listed explicitly: pdoc alone follows ``__all__``, which
would hide the submodules of packages that re-export a few names.
"""

from __future__ import annotations

import pkgutil
import sys
import warnings
from pathlib import Path

#: Modules left out: the CLI's entry point is documented by ``evertgym --help``.
SKIP = {"evertgym.__main__", "evertgym.apidocs"}


def modules() -> list[str]:
    """Every importable module of the package, parents first."""
    package = Path(__file__).resolve().parent  # this package's folder (the module sits in it)
    names = ["evertgym"] + [m.name for m in pkgutil.walk_packages([str(package)], "evertgym.")]
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
    from evertgym._extras import require

    require("the API reference", "pdoc")
    import pdoc

    names = modules()
    _resolve_lazy_exports(names)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # pdoc adds a package's submodules itself when it can; listing them again is harmless
        warnings.filterwarnings("ignore", message=".*has already been added", category=UserWarning)
        pdoc.pdoc(*names, output_directory=out)
    return names


def main(argv: list[str] | None = None) -> int:
    """``python -m evertgym.apidocs [OUT]``."""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m evertgym.apidocs", description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="docs/api", help="the folder of the HTML reference")
    target = Path(ap.parse_args(argv).out)
    print(f"{len(build(target))} modules -> {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
