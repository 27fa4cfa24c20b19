"""Write rl-zoo3's hyperparameter files (agents/ppo.yml, agents/sac.yml) from agents/*.toml.

    python scripts/write_zoo_yaml.py
"""

from __future__ import annotations

from pathlib import Path

from evertgym.agents.zoo import zoo_files

AGENTS = Path(__file__).resolve().parents[1] / "agents"

if __name__ == "__main__":
    for algo, text in zoo_files(sorted(AGENTS.glob("*.toml"))).items():
        out = AGENTS / f"{algo}.yml"
        out.write_text(text)
        print(f"wrote {out}")
