"""The docs' examples run: every Python block of the README and docs/*.md pages listed
here, and every ``evertgym`` command of the quickstart."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from evertgym.cli import main

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["README.md", "docs/quickstart.md", "docs/envs.md", "docs/agents.md", "docs/scenes.md"]


def _blocks(page: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", (ROOT / page).read_text(encoding="utf-8"), flags=re.S)


PY = [(page, i, code) for page in PAGES for i, code in enumerate(_blocks(page, "python"))]


def test_the_pages_have_examples():
    assert {page for page, _, _ in PY} == set(PAGES)


@pytest.mark.parametrize("page,i,code", PY, ids=[f"{p}#{i}" for p, i, _ in PY])
def test_python_example_runs(page, i, code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # whatever an example writes stays out of the checkout
    exec(compile(code, f"{page} block {i}", "exec"), {"__name__": "__docs__"})


def _commands(page: str) -> list[str]:
    lines = [ln.split("  #")[0].strip() for block in _blocks(page, "bash") for ln in block.splitlines()]
    return [ln for ln in lines if ln.startswith("evertgym ")]


QUICK = _commands("docs/quickstart.md")


@pytest.mark.parametrize("line", QUICK)
def test_quickstart_command_runs(line, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(shlex.split(line)[1:])
    except SystemExit as e:  # --version exits
        code = e.code
    assert code == 0
    assert capsys.readouterr().out.strip()


def test_quickstart_has_commands():
    assert any("score" in c for c in QUICK) and any("stiffness" in c for c in QUICK)
