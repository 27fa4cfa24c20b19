"""First use of the command line: `evertgym train NAME` takes a shipped config by name and
`--timesteps N` tries it briefly in its own run folder; `evertgym policies` fits 100 columns; a
misspelt flag gets its subcommand's usage; flag and file ranges are worded alike."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evertgym.cli import main


def test_a_shipped_config_by_name_and_a_short_try_of_it(tmp_path):
    from evertgym.agents.train import load_config, resolve_config, run_status
    from evertgym.agents.tuned import shipped_dir

    assert resolve_config("ubend_ppo_operator") == shipped_dir() / "ubend_ppo_operator.toml"
    cfg = load_config("ubend_ppo_operator", timesteps=2048)
    assert cfg["n_timesteps"] == 2048 and cfg["name"] == "ubend_ppo_operator_2048steps"
    assert load_config("ubend_ppo_operator", seed=1, timesteps=64)["name"] == "ubend_ppo_operator_seed1_64steps"
    status = run_status("colon_residual_operator", tmp_path, None, 100)
    assert status["run_dir"] == str(tmp_path / "colon_residual_operator_100steps") and status["n_timesteps"] == 100
    with pytest.raises(ValueError, match="neither a file nor a shipped config; shipped: .*'ubend_ppo_operator'"):
        resolve_config("ubend_ppo_operatr")
    with pytest.raises(ValueError, match="timesteps = 0 is out of range"):
        load_config("ubend_ppo_operator", timesteps=0)


def test_train_refuses_an_unknown_name_in_one_line(capsys):
    assert main(["train", "no_such_policy"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "shipped:" in err and "ubend_ppo_operator" in err


def test_train_timesteps_trains_a_short_try_into_its_own_folder(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    cfg = tmp_path / "tiny.toml"
    cfg.write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nseed = 1\nn_envs = 1\nn_timesteps = 100000\nnormalize = true\n'
                   "checkpoint_freq = 128\neval_episodes = 0\n[env_kwargs]\nmax_episode_s = 1.0\n"
                   "[hyperparams]\nn_steps = 64\nbatch_size = 32\nn_epochs = 1\n")
    out = tmp_path / "runs"
    assert main(["train", str(cfg), "--timesteps", "128", "--out", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "trained 128 env steps" in text and str(Path(out, "tiny_128steps", "final.zip")) in text
    assert json.loads((out / "tiny_128steps" / "eval.json").read_text())["num_timesteps"] == 128
    assert not (out / "tiny").exists()  # the full run's folder is untouched


def test_policies_fits_100_columns_and_gives_the_correction_in_kpa(capsys):
    assert main(["policies"]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100
    # a residual policy's largest correction in kPa: scale 0.25 action units of a [-1, 1] action over 0-8 kPa
    assert "correcting cycle by at most 1 kPa" in out and "by at most 0.2 kPa" in out
    assert "185/200 [0.88, 0.95] on quasistatic" in out  # tortuous_residual_operator, docs/results/tortuous_residual_operator_eval.json


def test_policies_says_which_policy_senses_the_tip_and_the_engine_of_its_number(tmp_path, monkeypatch, capsys):
    """No shipped policy senses the tip or runs on the dynamic engine (colon_ppo and ubend_ppo were retired), so a
    folder of one such card stands in for agents/: its line says both (policy_cards reads only JSON)."""
    import evertgym.agents.policies as policies

    folder = tmp_path / "agents"
    (folder / "tip_dynamic").mkdir(parents=True)
    (folder / "tip_dynamic" / "final.zip").write_bytes(b"")
    (folder / "tip_dynamic" / "final_env.json").write_text(json.dumps(
        {"env_id": "evertgym/UBend-v0", "env_kwargs": {"tip_sensing": True}, "engine": "dynamic"}))
    (folder / "held_out.json").write_text(json.dumps({"policies": {"tip_dynamic": {
        "env_id": "evertgym/UBend-v0", "env_kwargs": {}, "engine": "dynamic", "episodes": 200, "successes": 197,
        "ci_low": 0.9568, "ci_high": 0.9949, "source": "docs/results/x_eval.json"}}}))
    monkeypatch.setattr(policies, "shipped_dir", lambda: folder)
    assert main(["policies"]) == 0
    out = capsys.readouterr().out
    assert "197/200 [0.96, 0.99] on dynamic" in out and "observes tip_sensing=true (senses the tip)" in out
    assert main(["policies", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert (row["name"], row["senses_tip"], row["engine"], row["held_out"]["engine"]) == ("tip_dynamic", True, "dynamic", "dynamic")


def test_a_misspelt_flag_prints_the_subcommands_usage_and_the_nearest_flag(capsys):
    with pytest.raises(SystemExit) as e:
        main(["score", "--trails", "3"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "usage: evertgym score" in err and "unrecognized arguments: --trails 3 (did you mean --trials?)" in err


def test_flag_and_file_ranges_are_worded_alike(capsys):
    assert main(["score", "--bands-mm", "100", "--reduction", "0.9"]) == 2
    assert "--reduction = 0.9 is out of range: allowed [0, 0.6) (fraction of the diameter)" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["score", "--help"])
    assert "--bands-mm '' adds a bare robot" in " ".join(capsys.readouterr().out.split())


def test_tune_checks_its_flags_in_one_line_and_writes_where_tuned_loads(capsys):
    assert main(["tune", "--env", "evertgym/Nope-v0"]) == 2
    assert "--env = 'evertgym/Nope-v0'" in capsys.readouterr().err
    assert main(["tune", "--env", "evertgym/UBend-v0", "--episodes", "0"]) == 2
    assert "--episodes = 0 is out of range" in capsys.readouterr().err
    from evertgym.agents.tuned import shipped_dir, tuned_path

    assert tuned_path("evertgym/Colon-v0", shipped_dir()).name == "tuned_operator_Colon-v0.json"


def test_bench_rod_times_the_rod_solver_per_design(capsys):
    assert main(["bench", "rod", "--repeats", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert len(rows) == 8 and all(r["median_ms"] > 0 for r in rows)
    bare = next(r for r in rows if r["design"] == "no bands" and r["displacement_mm"] == 20.0)
    assert bare["k_n_per_m"] == pytest.approx(11.36, abs=0.05)  # the stiffness table's no-band row


def test_bench_render_times_a_frame_against_a_step(capsys):
    assert main(["bench", "render", "--frames", "1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [r["what"] for r in rows] == ["env step (0.1 s simulated)", "frame, evertgym.render", "frame, matplotlib render_rgb"]
    assert rows[0]["x_step"] == 1.0 and all(r["ms"] > 0 for r in rows)


def test_the_length_benchmark_runs_one_short_robot():
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "evertgym.bench.length", "--lengths-m", "0.2", "--repeats", "1", "--engine",
                           "dynamic"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "length_m" in done.stdout and "    0.20" in done.stdout


def test_the_peers_page_is_written_with_its_command(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "evertgym.bench.peers_page", "--repeats", "1", "--docs", str(tmp_path)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    page = (tmp_path / "peers.md").read_text()
    assert "python -m evertgym.bench.peers_page" in page and "scripts/" not in page


@pytest.mark.slow
def test_the_accuracy_page_is_written_with_its_command(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "evertgym.bench.accuracy_page", "--quick", "--docs", str(tmp_path)],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    page = (tmp_path / "benchmarks.md").read_text()
    assert "python -m evertgym.bench.accuracy_page" in page and (tmp_path / "benchmarks_pareto.png").is_file()


def test_the_calibration_command_refits_the_eversion_threshold_without_writing(capsys):
    from evertgym.experiments.calibration import main as calibration
    from evertgym.model.params import PARAMS_PATH

    before = PARAMS_PATH.read_bytes()
    assert calibration(["--part", "eversion", "--dry-run"]) == 0
    assert '"eversion_threshold"' in capsys.readouterr().out and PARAMS_PATH.read_bytes() == before


def test_the_dormant_walls_measurement_runs_a_short_growth():
    from evertgym.bench.dormant import run

    row = run(True, 0.0, 3.0, sim_s=0.5)
    assert row["dormant_walls"] is True and row["length_mm"] > 0 and row["wall_s"] > 0
