"""Baselines, SB3 training with checkpoints and resume, evaluation side by side."""

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from evertgym.agents import ConstantPressure, OperatorProtocol, make_baseline, pressure_to_action
from evertgym.agents.evaluate import evaluate
from evertgym.agents.train import load_config
from evertgym.env import EversionEnv
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE


def test_pressure_action_mapping():
    assert pressure_to_action(0.0)[0] == pytest.approx(-1.0)
    assert pressure_to_action(4.0)[0] == pytest.approx(0.0)
    assert pressure_to_action(8.0)[0] == pytest.approx(1.0)


def test_operator_raises_pressure_when_progress_stalls():
    env = EversionEnv(scene={"family": "straight", "params": {}}, design={"tube": {"length_mm": 600.0}})
    env.reset(seed=0)
    op = OperatorProtocol(start_kpa=0.3, step_kpa=0.2, stall_s=0.5)  # below the eversion threshold
    op.reset(env)
    info = {"insertion_length_mm": 15.0}
    cmds = []
    for _ in range(30):
        a = op.act(None, info)
        cmds.append((a[0] + 1) * 4)
        _, _, _, _, info = env.step(a)
    assert cmds[0] == pytest.approx(0.3)
    assert max(cmds) > 0.45  # rose past the threshold...
    assert info["insertion_length_mm"] > 30.0  # ...and the robot grew
    assert max(cmds) < 1.5  # and stopped raising once it moved


def test_cycling_is_a_square_wave_of_the_control_clock():
    env = EversionEnv(scene={"family": "straight", "params": {}}, design={"tube": {"length_mm": 600.0}}, control_hz=10.0)
    env.reset(seed=0)
    cyc = make_baseline("cycle", low_kpa=1.0, high_kpa=6.0, period_s=1.0)
    cyc.reset(env)
    cmds = [round(float((cyc.act(None, {})[0] + 1) * 4), 6) for _ in range(20)]
    assert cmds == ([6.0] * 5 + [1.0] * 5) * 2
    with pytest.raises(ValueError, match="period_s"):
        make_baseline("cycle", period_s=0.0)
    with pytest.raises(ValueError, match="high_kpa"):
        make_baseline("cycle", high_kpa=12.0)


def _commands_kpa(policy, n: int, control_hz: float = 10.0, obs_info=None) -> list[float]:
    env = EversionEnv(scene={"family": "straight", "params": {}}, design={"tube": {"length_mm": 600.0}}, control_hz=control_hz)
    env.reset(seed=0)
    policy.reset(env)
    return [round(float((policy.act(None, {})[0] + 1) * 4), 6) for _ in range(n)]


def test_cycle_low_level_period_and_duty_are_parameters_in_python_and_policy_strings():
    from evertgym.agents.policies import make_policy, policy_desc

    # the 0 <-> 3 kPa, 1 s wave, spelled as the CLI spells it
    assert policy_desc("cycle:low_kpa=0,high_kpa=3,period_s=1") == {"name": "cycle", "low_kpa": 0.0, "high_kpa": 3.0, "period_s": 1.0}
    wave = _commands_kpa(make_policy("cycle:low_kpa=0,high_kpa=3,period_s=1"), 20)
    assert wave == ([3.0] * 5 + [0.0] * 5) * 2
    # duty: the fraction of each period at the high level
    assert _commands_kpa(make_baseline("cycle", low_kpa=0.0, high_kpa=3.0, period_s=1.0, duty=0.3), 10) == [3.0] * 3 + [0.0] * 7
    # the historical defaults still hold: 1 <-> 8 kPa, 2 s, half and half
    assert _commands_kpa(make_policy("cycle"), 20) == [8.0] * 10 + [1.0] * 10
    assert policy_desc("constant:pressure_kpa=3") == {"name": "constant", "pressure_kpa": 3.0}
    assert policy_desc("operator") == {"name": "operator"} == policy_desc("operator:")


@pytest.mark.parametrize(
    "desc, message",
    [
        ("cycle:duty=1.5", "duty = 1.5 is out of range: allowed (0, 1)"),
        ("cycle:duty=0", "duty = 0.0 is out of range"),
        ("cycle:low_kpa=-1", "low_kpa = -1.0 is out of range: allowed [0, 8] kPa"),
        ("cycle:period_s=0", "period_s = 0.0 is out of range"),
        ("cycle:low_kpa=zero", "low_kpa must be a number"),
        ("cycle:low_kpa=0,low_kpa=1", "low_kpa is given twice"),
        ("cycle:low_kpa=0,3", "'3' is not a parameter"),
        ("cycle:level_kpa=0", "level_kpa"),
    ],
)
def test_policy_strings_reject_bad_parameters_in_one_line(desc, message):
    from evertgym.agents.policies import make_policy

    with pytest.raises(ValueError, match=re.escape(message)) as e:
        make_policy(desc)
    assert "\n" not in str(e.value)


