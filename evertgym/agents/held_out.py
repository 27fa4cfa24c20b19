"""Write ``agents/held_out.json``: each shipped policy's held-out success, from the evaluations in docs/results/.

    python -m evertgym.agents.held_out           # (re)write agents/held_out.json (in a checkout)
    python -m evertgym.agents.held_out --check   # exit 1 if the file differs from docs/results/

``evertgym policies`` prints these numbers (the index ships with the policies; docs/ does
not).  Every number comes from one of the ``evertgym eval ... --json`` outputs kept in
``docs/results/*_eval.json`` (docs/agents.md gives each command): the row of the shipped policy,
``agents/<name>/final.zip`` or ``<name>``, with the file's evaluation env kwargs
(``{}`` for the files that predate the key: the env's defaults).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the checkout: docs/results/ is not installed
OUT = ROOT / "agents" / "held_out.json"


def build() -> dict:
    """``{"source": ..., "policies": {name: {env_id, env_kwargs, engine, episodes, successes, ci_low, ci_high, source}}}``."""
    names = sorted(p.parent.name for p in (ROOT / "agents").glob("*/final.zip"))
    out: dict[str, dict] = {}
    for f in sorted((ROOT / "docs" / "results").glob("*_eval.json")):
        data = json.loads(f.read_text(encoding="utf-8"))
        for row in data["rows"]:
            for name in names:
                if row["policy"] in (name, f"agents/{name}/final.zip") and name not in out:
                    env_id = data.get("env_id") or json.loads((ROOT / "agents" / name / "final_env.json").read_text())["env_id"]
                    # the engine the episodes ran on; files without the key predate 0.3.0, whose default was the dynamic engine
                    out[name] = {"env_id": env_id, "env_kwargs": data.get("env_kwargs", {}), "engine": data.get("engine", "dynamic"),
                                 "episodes": row["episodes"],
                                 "successes": round(row["success_rate"] * row["episodes"]), "ci_low": round(row["ci_low"], 4),
                                 "ci_high": round(row["ci_high"], 4), "source": f"docs/results/{f.name}"}
    missing = sorted(set(names) - set(out))
    if missing:
        sys.exit(f"no held-out evaluation in docs/results/*_eval.json for {missing}")
    return {"source": "python -m evertgym.agents.held_out (from docs/results/*_eval.json)", "policies": out}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="compare agents/held_out.json with docs/ instead of writing it")
    args = ap.parse_args()
    text = json.dumps(build(), indent=2) + "\n"
    if args.check:
        if not OUT.is_file() or OUT.read_text(encoding="utf-8") != text:
            print(f"{OUT.relative_to(ROOT)} differs from docs/results/*_eval.json: run python -m evertgym.agents.held_out", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(text, encoding="utf-8")
    print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
