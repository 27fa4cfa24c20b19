"""A new user's first steps: resume after Ctrl-C, a run's own checkpoints, missing
extras, the shipped policies, progress and verdicts, and a clone named ``evertgym`` in the
current folder."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from evertgym.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _tiny_config(folder: Path, name: str = "tiny", n_timesteps: int = 512, tip_sensing: bool = True) -> Path:
    """A PPO config that trains in seconds: 1 s episodes (10 steps), a checkpoint every 128 steps."""
    cfg = folder / f"{name}.toml"
    cfg.write_text(
        f'env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nseed = 1\nn_envs = 1\nn_timesteps = {n_timesteps}\nnormalize = true\n'
        "checkpoint_freq = 128\neval_episodes = 0\n"
        f"[env_kwargs]\nmax_episode_s = 1.0\ntip_sensing = {str(tip_sensing).lower()}\n"
        "[hyperparams]\nn_steps = 64\nbatch_size = 32\nn_epochs = 1\n"
    )
    return cfg


# ---- 1. resume after Ctrl-C -------------------------------------------------------------------
@pytest.mark.slow
def test_a_train_interrupted_by_ctrl_c_resumes_when_the_same_command_is_rerun(tmp_path):
    """SIGINT after the first checkpoint; the same command again continues from it (no
    --resume).  The fast variant below reruns in this process."""
    pytest.importorskip("stable_baselines3")
    cfg = _tiny_config(tmp_path, n_timesteps=512)
    out = tmp_path / "runs"
    run = out / "tiny"
    cmd = [sys.executable, "-m", "evertgym.cli", "train", str(cfg), "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.time() + 240
    while time.time() < deadline and not list((run / "checkpoints").glob("model_vecnormalize_*_steps.pkl")):
        time.sleep(0.1)  # the statistics are saved after the model: a checkpoint is complete
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-2000:]
    assert "rerun the same command to resume" in err
    assert not (run / "final.zip").exists(), "the run finished before the interrupt: nothing was tested"
    saved = sorted(int(p.name.split("_")[1]) for p in (run / "checkpoints").glob("model_*_steps.zip"))

    again = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]
    resumed = json.loads((run / "config.json").read_text())["resume"]
    assert resumed is not None and resumed["num_timesteps"] in saved, "the rerun started again at step 0"
    assert f"resuming {run} from its checkpoint at {resumed['num_timesteps']} of 512 steps" in again.stderr
    summary = json.loads((run / "eval.json").read_text())
    assert summary["resumed_from_steps"] == resumed["num_timesteps"] and summary["num_timesteps"] >= 512


def test_a_rerun_continues_from_the_checkpoint_and_a_finished_run_is_not_trained_again(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    from evertgym.agents.train import train

    cfg = _tiny_config(tmp_path, n_timesteps=128)
    argv = ["train", str(cfg), "--out", str(tmp_path)]
    assert main([*argv, "--resume", "--no-progress"]) == 2
    assert "--resume: " in capsys.readouterr().err and not (tmp_path / "tiny" / "final.zip").exists()
    train(cfg, out_dir=tmp_path, progress=False)  # stopped at 128 steps, as if by Ctrl-C after its checkpoint
    with pytest.raises(ValueError, match="already holds a run with a checkpoint at 128 steps"):
        train(cfg, out_dir=tmp_path, resume=False, progress=False)
    _tiny_config(tmp_path, n_timesteps=256)
    from evertgym.agents.train import run_status

    assert run_status(cfg, tmp_path) == {"run_dir": str(tmp_path / "tiny"), "n_timesteps": 256, "checkpoint_steps": 128,
                                         "finished": False}
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"resuming {tmp_path / 'tiny'} from its checkpoint at 128 of 256 steps" in err
    assert "return=" in err and "success=" in err  # the bar's rolling episode return and success
    assert json.loads((tmp_path / "tiny" / "config.json").read_text())["resume"]["num_timesteps"] == 128
    final = (tmp_path / "tiny" / "final.zip").read_bytes()
    assert main([*argv, "--json"]) == 0
    out = capsys.readouterr()
    assert "already trained to 256 steps: nothing to do" in out.err
    assert json.loads(out.out)["already_trained"] is True
    assert (tmp_path / "tiny" / "final.zip").read_bytes() == final


# ---- 2. a user's own checkpoint -----------------------------------------------------------------
@pytest.fixture(scope="module")
def tip_sensing_run(tmp_path_factory) -> Path:
    """A run trained with tip sensing (17 observations, against UBend-v0's default 15)."""
    pytest.importorskip("stable_baselines3")
    from evertgym.agents.train import train

    folder = tmp_path_factory.mktemp("run")
    train(_tiny_config(folder, n_timesteps=128), out_dir=folder, progress=False)
    return folder / "tiny"


def _eval(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["eval", *argv, "--env", "evertgym/UBend-v0", "--episodes", "1", "--env-kwargs", '{"max_episode_s": 1.0}', "--json"])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_a_runs_checkpoint_evaluates_with_the_runs_observation_flags(tip_sensing_run, capsys):
    ckpt = tip_sensing_run / "checkpoints" / "model_128_steps.zip"
    assert json.loads((ckpt.parent / "model_128_steps_env.json").read_text())["env_kwargs"]["tip_sensing"] is True
    code, out, err = _eval(capsys, str(ckpt), "--trust-model")
    assert code == 0, err
    assert json.loads(out)["rows"][0]["episodes"] == 1
    # a run trained before checkpoints carried their env: the run's config.json says it
    (ckpt.parent / "model_128_steps_env.json").unlink()
    code, out, err = _eval(capsys, str(ckpt), "--trust-model")
    assert code == 0, err
    from evertgym.agents import load_policy

    policy, env_id, kwargs = load_policy(ckpt, trust=True)
    assert (env_id, kwargs["tip_sensing"]) == ("evertgym/UBend-v0", True)
    assert policy.obs_rms is not None  # SB3's checkpoint name of the normaliser: model_vecnormalize_128_steps.pkl


def test_a_real_observation_mismatch_is_one_line_with_both_shapes_and_the_fix(tip_sensing_run, tmp_path, capsys):
    for f in ("model_128_steps.zip", "model_vecnormalize_128_steps.pkl"):  # a copy without its run
        shutil.copy(tip_sensing_run / "checkpoints" / f, tmp_path / f)
    code, _, err = _eval(capsys, str(tmp_path / "model_128_steps.zip"), "--trust-model")
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "takes observations of shape (17,) but evertgym/UBend-v0 gives (15,)" in err
    assert """--env-kwargs '{"tip_sensing": true}'""" in err
    argv = ["rollout", str(tmp_path / "model_128_steps.zip"), "--env", "evertgym/UBend-v0", "--trust-model", "--out", str(tmp_path / "r.gif")]
    assert main(argv) == 2
    assert "shape (17,) but evertgym/UBend-v0 gives (15,)" in capsys.readouterr().err
    assert main([*argv, "--env-kwargs", '{"tip_sensing": true, "max_episode_s": 1.0}', "--json"]) == 0


# ---- 3. missing extras -------------------------------------------------------------------------
_BLOCKED = textwrap.dedent("""
    import contextlib, importlib.abc, io, sys

    class Missing(importlib.abc.MetaPathFinder):  # as if the extras were not installed
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in {"torch", "stable_baselines3", "tensorboard", "optuna", "dask", "distributed"}:
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)

    sys.meta_path.insert(0, Missing())
    from evertgym.cli import main

    for argv in COMMANDS:
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(argv)
        print(json.dumps([code, err.getvalue()]))
""")


def test_every_command_that_needs_an_extra_names_it(tmp_path):
    commands = [
        ["eval", "colon_ppo_operator", "--env", "evertgym/Colon-v0", "--episodes", "1"],
        ["rollout", "ubend_ppo_operator", "--env", "evertgym/UBend-v0", "--out", str(tmp_path / "r.gif")],
        ["train", str(_tiny_config(tmp_path)), "--out", str(tmp_path / "runs")],
        ["score", "--scene", "straight", "--scenes", "1", "--trials", "1", "--policy", "colon_ppo_operator", "--backend", "serial",
         "--db", str(tmp_path / "a.sqlite")],
        ["score", "--scene", "straight", "--scenes", "1", "--trials", "1", "--policy", str(ROOT / "agents" / "ubend_ppo_operator" / "final.zip"),
         "--db", str(tmp_path / "b.sqlite")],
        ["optimize", "--trials", "1", "--study", str(tmp_path / "s.sqlite"), "--db", str(tmp_path / "o.sqlite")],
        ["score", "--scene", "straight", "--scenes", "1", "--trials", "1", "--backend", "dask", "--db", str(tmp_path / "d.sqlite")],
    ]
    extras = ["rl", "rl", "rl", "rl", "rl", "design", "cluster"]
    code = f"import json\nCOMMANDS = {commands!r}\n" + _BLOCKED
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    for argv, extra, line in zip(commands, extras, done.stdout.splitlines()):
        status, err = json.loads(line)
        assert status == 2 and err.count("\n") == 1, (argv, err)
        assert f"pip install 'evertgym[{extra}]'" in err, (argv, err)


# ---- 4. discovery -------------------------------------------------------------------------------
def test_policies_lists_every_shipped_policy_with_env_observations_config_and_held_out_success(capsys):
    from evertgym.agents import shipped_policies

    assert main(["policies"]) == 0
    out = capsys.readouterr().out
    assert "185/200 [0.88, 0.95]" in out  # tortuous_residual_operator, docs/results/tortuous_residual_operator_eval.json
    for name in shipped_policies():
        assert f"agents/{name}.toml" in out
    assert main(["policies", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [r["name"] for r in rows] == shipped_policies()
    assert not {"colon_ppo", "ubend_ppo"} & {r["name"] for r in rows}  # retired (their configs are in agents/tries/)
    ubend = rows[[r["name"] for r in rows].index("ubend_ppo_operator")]
    assert ubend["env_id"] == "evertgym/UBend-v0" and ubend["observations"] == {"tip_sensing": False}
    assert ubend["held_out"]["successes"] == 200 and ubend["held_out"]["engine"] == "quasistatic"
    assert ubend["held_out"]["env_kwargs"] == {"regulator_tau_s": [0.1, 0.6]}
    # every listed number says the engine it was measured on; a policy that senses the tip says so
    assert all(r["engine"] in ("dynamic", "quasistatic") and r["held_out"]["engine"] in ("dynamic", "quasistatic") for r in rows)
    assert {r["name"] for r in rows if r["senses_tip"]} == {r["name"] for r in rows if r["observations"].get("tip_sensing")}
    # a residual policy names the rule it corrects; a plain one has none
    residual = {r["name"]: r["residual"] for r in rows}
    assert residual["colon_residual_operator"] == {"rule": "cycle:low_kpa=0,high_kpa=3,period_s=1", "scale": 0.25}
    assert residual["tortuous_residual_operator"] == {"rule": "cycle", "scale": 0.25}
    assert residual["tortuous_v1_residual_operator"] == {"rule": "cycle", "scale": 0.25}
    assert residual["ubend_residual_operator"]["scale"] == 0.05
    assert residual["colon_ppo_operator"] is None
    assert "correcting\n      cycle:low_kpa=0,high_kpa=3,period_s=1 by at most 1 kPa" in out


def test_the_held_out_index_agrees_with_the_evaluations_in_docs():
    done = subprocess.run([sys.executable, "-m", "evertgym.agents.held_out", "--check"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr


def test_an_unknown_policy_lists_the_shipped_ones(capsys):
    assert main(["eval", "foo_ppo", "--env", "evertgym/UBend-v0"]) == 2
    err = capsys.readouterr().err
    assert "unknown policy 'foo_ppo'" in err and "'colon_ppo_operator'" in err and "evertgym policies" in err


def test_the_eval_table_never_cuts_a_name(monkeypatch, capsys):
    import evertgym.agents.evaluate as evaluate

    name = "cycle:low_kpa=0,high_kpa=3,period_s=1"
    row = {"policy": name, "episodes": 1, "successes": 1, "success_rate": 1.0, "ci_low": 0.2, "ci_high": 1.0, "mean_time_to_goal_s": 1.0,
           "mean_peak_pressure_kpa": 3.0, "mean_max_contact_force_n": 1.0, "mean_peak_pressure_bend_kpa": 3.0,
           "bend_reached_episodes": 1, "peak_before_bend_episodes": 0}
    monkeypatch.setattr(evaluate, "evaluate", lambda *a, **k: [row])
    assert main(["eval", name, "--env", "evertgym/UBend-v0", "--episodes", "1"]) == 0
    assert f"\n{name} " in capsys.readouterr().out


def test_the_eval_table_prints_the_count_of_passes(monkeypatch, capsys):
    """171 of 200 is printed as a count beside the rate: a rounded 0.85 once read back as 170."""
    import evertgym.agents.evaluate as evaluate

    row = {"policy": "operator", "episodes": 200, "successes": 171, "success_rate": 0.855, "ci_low": 0.8, "ci_high": 0.9,
           "mean_time_to_goal_s": 1.0, "mean_peak_pressure_kpa": 3.0, "mean_max_contact_force_n": 1.0,
           "mean_peak_pressure_bend_kpa": 3.0, "bend_reached_episodes": 1, "peak_before_bend_episodes": 0}
    monkeypatch.setattr(evaluate, "evaluate", lambda *a, **k: [row])
    assert main(["eval", "operator", "--env", "evertgym/UBend-v0", "--episodes", "200"]) == 0
    out = capsys.readouterr().out
    assert " passed " in out and "   171    0.855 [0.800, 0.900]" in out


# ---- 5. progress ------------------------------------------------------------------------------
def test_optimize_shows_a_bar_with_the_best_design_so_far(tmp_path, capsys):
    argv = ["optimize", "--trials", "2", "--scenes", "1", "--trials-per-scene", "1", "--held-out", "1", "--backend", "serial",
            "--study", str(tmp_path / "s.sqlite"), "--db", str(tmp_path / "t.sqlite")]
    assert main(argv) == 0
    out = capsys.readouterr()
    assert "optimize: 100%" in out.err and "2/2" in out.err and "best=" in out.err
    assert "best after 2 designs: " in out.out


# ---- 6. verdicts --------------------------------------------------------------------------------
def test_score_prints_the_difference_to_the_first_design_with_a_verdict(tmp_path, capsys):
    design = tmp_path / "banded.toml"
    design.write_text("[tube]\ndiameter_mm = 40.0\nlength_mm = 600.0\n[[bands]]\nposition_mm = 300.0\nreduction = 0.2\n")
    argv = ["score", "--design", str(design), "--bands-mm", "", "--scene", "straight", "--scenes", "1", "--trials", "2",
            "--backend", "serial", "--db", str(tmp_path / "s.sqlite"), "--max-s", "1", "--length-mm", "600"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "banded - no bands: " in out and "(Newcombe 95%); " in out
    assert "no clear winner between banded and no bands" in out or "succeeds more often than" in out
    assert main([*argv, "--json"]) == 0
    diff = json.loads(capsys.readouterr().out)["differences"]
    assert [(d["design"], d["other"]) for d in diff] == [("banded", "no bands")]
    assert diff[0]["ci_lo"] <= diff[0]["difference"] <= diff[0]["ci_hi"]


_STUDY = {"objective": "objective: ...", "study": {"path": "s.sqlite", "name": "bands-x", "new": True, "resumed_designs": 0,
                                                   "settings": {}, "other_studies": []}}


def test_optimize_prints_a_design_without_bands_as_having_no_spacing_or_reduction(monkeypatch, capsys):
    import evertgym.experiments.optimize as optimize

    rows = [{"design_name": name, "n": 8, "successes": k, "success_rate": k / 8, "success_ci_lo": 0.0, "success_ci_hi": 1.0}
            for name, k in (("best", 8), ("paper 3 x 10% / 50 mm", 2))]
    out = {"best_params": {"n_bands": 0, "spacing_mm": 53.2, "reduction": 0.31, "last_band_mm": 201.0},
           "best_design": {"tube": {}, "bands": []}, "held_out": rows, "trials": 3, **_STUDY}
    monkeypatch.setattr(optimize, "optimize_bands", lambda *a, **k: out)
    assert main(["optimize", "--trials", "3"]) == 0
    text = capsys.readouterr().out
    assert "best after 3 designs: no bands (n_bands = 0; spacing, reduction and last band: absent)" in text
    assert "53.2" not in text and "0.31" not in text
    assert "best succeeds more often than paper 3 x 10% / 50 mm" in text


def test_optimize_tests_the_best_and_the_paper_design_against_the_bare_robot(monkeypatch, capsys):
    import evertgym.experiments.optimize as optimize

    rows = [{"design_name": name, "n": 16, "successes": k, "success_rate": k / 16, "success_ci_lo": 0.0, "success_ci_hi": 1.0}
            for name, k in (("best", 15), ("paper 3 x 10% / 50 mm", 9), ("no bands", 2))]
    out = {"best_params": {"n_bands": 3, "spacing_mm": 50.0, "reduction": 0.12, "last_band_mm": 300.0},
           "best_design": {"tube": {}, "bands": [{"position_mm": p, "reduction": 0.12} for p in (200.0, 250.0, 300.0)]},
           "held_out": rows, "trials": 3, **_STUDY}
    monkeypatch.setattr(optimize, "optimize_bands", lambda *a, **k: dict(out))
    assert main(["optimize", "--trials", "3"]) == 0
    text = capsys.readouterr().out
    assert "best - no bands: +0.81" in text and "paper 3 x 10% / 50 mm - no bands: +0.44" in text
    assert "paper 3 x 10% / 50 mm succeeds more often than no bands" in text
    assert main(["optimize", "--trials", "3", "--json"]) == 0
    diff = json.loads(capsys.readouterr().out)["differences"]
    assert [(d["design"], d["other"]) for d in diff] == [("best", "paper 3 x 10% / 50 mm"), ("best", "no bands"),
                                                         ("paper 3 x 10% / 50 mm", "no bands")]


# ---- 7. a clone named evertgym in the current folder ----------------------------------------------
def test_the_package_imports_from_the_folder_that_holds_a_clone_named_evertgym(tmp_path):
    clone = tmp_path / "evertgym"  # what Python sees of a clone: a folder without __init__.py
    clone.mkdir()
    (clone / "README.md").write_text("a clone of the repository\n")
    code = "import gymnasium as gym, evertgym; gym.make('evertgym/UBend-v0').close(); print(evertgym.__version__)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    import evertgym

    assert done.stdout.strip() == evertgym.__version__


def test_optimize_passes_the_tube_and_the_trial_time_to_the_search(monkeypatch, capsys, tmp_path):
    import evertgym.experiments.optimize as optimize

    seen: dict = {}
    rows = [{"design_name": name, "n": 2, "successes": 1, "success_rate": 0.5, "success_ci_lo": 0.0, "success_ci_hi": 1.0}
            for name in ("best", "paper 3 x 10% / 50 mm", "no bands")]
    out = {"best_params": {"n_bands": 1, "spacing_mm": 50.0, "reduction": 0.1, "last_band_mm": 300.0},
           "best_design": {"tube": {}, "bands": [{"position_mm": 300.0, "reduction": 0.1}]}, "held_out": rows, "trials": 1, **_STUDY}
    monkeypatch.setattr(optimize, "optimize_bands", lambda *a, **k: (seen.update(k), dict(out))[1])
    stores = ["--study", str(tmp_path / "s.sqlite"), "--db", str(tmp_path / "o.sqlite")]
    assert main(["optimize", "--scene", "colon_random", "--scene-params", "{}", "--diameter-mm", "20", "--length-mm", "800",
                 "--max-s", "30", *stores]) == 0
    assert (seen["diameter_mm"], seen["length_mm"], seen["max_s"]) == (20.0, 800.0, 30.0)
    assert main(["optimize", *stores]) == 0  # the defaults: the paper's U-bend robot, 20 s trials
    assert (seen["diameter_mm"], seen["length_mm"], seen["max_s"]) == (40.0, 900.0, 20.0)


@pytest.mark.parametrize("diameter_mm, length_mm", [(40.0, 900.0), (20.0, 800.0), (40.0, 1500.0)])
def test_every_design_the_search_draws_keeps_its_bands_on_the_body_under_the_jitter(diameter_mm, length_mm):
    """A band 23 mm from the base, which the +/- 25 mm jitter moved off the body, stopped a tortuous search."""
    from evertgym.env import EversionEnv
    from evertgym.experiments.optimize import BAND_JITTER_MM, MIN_BAND_MM, band_design

    for n, spacing, last in ((2, 100.0, 123.0), (6, 100.0, 150.0), (6, 20.0, 150.0), (6, 100.0, 500.0), (1, 20.0, 150.0)):
        design = band_design(n, spacing, 0.5, last, diameter_mm, length_mm)
        assert all(b["position_mm"] > MIN_BAND_MM for b in design["bands"])
        EversionEnv(scene={"family": "straight", "params": {}}, design=design, band_offset_mm=(-BAND_JITTER_MM, BAND_JITTER_MM))
    assert [b["position_mm"] for b in band_design(2, 100.0, 0.1, 123.0, 40.0, 900.0)["bands"]] == [123.0]
    # a short robot: bands the search places past its tip's reach are left out too
    short = band_design(3, 50.0, 0.1, 500.0, 40.0, 300.0)
    assert short["bands"] == []
    EversionEnv(scene={"family": "straight", "params": {}}, design=band_design(3, 50.0, 0.1, 250.0, 40.0, 300.0),
                band_offset_mm=(-BAND_JITTER_MM, BAND_JITTER_MM))
