"""The paper's stiffness table: calibrated rows and predicted rows (Exp 2)."""

import json

import pytest

from evertgym.cli import main
from evertgym.experiments.stiffness import reproduce_stiffness
from evertgym.model.params import load_params
from evertgym.model.stiffness import paper_rows


@pytest.fixture(scope="module")
def result():
    return reproduce_stiffness()


def test_rows_follow_measurements_json(result):
    rows = result["rows"]
    assert len(rows) == len(paper_rows()) == 19
    assert {r["experiment"] for r in rows} == {1, 2, 3}
    assert all(r["role"] == ("predict" if r["experiment"] == 2 else "calibrate") for r in rows)


def test_rms_errors_meet_the_targets(result):
    assert result["rms"]["calibrate"] <= 0.10
    assert result["rms"]["predict"] <= 0.08


def test_findings_of_the_paper_hold(result):
    by = {(tuple(r["bands_from_tip_mm"]), r["reduction"], r["experiment"]): r["cosserat_n_per_m"] for r in result["rows"]}
    # more bands lower k cumulatively
    e1 = [by[(b, 0.5 if b else 0.0, 1)] for b in [(), (50,), (50, 100), (50, 100, 150), (50, 100, 150, 200)]]
    assert all(a > b for a, b in zip(e1, e1[1:]))
    # a band further from the tip lowers k more (predicted, Exp 2)
    e2 = [by[((d,), 0.5, 2)] for d in range(30, 101, 10)]
    assert all(a > b for a, b in zip(e2, e2[1:]))
    # larger reduction lowers k, more steeply from 40 to 50% than from 10 to 20%
    e3 = [by[((100,), red, 3)] for red in (0.1, 0.2, 0.3, 0.4, 0.5)]
    assert all(a > b for a, b in zip(e3, e3[1:]))
    assert (e3[3] - e3[4]) > 2 * (e3[0] - e3[1])


def test_calibration_never_saw_exp2():
    prov = load_params().provenance
    assert "calibrate_on" in prov["fitted_on"] and "Exp 2" in prov["held_out"]


def test_cli_json_contract(capsys):
    assert main(["reproduce", "stiffness", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    row = out["rows"][2]
    assert row["experiment"] == 1 and row["role"] == "calibrate"
    assert row["bands_from_tip_mm"] == [50, 100] and row["reduction"] == 0.5
    assert row["measured_n_per_m"] == 3.2 and row["cosserat_n_per_m"] > 0
    assert set(out["rms"]) >= {"calibrate", "predict"}


def test_stiffness_cli_json(capsys):
    assert main(["stiffness", "--bands-from-tip-mm", "50,100", "--reduction", "0.3", "--displacement-mm", "20", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) >= {"cosserat_force_n", "cosserat_n_per_m", "tip_x_mm", "tip_y_mm", "tip_angle_deg"}
    assert out["tip_y_mm"] == pytest.approx(20.0, rel=1e-6)
    assert out["cosserat_n_per_m"] == pytest.approx(out["cosserat_force_n"] / 0.02)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--reduction", "0.7", "--bands-from-tip-mm", "50"], "--reduction = 0.7 is out of range"),
        (["--length-mm", "-5"], "--length-mm = -5.0 is out of range"),
        (["--pressure-kpa", "9"], "--pressure-kpa = 9.0 is out of range: allowed [0.01, 8] kPa"),
        (["--displacement-mm", "nan"], "--displacement-mm = nan is out of range"),
        (["--bands-from-tip-mm", "50,abc"], "--bands-from-tip-mm = '50,abc'"),
        (["--bands-from-tip-mm", "700"], "bands[0].position_m"),
    ],
)
def test_stiffness_cli_rejects_bad_input(capsys, argv, message):
    assert main(["stiffness", *argv]) == 2
    assert message in capsys.readouterr().err
