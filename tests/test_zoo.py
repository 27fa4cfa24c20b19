"""rl-zoo3: our hyperparameter files are generated from agents/*.toml and train."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from evertgym.agents.zoo import zoo_files, zoo_hyperparams

ROOT = Path(__file__).resolve().parents[1]
AGENTS = ROOT / "agents"


def test_zoo_files_are_up_to_date_with_the_toml_configs():
    pytest.importorskip("yaml")
    files = zoo_files(sorted(AGENTS.glob("*.toml")))
    assert set(files) == {"ppo", "sac"}
    for algo, text in files.items():
        assert (AGENTS / f"{algo}.yml").read_text() == text, f"run: python -m evertgym.agents.zoo ({algo}.yml is stale)"


def test_zoo_entry_carries_every_hyperparameter_and_env_kwarg():
    from evertgym.agents.train import load_config

    cfg = load_config(AGENTS / "colon_ppo_operator.toml")
    entry = zoo_hyperparams(cfg)
    assert entry["env_kwargs"] == {"tip_sensing": False, "regulator_tau_s": [0.1, 0.6]} and entry["normalize"] is True
    assert entry["n_timesteps"] == cfg["n_timesteps"] == 80000 and entry["n_envs"] == 2
    assert entry["n_steps"] == cfg["hyperparams"]["n_steps"] and entry["policy"] == "MlpPolicy"
    assert entry["policy_kwargs"] == {"net_arch": [64, 64]}


def test_two_configs_of_one_algo_for_one_env_are_rejected(tmp_path):
    for name in ("a", "b"):
        (tmp_path / f"{name}.toml").write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 10\n')
    with pytest.raises(ValueError, match="one per env"):
        zoo_files(sorted(tmp_path.glob("*.toml")))


def test_a_variant_marked_zoo_false_is_left_out(tmp_path):
    (tmp_path / "a.toml").write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 10\n')
    (tmp_path / "b.toml").write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 20\nzoo = false\n')
    assert "n_timesteps: 10" in zoo_files(sorted(tmp_path.glob("*.toml")))["ppo"]
    (tmp_path / "b.toml").write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 20\nzoo = "no"\n')
    with pytest.raises(ValueError, match="zoo = 'no': allowed true or false"):
        zoo_files(sorted(tmp_path.glob("*.toml")))


@pytest.mark.slow
def test_rl_zoo3_trains_with_our_hyperparameters(tmp_path):
    pytest.importorskip("rl_zoo3")
    import yaml

    # one PPO update: n_steps 512 x n_envs 2 = 1024 env steps, the smallest run with our hyperparameters
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "evertgym/UBend-v0", "--gym-packages", "evertgym",
           "-conf", str(AGENTS / "ppo.yml"), "-n", "1024", "--log-folder", str(tmp_path), "--seed", "0", "--eval-freq", "-1"]
    env = {**os.environ, "PYTHONPATH": str(AGENTS.parent)}  # this checkout's package, whatever is installed
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    run = tmp_path / "ppo" / "evertgym-UBend-v0_1"
    assert (run / "evertgym-UBend-v0.zip").is_file() and (run / "evertgym-UBend-v0" / "vecnormalize.pkl").is_file()
    used = dict(yaml.unsafe_load((run / "evertgym-UBend-v0" / "config.yml").read_text()))
    # the env kwargs of the zoo file's entry (agents/ubend_ppo_operator.toml's: no simulator setting, the default engine)
    entry = yaml.safe_load((AGENTS / "ppo.yml").read_text())["evertgym/UBend-v0"]
    assert entry["env_kwargs"] == {"tip_sensing": False, "regulator_tau_s": [0.1, 0.6]}
    assert used["n_steps"] == 512 and used["batch_size"] == 128 and used["env_kwargs"] == entry["env_kwargs"]
