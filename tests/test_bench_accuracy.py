"""The accuracy sweep's choice of default and its contact-safety measure (no timings here)."""

import pytest

from evertgym.bench.accuracy import REFERENCE, SweepSetting, run_sweep, wall_overlap_mm
from evertgym.sim import SimConfig


def _row(setting: SweepSetting, force: float, overlap: float, wall: float, converged: bool = True) -> dict:
    return {"label": setting.label, "setting": setting.fidelity(), "tip_force_error": force, "tip_pose_error_mm": 0.1,
            "tensile_converged": converged, "ubend_disagreement": 0.0, "ubend_outcomes": [],
            "wall_s_per_sim_s": wall, "wall_overlap_mm": overlap, "colon_peak_force_n": 1.0}


def test_the_default_is_the_fastest_setting_within_budget_that_keeps_contact():
    coarse = SweepSetting("coarse", {"segment_length_m": 0.015})
    leaky = SweepSetting("leaky", {"dt_s": 0.004})
    slack = SweepSetting("slack", {"iterations": 5})
    fine = SweepSetting("fine", {"dt_s": 0.001})
    rows = {s.label: _row(s, f, o, w) for s, f, o, w in (
        (REFERENCE, 0.01, 0.0, 0.10),
        (coarse, 0.08, 0.0, 0.01),    # fastest, but 8% force error
        (leaky, 0.0275, 0.5, 0.012),  # within 3%, but the tube passes 0.5 mm into a wall
        (slack, 0.0275, 0.0, 0.02),   # the answer
        (fine, 0.0275, 0.0, 0.04),
    )}
    result = run_sweep([REFERENCE, coarse, leaky, slack, fine], done=rows)
    assert result["default"]["label"] == "slack"
    assert result["default"]["equals_simconfig_default"] is False
    # the Pareto set is over time, force error and U-bend disagreement only: the leaky setting is on it
    assert {r["label"] for r in result["rows"] if r["pareto"]} == {"coarse", "leaky", "reference (finest)"}


@pytest.mark.parametrize("dt_s", [0.002, 0.004])
def test_the_tube_keeps_out_of_the_tightest_ubend_wall_at_8kpa(dt_s):
    """The contact-safety run (20 mm U-bend, 8 kPa, 8 s): within the stress tests' tolerances."""
    assert wall_overlap_mm(SimConfig(dt_s=dt_s)) == 0.0
