"""Exp 4, simulated: minimum eversion pressures against the paper's table."""

import json

import pytest

from evertgym.cli import main
from evertgym.experiments.eversion import everts, min_eversion_pressure, paper_eversion_robot, reproduce_eversion
from evertgym.model.eversion import EversionThreshold, fit_eversion_threshold
from evertgym.model.params import load_measurements

TABLE = {r["diameter_reduction"]: r for r in load_measurements()["eversion_pressure_test"]["rows"]}


@pytest.mark.parametrize("reduction", [0.0, 0.3])
def test_simulated_minimum_pressure_within_one_sd(reduction):
    p = min_eversion_pressure(paper_eversion_robot(reduction), step_pa=10.0)
    row = TABLE[reduction]
    assert p is not None
    assert abs(p / 1e3 - row["median_min_pressure_kPa"]) <= row["sd"]


def test_a_60_percent_band_never_everts_at_8kpa_or_below():
    assert not everts(paper_eversion_robot(0.6), 8000.0)
    assert min_eversion_pressure(paper_eversion_robot(0.6)) is None


def test_threshold_law_is_super_linear_and_calibrated_file_matches_a_refit():
    law = EversionThreshold.calibrated()
    p = [float(law(r)) for r in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)]
    steps = [b - a for a, b in zip(p, p[1:])]
    assert all(b > a for a, b in zip(steps, steps[1:]))  # convex: super-linear
    refit = fit_eversion_threshold()
    assert refit["p0_pa"] == pytest.approx(law.p0_pa, rel=1e-4)
    assert max(abs(r) for r in refit["residuals_in_sd"]) < 1.0


@pytest.mark.slow
def test_full_eversion_table_within_one_sd_and_json_contract(capsys):
    assert main(["reproduce", "eversion", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    rows = {r["reduction"]: r for r in out["rows"]}
    assert set(rows) == {0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6}
    for red, r in rows.items():
        assert set(r) >= {"reduction", "measured_kpa", "sd_kpa", "simulated_kpa"}
        if red <= 0.5:
            assert abs(r["simulated_kpa"] - r["measured_kpa"]) <= r["sd_kpa"]
    assert rows[0.6]["simulated_kpa"] is None


def test_reproduce_eversion_rows_shape():
    out = reproduce_eversion(reductions=[0.6])
    assert out["rows"] == [{"reduction": 0.6, "measured_kpa": None, "sd_kpa": None, "simulated_kpa": None}]
