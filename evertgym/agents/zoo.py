"""rl-zoo3 hyperparameter files from our training configs (one source of truth).

The TOML configs in ``agents/`` (``evertgym train agents/ubend_ppo_operator.toml``) are the source;
``agents/ppo.yml`` and ``agents/sac.yml`` are rl-zoo3's format of the same
hyperparameters, keyed by env id, written by ``python -m evertgym.agents.zoo`` (a test
checks they are up to date).  Train with rl-zoo3::

    python -m rl_zoo3.train --algo ppo --env evertgym/UBend-v0 --gym-packages evertgym -conf agents/ppo.yml

What rl-zoo3 takes on its command line instead (``seed``, ``checkpoint_freq``,
``eval_episodes``) stays in the TOML only.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evertgym.agents.train import load_config

#: Header of every generated file.
HEADER = "# Generated from agents/*.toml by `python -m evertgym.agents.zoo`; edit the TOML, not this file.\n"


def zoo_hyperparams(cfg: dict) -> dict[str, Any]:
    """One env's entry of an rl-zoo3 hyperparameter file, from a training config (``load_config``)."""
    hp = dict(cfg.get("hyperparams", {}))
    out: dict[str, Any] = {
        "n_envs": int(cfg.get("n_envs", 1)),
        "n_timesteps": int(cfg["n_timesteps"]),
        "policy": hp.pop("policy", "MlpPolicy"),
        "normalize": bool(cfg.get("normalize", False)),
    }
    if cfg.get("env_kwargs"):
        out["env_kwargs"] = dict(cfg["env_kwargs"])
    out.update(hp)
    return out


def zoo_files(config_paths: list[str | Path]) -> dict[str, str]:
    """``{algo: YAML text}``: every config's entry under its env id, one file per algorithm.
    A config with ``zoo = false`` (a variant beside an env's main config) is left out."""
    import yaml

    by_algo: dict[str, dict[str, dict]] = {}
    for path in sorted(map(Path, config_paths)):
        cfg = load_config(path)
        if not cfg.get("zoo", True):
            continue
        entries = by_algo.setdefault(cfg["algo"], {})
        if cfg["env_id"] in entries:
            raise ValueError(f"{path}: a second {cfg['algo']} config for {cfg['env_id']}; rl-zoo3 takes one per env")
        entries[cfg["env_id"]] = zoo_hyperparams(cfg)
    return {algo: HEADER + yaml.safe_dump(entries, sort_keys=False) for algo, entries in by_algo.items()}


def main() -> None:
    """Rewrite the shipped ``ppo.yml`` and ``sac.yml`` from the shipped configs (``python -m evertgym.agents.zoo``)."""
    from evertgym.agents.tuned import shipped_dir

    folder = shipped_dir()
    for algo, text in zoo_files(sorted(folder.glob("*.toml"))).items():
        out = folder / f"{algo}.yml"
        out.write_text(text, encoding="utf-8")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
