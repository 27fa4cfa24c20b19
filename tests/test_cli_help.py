"""Every subcommand's --help runs and shows each option's default; --version; human summaries."""

from __future__ import annotations

import argparse
import json

import pytest

import evertgym
from evertgym.cli import build_parser, main


def _commands(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()):
    """(argv prefix, parser) for the parser and every subcommand below it."""
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, prefix + (name,))


COMMANDS = list(_commands(build_parser()))


def test_every_command_is_reached():
    names = {" ".join(p) for p, _ in COMMANDS}
    assert {"score", "train", "eval", "rollout", "stiffness", "reproduce stiffness", "reproduce ubend", "bench env"} <= names


@pytest.mark.parametrize("argv,parser", COMMANDS, ids=[" ".join(p) or "evertgym" for p, _ in COMMANDS])
def test_help_shows_defaults_and_choices(argv, parser, capsys):
    with pytest.raises(SystemExit) as e:
        main([*argv, "--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: evertgym")
    for action in parser._actions:
        if not action.option_strings or action.default is argparse.SUPPRESS or action.help is argparse.SUPPRESS:
            continue
        assert action.help, f"{' '.join(argv)} {action.option_strings[0]} has no help"
        name = f"{' '.join(argv)} {action.option_strings[0]}"
        text = parser._get_formatter()._expand_help(action)
        # every option that takes a value names its default once; an on/off flag names none
        # ("--no-progress  no progress bar (default: True)", "(default 1) (default: 1)")
        if action.nargs == 0:
            assert "default" not in text, f"{name}: {text!r}"
        elif not action.required:
            assert text.count("default") == 1, f"{name}: {text!r}"
            if "(default: " in text and action.default is not None:
                assert f"(default: {action.default})" in " ".join(out.split()), name
        if action.choices:
            assert "{" + ",".join(map(str, action.choices)) + "}" in out


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"evertgym {evertgym.__version__}"


def test_score_help_lists_scene_families(capsys):
    from evertgym.scenes import FAMILIES

    with pytest.raises(SystemExit):
        main(["score", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert all(f in out for f in FAMILIES)


def test_stiffness_with_a_design_says_which_free_length(tmp_path, capsys):
    design = tmp_path / "long.toml"
    design.write_text("[tube]\ndiameter_mm = 40.0\nlength_mm = 600.0\n")
    assert main(["stiffness", "--design", str(design), "--no-sim"]) == 0
    out = capsys.readouterr().out
    assert "free length (clamp to tip): 200.7 mm, calibrated" in out and "robot length 600 mm" in out
    assert main(["stiffness", "--design", str(design), "--no-sim", "--length-mm", "500"]) == 0
    assert "500.0 mm, --length-mm" in capsys.readouterr().out
    assert main(["stiffness", "--design", str(design), "--no-sim", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["length_mm"] == pytest.approx(200.7, abs=0.05)
