"""Design validation: every invalid field rejected with a message naming it and its range."""

import json

import pytest

from evertgym.design import Band, DesignError, TubeDesign


@pytest.mark.parametrize(
    "kwargs, field, allowed",
    [
        (dict(diameter_m=-0.04), "diameter_m", "[0.001, 0.5]"),
        (dict(diameter_m=0.0), "diameter_m", "[0.001, 0.5]"),
        (dict(diameter_m=float("nan")), "diameter_m", "not finite"),
        (dict(wall_thickness_m=0.0), "wall_thickness_m", "[1e-06, 0.002)"),
        (dict(wall_thickness_m=5e-324), "wall_thickness_m", "[1e-06, 0.002)"),  # Chipmunk aborted on it
        (dict(wall_thickness_m=0.005), "wall_thickness_m", "thin-walled"),
        (dict(length_m=-1.0), "length_m", "[0.025, 20]"),
        (dict(length_m="long"), "length_m", "not a number"),
        (dict(pressure_stiffening=-1.0), "pressure_stiffening", "[0, 10]"),
        (dict(membrane_modulus_pa=0.0), "membrane_modulus_pa", "(0, 1e+10]"),
    ],
)
def test_invalid_tube_fields_are_named(kwargs, field, allowed):
    with pytest.raises(DesignError) as e:
        TubeDesign(**kwargs)
    assert field in str(e.value) and allowed in str(e.value)


@pytest.mark.parametrize(
    "band, field, allowed",
    [
        (dict(position_m=0.3, reduction=0.7), "reduction", "[0, 0.6)"),
        (dict(position_m=0.3, reduction=0.6), "reduction", "[0, 0.6)"),
        (dict(position_m=0.3, reduction=-0.1), "reduction", "[0, 0.6)"),
        (dict(position_m=0.3, reduction=0.1, width_m=0.0), "width_m", "(0, 0.2]"),
        (dict(position_m=float("inf"), reduction=0.1), "position_m", "not finite"),
    ],
)
def test_invalid_band_fields_are_named(band, field, allowed):
    with pytest.raises(DesignError) as e:
        Band(**band)
    assert field in str(e.value) and allowed in str(e.value)


def test_band_outside_the_body_is_rejected():
    with pytest.raises(DesignError, match=r"bands\[0\].position_m = 0.7 .*allowed \[0.0075, 0.5925\]"):
        TubeDesign(length_m=0.6, bands=(Band(0.7, 0.1),))
    with pytest.raises(DesignError, match=r"bands\[0\].position_m"):
        TubeDesign(length_m=0.6, bands=(Band(0.0, 0.1),))


def test_overlapping_bands_are_rejected():
    with pytest.raises(DesignError, match=r"overlaps .*spacing >= 0.015"):
        TubeDesign(bands=(Band(0.30, 0.1), Band(0.31, 0.1)))
    TubeDesign(bands=(Band(0.30, 0.1), Band(0.315, 0.1)))  # touching strips are fine


def test_bands_are_sorted_by_position():
    d = TubeDesign(bands=(Band(0.4, 0.1), Band(0.2, 0.3)))
    assert [b.position_m for b in d.bands] == [0.2, 0.4]


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_design_file_round_trip(tmp_path, suffix):
    d = TubeDesign(0.02, 0.05e-3, 0.8, (Band(0.25, 0.1), Band(0.30, 0.1), Band(0.35, 0.1)), pressure_stiffening=0.5)
    path = tmp_path / f"design{suffix}"
    d.save(path)
    assert TubeDesign.load(path) == d
    text = path.read_text()
    assert "diameter_mm" in text and "position_mm" in text  # field units at the edge


def test_bands_from_tip_convert_to_body_coordinates():
    d = TubeDesign(length_m=0.6).with_bands_from_tip([0.05, 0.1], 0.5)
    assert [round(b.position_m, 9) for b in d.bands] == [0.5, 0.55]


@pytest.mark.parametrize(
    "text, message",
    [
        ("[tube]\ndiameter_mm = -40\n", "tube.diameter_mm = -40.0 is out of range: allowed [1, 500] mm"),
        # a denormal wall passed the old open bound (0, ...) and made Chipmunk abort on the segment mass
        ("[tube]\nwall_thickness_mm = 2.225073858507203e-309\n",
         "tube.wall_thickness_mm = 2.225073858507203e-309 is out of range: allowed [0.001, 2) mm"),
        ("[tube]\nlength_mm = 600\n[[bands]]\nposition_mm = 800\nreduction = 0.1\n",
         "bands[0].position_mm = 800 is out of range: allowed [7.5, 592.5] mm"),
        ("[[bands]]\nposition_mm = 300\nreduction = 0.1\n[[bands]]\nposition_mm = 200\nreduction = 0.1\n"
         "[[bands]]\nposition_mm = 305\nreduction = 0.1\n", "bands[2].position_mm = 305 overlaps bands[0] at 300"),
        ("[[bands]]\nposition_mm = 300\nreductoin = 0.1\n", "bands[0]: unknown field(s) ['reductoin']"),
        ("[tube]\ndiameter = 40\n", "unknown field(s) ['diameter']"),
        ("[[bands]]\nposition_mm = 300\nreduction = 0.7\n", "bands[0].reduction = 0.7 is out of range: allowed [0, 0.6)"),
        ("[[bands]]\nreduction = 0.1\n", "bands[0] must have position_mm and reduction"),
        ("[[bands]]\nposition_mm = 'x'\nreduction = 0.1\n", "bands[0].position_mm = 'x' is not a number"),
        ("[tube\n", "malformed design file"),
        ("[robot]\n", "unknown design section(s) ['robot']"),
    ],
)
def test_malformed_design_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(DesignError) as e:
        TubeDesign.load(path)
    assert message in str(e.value)


def test_malformed_json_design(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"bands": {"position_mm": 1}}))
    with pytest.raises(DesignError, match="bands must be a list"):
        TubeDesign.load(path)