def test_eval_cli_takes_baselines_with_parameters(capsys):
    from evertgym.cli import main

    argv = ["eval", "cycle:low_kpa=0,high_kpa=3,period_s=1", "cycle", "--env", "evertgym/UBend-v0", "--episodes", "1", "--json"]
    assert main(argv) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [r["policy"] for r in rows] == ["cycle:low_kpa=0,high_kpa=3,period_s=1", "cycle"]
    # the 0 kPa low level deflates; the peak is the 3 kPa high level, not the default 8 kPa
    assert rows[0]["mean_peak_pressure_kpa"] <= 3.0 + 0.05
    assert main(["eval", "cycle:duty=2", "--env", "evertgym/UBend-v0", "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "duty = 2.0 is out of range" in err and "Traceback" not in err


def test_eval_validation_episodes_are_neither_held_out_nor_training(capsys):
    from evertgym.cli import main
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE
    from evertgym.limits import MAX_EPISODES

    assert VALIDATION_SEED_BASE >= HELD_OUT_SEED_BASE + MAX_EPISODES and VALIDATION_SEED_BASE + MAX_EPISODES < 2**31
    argv = ["eval", "constant", "--env", "evertgym/UBend-v0", "--episodes", "1", "--json"]
    assert main(argv) == 0
    held_out = json.loads(capsys.readouterr().out)
    assert main([*argv, "--validation"]) == 0
    validation = json.loads(capsys.readouterr().out)
    assert (held_out["seed_base"], validation["seed_base"]) == (HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE)
    # another scene: the constant 3 kPa run ends elsewhere
    assert held_out["rows"][0] != validation["rows"][0]
    assert main(argv[:-1] + ["--validation"]) == 0
    assert "validation episodes: episode and scene seeds 2000000000-2000000000" in capsys.readouterr().out


def _stub_env(control_dt: float = 0.1):
    from types import SimpleNamespace

    return SimpleNamespace(unwrapped=SimpleNamespace(control_dt=control_dt))


def test_deflate_on_stall_deflates_after_a_stall_then_resumes():
    """On a stub insertion trace (10 Hz): growth, a stall, growth again.  The rule holds
    3 kPa, answers the stall with 0 kPa for 0.5 s (5 steps), then inflates again and holds."""
    from evertgym.agents.policies import make_policy

    policy = make_policy("deflate:high_kpa=3,low_kpa=0,deflate_s=0.5")
    policy.reset(_stub_env())
    lengths = [15.0 + 5.0 * k for k in range(20)]  # 50 mm/s for 2 s
    lengths += [lengths[-1] + 0.1 * k for k in range(1, 31)]  # stalled (1 mm/s) for 3 s
    lengths += [lengths[-1] + 5.0 * k for k in range(1, 21)]  # growing again
    cmds = [round(float((policy.act(None, {"insertion_length_mm": x})[0] + 1) * 4), 6) for x in lengths]
    first_low = cmds.index(0.0)
    # the last growing sample is step 19: the stall is seen once the window (1 s) holds < 2 mm
    assert 19 + 10 <= first_low <= 19 + 11
    assert cmds[:first_low] == [3.0] * first_low  # growing, then the first second of the stall: inflated
    assert cmds[first_low:first_low + 5] == [0.0] * 5  # deflated for 0.5 s
    assert cmds[first_low + 5] == 3.0  # then inflated again
    assert set(cmds[50:]) == {3.0}  # growing again: no more deflation
    assert 1 <= policy.deflations <= 2  # the stall lasted 3 s: at most one repeat after a full window at 3 kPa
    assert policy.max_command_kpa == 3.0
    # no stall, no deflation
    policy.reset(_stub_env())
    assert {round(float((policy.act(None, {"insertion_length_mm": 15.0 + 5.0 * k})[0] + 1) * 4), 6) for k in range(40)} == {3.0}
    assert policy.deflations == 0


def test_deflate_defaults_and_bad_parameters():
    from evertgym.agents import DeflateOnStall
    from evertgym.agents.policies import make_policy

    d = make_policy("deflate")
    assert isinstance(d, DeflateOnStall) and (d.high_kpa, d.low_kpa, d.deflate_s) == (3.0, 0.0, 0.5)
    for desc, message in [("deflate:deflate_s=0", "deflate_s = 0.0 is out of range"), ("deflate:high_kpa=9", "high_kpa = 9.0"),
                          ("deflate:stall_mm=-1", "stall_mm = -1.0"), ("deflate:tip_force=1", "tip_force")]:
        with pytest.raises(ValueError, match=re.escape(message)):
            make_policy(desc)


def test_deflate_on_stall_deflates_in_a_colon_episode():
    """A held-out Colon-v0 episode (the third) in which the robot stalls: the rule deflates at
    least once, only to 0 kPa, and never commands more than 3 kPa.  (The first held-out episode
    served until the engine's wall fix of 2026-12-04: its robot had passed through a wall and
    stood still, and the rule deflated 17 times; it now passes without a stall.)"""
    import gymnasium as gym

    from evertgym.agents.evaluate import run_episode
    from evertgym.agents.policies import make_policy
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    env = gym.make("evertgym/Colon-v0")
    policy = make_policy("deflate")
    seen: list[float] = []

    def record(env, info) -> bool:
        seen.append(round(env.unwrapped.command_pa / 1e3, 6))
        return False

    seed = HELD_OUT_SEED_BASE + 2
    info = run_episode(env, policy, seed, options={"scene_seed": seed}, stop=record)
    assert set(seen) == {0.0, 3.0} and policy.deflations >= 1
    assert info["peak_pressure_kpa"] <= 3.0 + 0.05
    assert info["outcome"] in ("success", "time out")


@pytest.mark.parametrize("kwargs, field", [(dict(pressure_kpa=9.0), "pressure_kpa"), (dict(pressure_kpa=float("nan")), "pressure_kpa")])
def test_baselines_reject_bad_parameters(kwargs, field):
    with pytest.raises(ValueError, match=field):
        ConstantPressure(**kwargs)
    with pytest.raises(ValueError, match="unknown baseline"):
        make_baseline("teleport")


def test_tuned_parameters_are_per_env_and_the_ubend_file_keeps_its_name(tmp_path, monkeypatch):
    from evertgym.agents import tuned
    from evertgym.agents.policies import for_env, make_policy

    assert tuned.tuned_path("evertgym/UBend-v0").name == "tuned_operator.json"
    assert tuned.tuned_path("evertgym/Colon-v0").name == "tuned_operator_Colon-v0.json"
    legacy = tuned.load_tuned()  # the default before per-env files: tuned on UBend-v0
    ubend = make_policy(for_env("tuned", "evertgym/UBend-v0"))
    assert legacy.name == ubend.name == "tuned" and (legacy.start_kpa, legacy.step_kpa) == (ubend.start_kpa, ubend.step_kpa)
    assert ubend.tuned_on == "evertgym/UBend-v0"
    # evaluated on an env, "tuned" means tuned on that env; an explicit path or env_id stays
    assert for_env("tuned", "evertgym/Colon-v0") == {"name": "tuned", "env_id": "evertgym/Colon-v0"}
    assert for_env({"name": "tuned", "path": "x.json"}, "evertgym/Colon-v0") == {"name": "tuned", "path": "x.json"}
    assert for_env("operator", "evertgym/Colon-v0") == {"name": "operator"}
    with pytest.raises(ValueError, match="tuned on env 'evertgym/UBend-v0', not env_id = 'evertgym/Colon-v0'"):
        tuned.load_tuned(path=tuned.TUNED_PATH, env_id="evertgym/Colon-v0")
    monkeypatch.setattr(tuned, "shipped_dir", lambda: tmp_path)  # no tuned files at all
    with pytest.raises(ValueError, match=r"no tuned operator parameters.*evertgym tune --env evertgym/Colon-v0"):
        evaluate(["operator", "tuned"], "evertgym/Colon-v0", 1)  # refused before any episode


def test_tuning_uses_training_scenes_only_and_resumes_from_its_log(tmp_path):
    from evertgym.agents.train import held_out_seeds
    from evertgym.agents.tuned import load_tuned, tune_operator
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    grid = {"start_kpa": [1.0, 3.0], "step_kpa": [1.0], "stall_s": [1.0], "relax_kpa_per_s": [0.0]}
    log, seen = tmp_path / "t.jsonl", []
    out = tune_operator("evertgym/UBend-v0", 2, log=log, grid=grid, on_result=seen.append)
    assert len(seen) == 2 and out["env"] == "evertgym/UBend-v0" and out["best"] in seen
    assert out["best"]["success_rate"] == max(r["success_rate"] for r in seen)
    scenes = out["training_scene_seeds"]
    assert len(scenes) == 2 and all(0 <= s < HELD_OUT_SEED_BASE for s in scenes)
    assert not set(scenes) & set(held_out_seeds(1000).tolist())
    again: list[dict] = []
    assert tune_operator("evertgym/UBend-v0", 2, log=log, grid=grid, on_result=again.append) == out
    assert again == []  # every point came from the log
    f = tmp_path / "tuned.json"
    f.write_text(json.dumps(out))
    assert load_tuned(path=f, env_id="evertgym/UBend-v0").start_kpa == out["best"]["params"]["start_kpa"]
    with pytest.raises(ValueError, match="episodes = 0"):
        tune_operator("evertgym/UBend-v0", 0)


def test_config_validation(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('env_id = "evertgym/UBend-v0"\nalgo = "dqn"\nn_timesteps = 10\n')
    with pytest.raises(ValueError, match="algo = 'dqn'"):
        load_config(p)
    assert load_config("agents/colon_ppo_operator.toml")["algo"] == "ppo"
    p.write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 10\ndeterministic = "no"\n')
    with pytest.raises(ValueError, match="deterministic = 'no': allowed true or false"):
        load_config(p)
    assert load_config("agents/colon_ppo_operator.toml")["deterministic"] is False


def test_seed_override_names_its_own_run():
    cfg = load_config("agents/colon_ppo_operator.toml", seed=2)
    assert (cfg["seed"], cfg["name"]) == (2, "colon_ppo_operator_seed2")
    assert load_config("agents/colon_ppo_operator.toml")["name"] == "colon_ppo_operator"
    # no shipped config pins a simulator setting: it trains on the default physics
    assert load_config("agents/colon_ppo_operator.toml")["env_kwargs"] == {"tip_sensing": False, "regulator_tau_s": [0.1, 0.6]}
    with pytest.raises(ValueError, match=r"seed = True is out of range"):
        load_config("agents/colon_ppo_operator.toml", seed=True)


def test_eval_rows_side_by_side():
    rows = evaluate(["operator", {"name": "constant", "pressure_kpa": 3.0}], "evertgym/UBend-v0", 2)
    assert [r["policy"] for r in rows] == ["operator", "constant"]
    for r in rows:
        assert r["successes"] == round(r["success_rate"] * r["episodes"])
        assert set(r) >= {"policy", "episodes", "successes", "success_rate", "ci_low", "ci_high", "mean_peak_pressure_kpa",
                          "mean_max_contact_force_n",
                          "mean_peak_pressure_bend_kpa", "bend_reached_episodes", "peak_before_bend_episodes"}
        assert 0.0 <= r["ci_low"] <= r["success_rate"] <= r["ci_high"] <= 1.0


def test_eval_over_worker_processes_gives_the_same_rows():
    """Every episode is seeded, so spreading 3 episodes over 2 processes changes nothing."""
    pols = ["operator", {"name": "constant", "pressure_kpa": 2.0}]
    serial = evaluate(pols, "evertgym/UBend-v0", 3)
    pooled = evaluate(pols, "evertgym/UBend-v0", 3, workers=2)
    assert json.dumps(pooled) == json.dumps(serial)  # NaN time to goal when nothing succeeds
    with pytest.raises(ValueError, match="workers"):
        evaluate(pols, "evertgym/UBend-v0", 3, workers=0)


def test_eval_with_a_store_resumes_and_keeps_engines_apart(tmp_path, monkeypatch):
    """With ``db`` every finished episode is stored: a rerun plays none again and gives the same
    rows, a longer run plays only the new episodes, and the other engine is a different episode."""
    import evertgym.agents.evaluate as ev

    db = tmp_path / "eval.sqlite"
    kw = {"max_episode_s": 1.0}
    first = evaluate(["operator"], "evertgym/UBend-v0", 2, env_kwargs=kw, db=db)
    plain = evaluate(["operator"], "evertgym/UBend-v0", 2, env_kwargs=kw)
    assert json.dumps(first) == json.dumps(plain)
    played: list[int] = []
    real = ev.episode_trial
    monkeypatch.setattr(ev, "episode_trial", lambda spec: played.append(spec.seed) or real(spec))
    assert json.dumps(evaluate(["operator"], "evertgym/UBend-v0", 2, env_kwargs=kw, db=db)) == json.dumps(first)
    assert played == []
    evaluate(["operator"], "evertgym/UBend-v0", 2, env_kwargs=kw, db=db, trust=True)  # (trust reaches model files only)
    assert played == []
    evaluate(["operator"], "evertgym/UBend-v0", 3, env_kwargs=kw, db=db)
    assert played == [HELD_OUT_SEED_BASE + 2]
    played.clear()
    evaluate(["operator"], "evertgym/UBend-v0", 1, env_kwargs={**kw, "sim_config": {"engine": "dynamic"}}, db=db)
    assert played == [HELD_OUT_SEED_BASE]


def test_eval_store_identity_names_the_engine_and_a_model_file():
    from evertgym.agents.evaluate import _identities
    from evertgym.agents.policies import for_env, resolve_policy_path
    from evertgym.agents.trust import sha256_of

    pols = ["operator", "colon_ppo_operator"]
    descs = [for_env(p, "evertgym/Colon-v0") for p in pols]
    ident = _identities(descs, None)
    assert ident[0] == {"engine": "quasistatic"}
    assert ident[1] == {"engine": "quasistatic", "model_sha256": sha256_of(resolve_policy_path("colon_ppo_operator"))}
    assert _identities(descs, {"sim_config": {"engine": "dynamic"}})[0] == {"engine": "dynamic"}
    from evertgym.env.eversion_env import engine_of
    from evertgym.sim import SimConfig

    assert engine_of({"sim_config": SimConfig(engine="dynamic")}) == "dynamic"  # an env takes a SimConfig too


def test_a_retuned_operator_is_played_again_not_read_back_from_the_store(tmp_path, monkeypatch):
    import evertgym.agents.evaluate as ev
    from evertgym.agents.tuned import tuned_path

    shipped = json.loads(tuned_path("evertgym/UBend-v0").read_text())
    tuned = tmp_path / "tuned.json"
    tuned.write_text(json.dumps(shipped))
    db, kw, desc = tmp_path / "eval.sqlite", {"max_episode_s": 1.0}, {"name": "tuned", "path": str(tuned)}
    evaluate([desc], "evertgym/UBend-v0", 1, env_kwargs=kw, db=db)
    played: list[int] = []
    real = ev.episode_trial
    monkeypatch.setattr(ev, "episode_trial", lambda spec: played.append(spec.seed) or real(spec))
    evaluate([desc], "evertgym/UBend-v0", 1, env_kwargs=kw, db=db)
    assert played == []  # the same parameters: read back
    shipped["best"]["params"]["start_kpa"] += 1.0
    tuned.write_text(json.dumps(shipped))
    evaluate([desc], "evertgym/UBend-v0", 1, env_kwargs=kw, db=db)
    assert played == [HELD_OUT_SEED_BASE]  # other parameters under the same name: played again


def _tiny_config(tmp_path: Path, n_timesteps: int = 512, name: str = "tiny_ppo") -> Path:
    cfg = tmp_path / f"{name}.toml"
    # 1 s episodes (10 steps): dozens of resets, so each side of a stop draws many scenes
    cfg.write_text(
        f'env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nseed = 1\nn_envs = 1\nn_timesteps = {n_timesteps}\nnormalize = true\n'
        "checkpoint_freq = 128\neval_episodes = 0\n[env_kwargs]\nmax_episode_s = 1.0\n"
        "[hyperparams]\nn_steps = 64\nbatch_size = 32\nn_epochs = 1\n"
    )
    return cfg


# runs the CLI with every env reset appending its scene seed to a file (flushed per line,
# so a kill keeps what was drawn before it)
_SCENE_LOGGER = """
import sys
from evertgym.env.eversion_env import EversionEnv
_reset = EversionEnv.reset
def reset(self, *, seed=None, options=None):
    out = _reset(self, seed=seed, options=options)
    with open(sys.argv[1], "a") as fh:
        fh.write(f"{self.scene.spec.seed}\\n")
    return out
EversionEnv.reset = reset
from evertgym.cli import main
sys.exit(main(sys.argv[2:]))
"""


def test_training_killed_after_a_checkpoint_resumes_and_counts_on(tmp_path):
    cfg = _tiny_config(tmp_path)
    out = tmp_path / "runs"
    ckpt = out / "tiny_ppo" / "checkpoints"
    driver = tmp_path / "drive.py"
    driver.write_text(_SCENE_LOGGER)
    before, after = tmp_path / "scenes_before_kill.txt", tmp_path / "scenes_after_resume.txt"
    cmd = ["train", str(cfg), "--out", str(out), "--no-progress"]
    proc = subprocess.Popen([sys.executable, str(driver), str(before)] + cmd)
    deadline = time.time() + 240
    while time.time() < deadline and not list(ckpt.glob("model_vecnormalize_*_steps.pkl")):
        time.sleep(0.2)  # the statistics are saved after the model: a checkpoint is complete
    proc.kill()
    proc.wait()
    saved = sorted(int(p.name.split("_")[1]) for p in ckpt.glob("model_*_steps.zip"))
    assert saved, "no checkpoint was written before the kill"
    assert not (out / "tiny_ppo" / "final.zip").exists()
    done = subprocess.run([sys.executable, str(driver), str(after)] + cmd + ["--resume"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "tiny_ppo" / "eval.json").read_text())
    assert summary["num_timesteps"] >= 512
    from stable_baselines3 import PPO

    model = PPO.load(str(out / "tiny_ppo" / "final.zip"), device="cpu")
    assert model.num_timesteps == summary["num_timesteps"]
    # the counter continued from the checkpoint: it never restarted below it
    assert model.num_timesteps >= max(saved)
    assert list((out / "tiny_ppo" / "tb").rglob("events.out.tfevents*"))  # TensorBoard logs
    meta = json.loads((out / "tiny_ppo" / "final_env.json").read_text())
    assert meta["env_id"] == "evertgym/UBend-v0" and meta["deterministic"] is True  # the config's default
    # the resumed run played fresh episodes: none of the scenes drawn before the kill again
    drawn_before = before.read_text().split()
    drawn_after = after.read_text().split()
    assert len(drawn_before) >= 10 and len(drawn_after) >= 20
    assert not set(drawn_before) & set(drawn_after)
    resumed = json.loads((out / "tiny_ppo" / "config.json").read_text())["resume"]
    assert resumed["num_timesteps"] in saved and resumed["env_seed"] != 1


def test_a_run_from_its_config_is_repeatable_and_a_resumed_run_draws_fresh_scenes(tmp_path, monkeypatch):
    """Two runs from the config alone draw the same scenes and end with the same weights; a
    run stopped at 128 steps and resumed to 256 draws none of its first 128 steps' scenes."""
    import torch
    from stable_baselines3 import PPO

    from evertgym.agents.train import resume_seed, train

    drawn: list[int] = []
    reset = EversionEnv.reset

    def logging_reset(self, *, seed=None, options=None):
        out = reset(self, seed=seed, options=options)
        drawn.append(int(self.scene.spec.seed))
        return out

    monkeypatch.setattr(EversionEnv, "reset", logging_reset)
    runs = {}
    for name in ("a", "b"):
        cfg = _tiny_config(tmp_path, n_timesteps=128, name="tiny")
        train(cfg, out_dir=tmp_path / name, progress=False)
        runs[name] = (list(drawn), PPO.load(str(tmp_path / name / "tiny" / "final.zip"), device="cpu"))
        drawn.clear()
    (seeds_a, model_a), (seeds_b, model_b) = runs["a"], runs["b"]
    assert len(seeds_a) >= 10 and seeds_a == seeds_b
    for (k, va), vb in zip(model_a.policy.state_dict().items(), model_b.policy.state_dict().values()):
        assert torch.equal(va, vb), k
    # stop (the run ended at 128 steps), raise the budget, resume
    cfg = _tiny_config(tmp_path, n_timesteps=256, name="tiny")
    train(cfg, out_dir=tmp_path / "a", resume=True, progress=False)
    assert len(drawn) >= 10 and not set(drawn) & set(seeds_a)
    assert json.loads((tmp_path / "a" / "tiny" / "config.json").read_text())["resume"] == {
        "num_timesteps": 128, "env_seed": resume_seed(1, 128)}
    assert resume_seed(1, 0) == 1 and len({resume_seed(1, n) for n in (1, 64, 128, 256)} | {1}) == 5


def test_a_stochastic_policy_is_repeatable_per_episode_seed():
    """``model.zip:stochastic`` draws actions from the PPO Gaussian with a generator seeded by
    the episode seed: the same seed gives the same actions, another seed others, and the
    mean (deterministic) actions differ from both."""
    import gymnasium as gym

    from evertgym.agents.policies import make_policy

    def actions(desc: str, seed: int) -> np.ndarray:
        policy = make_policy(desc)
        env = gym.make("evertgym/UBend-v0", **policy.env_kwargs)
        obs, info = env.reset(seed=seed, options={"scene_seed": seed})
        policy.reset(env)
        out = []
        for _ in range(20):
            a = policy.act(obs, info)
            out.append(float(a[0]))
            obs, _, term, trunc, info = env.step(a)
        return np.array(out)

    shipped = "agents/ubend_ppo_operator/final.zip"
    a1, a2 = actions(shipped + ":stochastic", 7), actions(shipped + ":stochastic", 7)
    assert np.array_equal(a1, a2) and np.all(np.abs(a1) <= 1.0)
    assert not np.array_equal(a1, actions(shipped + ":stochastic", 8))
    assert not np.allclose(a1, actions(shipped + ":deterministic", 7))
    with pytest.raises(ValueError, match="deterministic' or 'stochastic"):
        make_policy(shipped + ":greedy")


def test_rollout_writes_a_gif_and_the_command_trace(tmp_path):
    from PIL import Image

    from evertgym.agents.rollout import rollout_gif

    out = rollout_gif({"name": "constant", "pressure_kpa": 8.0}, "evertgym/UBend-v0", tmp_path / "r.gif", seed=3, every=10)
    assert out["command_kpa"] and set(out["command_kpa"]) == {8.0}
    with Image.open(out["out"]) as gif:
        assert gif.n_frames == out["frames"] >= 2
    with pytest.raises(ValueError, match=".gif"):
        rollout_gif("operator", "evertgym/UBend-v0", tmp_path / "r.mp4")


def test_rollout_plays_the_held_out_episode_eval_plays(tmp_path):
    """``rollout --seed k`` is held-out episode k of ``eval`` (scene seed 1e9 + k), never a
    training scene; ``env_kwargs`` reach it."""
    from evertgym.agents.evaluate import episode_trial
    from evertgym.agents.rollout import rollout_gif
    from evertgym.scoring.spec import TrialSpec

    kw = {"regulator_tau_s": [0.1, 0.6]}
    out = rollout_gif("operator", "evertgym/UBend-v0", tmp_path / "r.gif", seed=1, every=50, env_kwargs=kw)
    assert out["episode_seed"] == 1_000_000_001
    spec = TrialSpec(design={}, design_name="u", scene={"family": "evertgym/UBend-v0", "params": kw, "seed": 1_000_000_001},
                     policy={"name": "operator"}, seed=1_000_000_001, index=0, group="o")
    info = episode_trial(spec)
    assert out["success"] == info["success"] and out["time_s"] == round(info["time_s"], 2)
    assert out["peak_pressure_kpa"] == round(info["peak_pressure_kpa"], 3)


def test_baselines_prints_every_policy_on_the_same_held_out_episodes(tmp_path):
    cmd = [sys.executable, "-m", "evertgym.cli", "baselines", "--envs", "evertgym/UBend-v0", "--episodes", "2",
           "--db", str(tmp_path / "b.sqlite"), "--policies", "constant:pressure_kpa=3;tuned;deflate"]
    out = subprocess.run(cmd + ["--json"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["evertgym/UBend-v0"]
    assert [r["policy"] for r in rows] == ["constant:pressure_kpa=3", "tuned", "deflate"]
    assert all(r["episodes"] == 2 and 0.0 <= r["ci_low"] <= r["success_rate"] <= r["ci_high"] <= 1.0 for r in rows)
    text = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert text.returncode == 0 and "scene seeds 1000000000-1000000001" in text.stdout
    assert "tuned: operator tuned on evertgym/UBend-v0 training scenes" in text.stdout
    bad = subprocess.run(cmd[:-1] + ["cycle:duty=3"], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "duty = 3.0 is out of range" in bad.stderr and "Traceback" not in bad.stderr


def test_baselines_loads_a_run_model_only_when_trusted(tmp_path):
    """A run's own model (not a shipped policy) sits in the baseline table with ``--trust-model``;
    without it the script refuses in one line that names the flag (model files are code)."""
    import shutil
    import zipfile

    root = Path(__file__).resolve().parents[1]
    run = tmp_path / "run"
    shutil.copytree(root / "agents" / "ubend_ppo_operator", run)
    with zipfile.ZipFile(run / "final.zip", "a") as z:  # other bytes than the shipped file: not in the manifest
        z.comment = b"a run of ours"
    cmd = [sys.executable, "-m", "evertgym.cli", "baselines", "--envs", "evertgym/UBend-v0", "--episodes", "1",
           "--db", str(tmp_path / "b.sqlite"), "--policies", f"constant:pressure_kpa=3;{run / 'final.zip'}", "--json"]
    refused = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "--trust-model" in refused.stderr and "Traceback" not in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
    out = subprocess.run(cmd + ["--trust-model"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["evertgym/UBend-v0"]
    assert [r["policy"] for r in rows] == ["constant:pressure_kpa=3", str(run / "final.zip")]
    assert rows[1]["episodes"] == 1


def test_eval_under_a_randomised_regulator_lag_draws_it_per_episode():
    """``env_kwargs`` reach every episode's env: the lag is drawn in [0.1, 0.6] s per episode,
    and the rows carry the bend columns (a held 3 kPa peaks at 3 kPa in the bend)."""
    from evertgym.agents.evaluate import episode_trial
    from evertgym.scoring.spec import TrialSpec

    kw = {"regulator_tau_s": [0.1, 0.6]}
    taus = []
    for seed in (1_000_000_000, 1_000_000_001):
        spec = TrialSpec(design={}, design_name="u", scene={"family": "evertgym/UBend-v0", "params": kw, "seed": seed},
                         policy={"name": "constant", "pressure_kpa": 3.0}, seed=seed, index=0, group="c")
        info = episode_trial(spec)
        taus.append(info["regulator_tau_s"])
    assert all(0.1 <= t <= 0.6 for t in taus) and taus[0] != taus[1]
    (row,) = evaluate([{"name": "constant", "pressure_kpa": 3.0}], "evertgym/UBend-v0", 1, env_kwargs=kw)
    assert row["bend_reached_episodes"] == 1 and row["mean_peak_pressure_bend_kpa"] == pytest.approx(3.0, abs=0.02)


def test_baselines_rejects_bad_env_kwargs_in_one_line():
    cmd = [sys.executable, "-m", "evertgym.cli", "baselines", "--envs", "evertgym/UBend-v0", "--episodes", "1",
           "--env-kwargs", '{"regulator_tau_s": [0.1, 99]}']
    bad = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "regulator_tau_s = 99 is out of range" in bad.stderr and "Traceback" not in bad.stderr


def test_a_policy_carries_its_observation_flags_not_its_training_physics():
    """The shipped operator-only policy was trained under a randomised regulator lag: in an
    evaluation it keeps its observation (no tip sensing) but meets the evaluation's physics,
    the same as every baseline beside it."""
    import json as _json

    from evertgym.agents.evaluate import _policy_and_env
    from evertgym.agents.policies import make_policy

    policy = make_policy("colon_ppo_operator")
    assert policy.env_kwargs["regulator_tau_s"] == [0.1, 0.6] and policy.deterministic is False
    assert policy.observation_kwargs == {"tip_sensing": False}
    _, env = _policy_and_env(_json.dumps({"name": "colon_ppo_operator"}), "evertgym/Colon-v0", "{}")
    assert env.unwrapped.regulator_tau_range is None and env.unwrapped.tip_sensing is False
    _, env = _policy_and_env(_json.dumps({"name": "colon_ppo_operator"}), "evertgym/Colon-v0",
                             _json.dumps({"regulator_tau_s": [0.1, 0.6]}))
    assert env.unwrapped.regulator_tau_range == (0.1, 0.6)


@pytest.mark.parametrize("path", sorted(Path(__file__).resolve().parents[1].glob("agents/**/*.toml")),
                         ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_config_loads_and_builds_its_env(path):
    """The configs the docs' commands train (shipped and tries) are valid and their env kwargs build an env:
    a try whose command is quoted in docs/agents.md must not rot when the env's arguments change."""
    import gymnasium as gym

    cfg = load_config(path)
    env = gym.make(cfg["env_id"], **cfg["env_kwargs"])
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    env.close()


def test_the_baselines_table_counts_seeds_from_the_held_out_base():
    from evertgym.agents.baseline_table import HELD_OUT_SEED_BASE as table_base
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    assert table_base == HELD_OUT_SEED_BASE
