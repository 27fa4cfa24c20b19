"""The package's import graph: no cycles, and every import runs down the declared layers.

Layer order (docs/architecture.md)::

    design < model < scenes < sim < render < env < scoring < agents < experiments < bench < cli

Every ``import``/``from ... import`` inside ``evertgym/`` is read with :mod:`ast`, at module
level *and* inside functions (a function-level import is still a dependency), and
``if TYPE_CHECKING:`` blocks too.  ``_blas``, ``_extras``, ``_validate``, ``_version`` and ``limits`` import nothing
from the package and sit below every layer; ``cli_guard`` belongs to the CLI.  Experiments and agents are siblings in the design; an
experiment plays a policy, so ``experiments`` may import ``agents``, never the reverse.  The
package root registers the environments by entry-point string and may import only
``evertgym.env`` (whose package module is light) and ``evertgym._version``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "evertgym"

# rank of each top-level module or package of evertgym/
LAYERS: dict[str, float] = {
    "_blas": 0,
    "_extras": 0,
    "_validate": 0,
    "_version": 0,
    "limits": 0,
    "design": 1,
    "model": 2,
    "scenes": 3,
    "sim": 4,
    "render": 4.5,  # draws scenes and a robot's state for the env; knows neither sim nor env
    "env": 5,
    "scoring": 6,
    "agents": 7,
    "experiments": 7.5,
    "bench": 8,
    "cli": 9,
    "apidocs": 9.5,  # python -m evertgym.apidocs: imports every module to document it
    "cli_guard": 8.5,
}
ROOT_MAY_IMPORT = {"evertgym.env", "evertgym._version"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[str, int]]:
    """Every ``evertgym.*`` module imported by ``path`` (resolving relative imports), with its line."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out: list[tuple[str, int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "evertgym"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "evertgym":
                continue
            for alias in node.names:  # `from evertgym.scenes import colon` imports a module
                sub = f"{mod}.{alias.name}"
                out.append((sub if _exists(sub) else mod, node.lineno))
    return out


def _exists(module: str) -> bool:
    rel = Path(*module.split("."))
    return (PKG.parent / rel).with_suffix(".py").exists() or (PKG.parent / rel / "__init__.py").exists()


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None  # None: the package root


def _graph() -> dict[str, list[tuple[str, int]]]:
    return {_module_name(p): _imports(p) for p in sorted(PKG.rglob("*.py"))}


def test_every_top_level_module_has_a_layer():
    names = {_layer(m) for m in _graph()} - {None}
    assert names <= set(LAYERS), f"modules outside the declared layers: {sorted(names - set(LAYERS))}"


def test_imports_run_down_the_layers():
    bad = []
    for mod, imports in _graph().items():
        mine = _layer(mod)
        for target, line in imports:
            theirs = _layer(target)
            if mine is None:  # package root: registration only
                if target not in ROOT_MAY_IMPORT:
                    bad.append(f"{mod}:{line} -> {target} (the root imports only {sorted(ROOT_MAY_IMPORT)})")
                continue
            if theirs is None:
                bad.append(f"{mod}:{line} -> {target} (imports the package root)")
            elif theirs != mine and LAYERS[theirs] >= LAYERS[mine]:
                bad.append(f"{mod}:{line} -> {target} ({mine} may not import {theirs})")
    assert not bad, "imports against the layer order:\n" + "\n".join(bad)


def _cycles(graph: dict[str, list[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, []):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, []):
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def _module_graph() -> dict[str, list[str]]:
    """Imports between modules; a package's ``__init__`` is an edge to the package too."""
    g = {}
    for mod, imports in _graph().items():
        g[mod] = sorted({t for t, _ in imports if t != mod})
    return g


def test_no_import_cycles():
    cycles = _cycles(_module_graph())
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]
    assert _cycles({"a": ["b"], "b": []}) == []


@pytest.mark.parametrize(
    "src, expected",
    [
        ("from evertgym.scenes import colon\n", "evertgym.scenes.colon"),
        ("def f():\n    from evertgym.agents.tuned import load_tuned\n", "evertgym.agents.tuned"),
        ("from ..model import params\n", "evertgym.model.params"),
    ],
)
def test_reader_sees_module_and_function_level_imports(tmp_path, src, expected, monkeypatch):
    fake = PKG / "sim" / "_probe_for_test.py"
    try:
        fake.write_text(src)
        assert expected in [t for t, _ in _imports(fake)]
    finally:
        fake.unlink()


def test_import_evertgym_is_light():
    """Registering the envs imports Gymnasium and the presets, not the simulator's libraries."""
    import subprocess
    import sys

    code = ("import sys, evertgym, gymnasium; "
            "heavy = sorted(m for m in ('pymunk', 'scipy', 'torch', 'stable_baselines3', 'matplotlib') if m in sys.modules); "
            "assert 'evertgym/UBend-v0' in gymnasium.registry, 'envs not registered'; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", f"import evertgym pulled in {out}"


def test_an_env_step_loads_no_plotting_or_fitting_library():
    """Making and stepping an env (no render mode) loads neither matplotlib, Pillow, scipy.optimize,
    scipy.interpolate, scipy.spatial nor scipy.sparse: they cost an env process about 70 MB of its
    200 MB (peak RSS).  The colon is the one with a compliant wall (scipy.sparse's
    eigensolver sizes the dynamic engine's wall, which the quasi-static default never steps)."""
    import subprocess
    import sys

    heavy = ('matplotlib', 'PIL', 'scipy.optimize', 'scipy.interpolate', 'scipy.spatial', 'scipy.sparse', 'torch')
    code = ("import sys, numpy as np, gymnasium as gym, evertgym\n"
            "for name in ('evertgym/UBend-v0', 'evertgym/Colon-v0'):\n"
            "    env = gym.make(name); env.reset(seed=0); env.step(np.zeros(1, np.float32)); env.reset(seed=1)\n"
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", f"an env step pulled in {out}"
