"""docs/choosing_bands.md's U-bend recommendation is what its command prints on the default physics."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evertgym.cli import main

PAGE = Path(__file__).resolve().parent.parent / "docs" / "choosing_bands.md"


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_the_30_mm_u_bend_recommendation_is_reproduced_by_its_command(tmp_path, capsys):
    argv = ["optimize", "--scene", "ubend", "--scene-params", '{"radius_mm": 30}', "--held-out", "24",
            "--study", str(tmp_path / "study.sqlite"), "--db", str(tmp_path / "trials.sqlite"), "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    bands = out["best_design"]["bands"]
    where = ", ".join(f"{b['position_mm']:.0f}" for b in bands)
    assert f"best after 20 designs: {len(bands)} bands at {where} mm from the base" in PAGE.read_text(encoding="utf-8")
    rows = {r["design_name"]: r for r in out["held_out"]}
    assert rows["best"]["successes"] == rows["best"]["n"] == 48
    assert rows["no bands"]["successes"] <= 1
    best_bare = next(d for d in out["differences"] if (d["design"], d["other"]) == ("best", "no bands"))
    assert best_bare["ci_lo"] > 0.8  # the page: +0.98 [+0.86, +1.00]
    assert all(r.get("unconverged_solves", 0) == 0 for r in out["held_out"])
