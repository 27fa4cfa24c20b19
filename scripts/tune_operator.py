#!/usr/bin/env python
"""Search the operator protocol's parameters: the tuned heuristic baseline.

    python scripts/tune_operator.py [--env evertgym/Colon-v0] [--episodes 10] [--out agents/tuned_operator.json]

Every combination of start pressure, step, stall window and relaxation is run on the same
training scenes (seeds 0..episodes-1, never the held-out evaluation seeds); the best has
the highest success rate, then the lowest mean peak pressure.  Each result is appended to
``<out>.jsonl`` as it is produced, so a killed search resumes where it stopped.
"""

import argparse
import itertools
import json
from pathlib import Path

import gymnasium as gym

import evertgym  # noqa: F401
from evertgym.agents.baselines import OperatorProtocol
from evertgym.agents.evaluate import run_episode

GRID = {"start_kpa": [1.0, 2.0, 3.0], "step_kpa": [0.25, 0.5, 1.0], "stall_s": [0.5, 1.0], "relax_kpa_per_s": [0.0, 0.5]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="evertgym/Colon-v0")
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--out", default="agents/tuned_operator.json")
    args = ap.parse_args()
    out = Path(args.out)
    log = out.with_suffix(".jsonl")
    done = {}
    if log.exists():
        for line in log.read_text().splitlines():
            rec = json.loads(line)
            if rec["env"] == args.env and rec["episodes"] == args.episodes:
                done[json.dumps(rec["params"], sort_keys=True)] = rec
    env = gym.make(args.env)
    keys = list(GRID)
    for values in itertools.product(*GRID.values()):
        params = dict(zip(keys, values))
        key = json.dumps(params, sort_keys=True)
        if key in done:
            continue
        infos = [run_episode(env, OperatorProtocol(**params), seed) for seed in range(args.episodes)]
        rec = {
            "env": args.env,
            "episodes": args.episodes,
            "params": params,
            "success_rate": sum(i["success"] for i in infos) / len(infos),
            "mean_peak_pressure_kpa": sum(i["peak_pressure_kpa"] for i in infos) / len(infos),
        }
        with open(log, "a") as f:
            f.write(json.dumps(rec) + "\n")
        done[key] = rec
        print(json.dumps(rec), flush=True)
    best = max(done.values(), key=lambda r: (r["success_rate"], -r["mean_peak_pressure_kpa"]))
    out.write_text(json.dumps({"env": args.env, "episodes": args.episodes, "grid": GRID, "best": best}, indent=2) + "\n")
    print("best:", json.dumps(best))


if __name__ == "__main__":
    main()
