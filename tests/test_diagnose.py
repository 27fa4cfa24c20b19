"""`evertgym diagnose`: the section law's trace of one U-bend trial, and its bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from evertgym.experiments.diagnose import plot_trace, trace_ubend


@pytest.fixture(scope="module")
def trace():
    return trace_ubend(40.0, 0.0, 0, sim={"engine": "dynamic", "section_law": True})


def test_trace_samples_every_control_step_with_the_section_law_state(trace):
    s = trace["samples"]
    assert trace["section_law"] and len(s) > 20
    assert [x["t_s"] for x in s] == sorted(x["t_s"] for x in s)
    for x in s:
        n = len(x["joint_mm"])
        assert len(x["wall_tension_n"]) == len(x["moment_ratio"]) == len(x["capacity_n"]) == n
        # the tip never takes more than the weakest section's capacity by more than the window's slack
        assert x["tip_axial_force_n"] <= 1.5 * 3000.0 * math.pi * 0.02**2
    straight = s[5]  # early, in the straight pipe: no axial load, T_wall = p pi r^2 - T_tail
    p = straight["pressure_kpa"] * 1e3
    assert max(straight["wall_tension_n"]) <= p * math.pi * 0.02**2 + 1e-6


def test_trace_plots(trace, tmp_path):
    out = plot_trace(trace, tmp_path / "t.png")
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("argv, field", [
    (["--radius-mm", "10"], "--radius-mm"),
    (["--sim", '{"nope": 1}'], "nope"),
    (["--sim", '{"dt_s": -1}'], "dt_s"),
    (["--sim", "[1"], "--sim"),
    (["--casing-friction", "9"], "--casing-friction"),
])
def test_bad_input_is_one_line_and_exit_2(argv, field):
    r = subprocess.run([sys.executable, "-m", "evertgym.cli", "diagnose", *argv], capture_output=True, text=True)
    assert r.returncode == 2
    assert field in r.stderr and "Traceback" not in r.stderr


def test_json_output_is_the_trace():
    r = subprocess.run([sys.executable, "-m", "evertgym.cli", "diagnose", "--radius-mm", "40", "--section-law", "--json"],
                       capture_output=True, text=True, check=True)
    d = json.loads(r.stdout)
    assert {"radius_mm", "success", "samples", "bands_mm", "section_law"} <= set(d)


def test_the_jam_anatomy_script_runs_and_names_its_engine(tmp_path):
    """``python -m evertgym.experiments.ubend_jams`` (its page is docs/ubend_jams.md) on one bare trial: the page
    names the engine; a knob of the other engine is refused in one line."""
    import subprocess
    import sys

    script = "-m evertgym.experiments.ubend_jams"
    page = tmp_path / "jams.md"
    out = subprocess.run([sys.executable, *script.split(), "--radii", "40", "--reductions", "0", "--trials", "1", "--workers", "1",
                          "--sim", '{"engine": "dynamic"}', "--write", str(page)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "engine 'dynamic'" in page.read_text() and "| no bands | 40 |" in out.stdout
    bad = subprocess.run([sys.executable, *script.split(), "--sim", '{"mass_ratio": 0.1}'], capture_output=True, text=True)
    assert bad.returncode == 2 and "mass_ratio = 0.1 means nothing to engine 'quasistatic'" in bad.stderr.strip().splitlines()[-1]
