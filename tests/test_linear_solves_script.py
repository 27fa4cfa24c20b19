"""scripts/linear_solves.py: the two linear solvers of a Newton step on the systems a Colon-v0 run makes; one line
for bad input."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).parents[1] / "scripts"
_spec = importlib.util.spec_from_file_location("linear_solves", SCRIPTS / "linear_solves.py")
linear_solves = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(linear_solves)


def test_on_colon_contact_increments_the_two_solvers_take_the_same_shift_and_step(capsys):
    assert linear_solves.main(["--steps", "40", "--min-iterations", "10", "--limit", "3", "--repeats", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    states = out["states"]
    assert states, "a Colon-v0 run of 40 steps has contact increments of 10 or more iterations"
    for s in states:
        assert s["pieces"] > 0 and s["one_segment"] + s["two_segments"] + s["wider"] > 0  # the pieces path ran
        assert s["same_gradient"]
        assert s["same_shift_from_zero"] and s["same_shift_from_one"]
        assert s["step_difference_from_zero"] < 1e-8 and s["step_difference_from_one"] < 1e-8


@pytest.mark.parametrize("argv, message", [
    (["--steps", "0"], "--steps = '0' is out of range: allowed a whole number >= 1"),
    (["--repeats", "x"], "--repeats = 'x' is out of range: allowed a whole number >= 1"),
    (["--env", "evertgym/Nope-v0"], "--env = 'evertgym/Nope-v0' is not a registered env id"),
])
def test_bad_input_gets_one_line(argv, message):
    with pytest.raises(SystemExit) as exc:
        linear_solves.main(argv)
    assert str(exc.value).startswith(message)
