"""Human summaries of the CLI (``--json`` keeps the machines' output)."""

from __future__ import annotations

import json

from evertgym.cli import main


def test_score_says_which_policy_scene_and_counts(tmp_path, capsys):
    argv = ["score", "--scene", "straight", "--scenes", "1", "--trials", "2", "--backend", "serial",
            "--db", str(tmp_path / "s.sqlite"), "--max-s", "1", "--length-mm", "600"]
    assert main([*argv, "--plot", str(tmp_path / "s.png")]) == 0
    out = capsys.readouterr().out
    assert "policy: constant, pressure_kpa=3" in out
    assert "scene:  straight (default parameters), seeds 0-0; 2 trials per scene" in out
    assert "designs: 1, 2 trials in all" in out
    assert (tmp_path / "s.png").stat().st_size > 0
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"rows", "differences", "physics", "unconverged_solves", "trials_unconverged"}
    assert out["physics"].startswith("physics: quasi-static engine")


def test_rollout_prints_a_summary_and_json_keeps_every_command(tmp_path, capsys, monkeypatch):
    import evertgym.agents.rollout as rollout

    info = {"frames": 3, "success": True, "time_s": 0.3, "peak_pressure_kpa": 4.0, "command_kpa": [2.0, 3.0, 4.0],
            "out": str(tmp_path / "r.gif"), "episode_seed": 1_000_000_000, "engine": "quasistatic"}
    monkeypatch.setattr(rollout, "rollout_gif", lambda *a, **k: dict(info))  # the episode itself: tests/test_agents.py
    argv = ["rollout", "operator", "--env", "evertgym/UBend-v0", "--out", str(tmp_path / "r.gif")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "success after 0.3 s (3 control steps); peak pressure 4.00 kPa; quasistatic engine" in out
    assert "pressure command: mean 3.00 kPa, range 2.00-4.00 kPa" in out and "[" not in out
    assert main([*argv, "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == info
