"""The physics trial's early give-up follows each policy's own highest command."""

from __future__ import annotations

import dataclasses

import pytest

from evertgym.agents import ConstantPressure, OperatorProtocol, PressureCycling, make_policy
from evertgym.experiments.paper import ubend_specs
from evertgym.experiments.trial import GIVE_UP_S, run_trial


def test_max_command_kpa_of_each_policy():
    assert ConstantPressure(3.0).max_command_kpa == 3.0
    assert OperatorProtocol(max_kpa=5.0).max_command_kpa == 5.0
    assert PressureCycling(low_kpa=1.0, high_kpa=6.0).max_command_kpa == 6.0
    assert make_policy("tuned").max_command_kpa <= 8.0


def test_capped_operator_gives_up_once_stalled_at_its_cap():
    """An operator capped at 0.8 kPa that jams in the 20 mm U-bend can get no more help: the
    trial must end about GIVE_UP_S after the stall instead of running to the time limit
    (before the fix it looked up a name no policy defined and ran all 20 s)."""
    spec = ubend_specs(trials=1, radii=(20.0,), reductions=(0.0,))[0]
    spec = dataclasses.replace(spec, policy={"name": "operator", "start_kpa": 0.8, "max_kpa": 0.8})
    result = run_trial(spec)
    assert not result["success"]
    max_s = spec.scene["episode"]["max_s"]
    assert result["time_s"] < max_s - 5.0
    assert result["stall_count"] >= 1
    # it stalled, then waited GIVE_UP_S at its cap (the regulator had long reached 3 kPa)
    assert result["time_s"] >= GIVE_UP_S


@pytest.mark.parametrize("bad", [{"name": "operator", "max_kpa": 9.0}, {"name": "cycle", "high_kpa": -1.0}])
def test_policy_caps_are_range_checked(bad):
    with pytest.raises(ValueError, match="kpa = .* is out of range: allowed \\[0, 8\\] kPa"):
        make_policy(bad)
