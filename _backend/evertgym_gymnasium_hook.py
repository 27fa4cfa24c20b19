"""Register evertgym's environments with Gymnasium when Gymnasium is imported.

Gymnasium 1.x no longer loads the ``gymnasium.envs`` entry-point group, so without help
``gymnasium.make("evertgym/UBend-v0")`` in a fresh interpreter fails with ``NamespaceNotFound``
until something imports evertgym.  The build backend installs this module beside the package
with ``evertgym_gymnasium_hook.pth``, which imports it at interpreter start-up.  It costs one
small class on ``sys.meta_path``: nothing is imported until Python imports ``gymnasium``; then,
once Gymnasium's own module has run, ``import evertgym`` registers the environments (by their
entry-point strings: the simulator itself loads only when an env is made).  A failure to import
evertgym never breaks ``import gymnasium``: it is reported as a warning.
"""

from __future__ import annotations

import sys
from typing import Any


class EvertgymGymnasiumHook:
    """A one-shot ``sys.meta_path`` finder: it wraps the loader of ``gymnasium`` and steps aside."""

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        if name != "gymnasium":
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        import importlib.util

        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run = spec.loader.exec_module

        def exec_module(module: Any) -> None:
            run(module)
            try:
                import evertgym  # noqa: F401 - registers the environments
            except Exception as e:  # noqa: BLE001 - never break `import gymnasium`
                import warnings

                warnings.warn(f"evertgym's environments are not registered with Gymnasium: import evertgym failed: {e}",
                              RuntimeWarning, stacklevel=2)

        spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def install() -> None:
    """Put the hook on ``sys.meta_path`` once (or register at once if Gymnasium is already imported)."""
    if "gymnasium" in sys.modules:
        try:
            import evertgym  # noqa: F401
        except Exception:  # noqa: BLE001
            pass
        return
    if not any(type(f).__name__ == "EvertgymGymnasiumHook" for f in sys.meta_path):
        sys.meta_path.insert(0, EvertgymGymnasiumHook())


install()
