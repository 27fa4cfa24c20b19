#!/usr/bin/env python
"""Search the operator protocol's parameters on an env's training scenes: the tuned baseline.

    python scripts/tune_operator.py --env evertgym/Colon-v0 [--episodes 8] [--out FILE.json]

Every point of the grid (start pressure, step, stall window, relaxation: 36 points) is
run on the same training episodes of the env (``reset(seed=k)``, ``k < --episodes``; their
scene seeds are drawn below the held-out base and checked, never the evaluation scenes);
the best has the highest success rate, then the lowest mean peak pressure.  The result goes
to the env's own file (``agents/tuned_operator_<name>.json``; UBend-v0's keeps its name
``agents/tuned_operator.json``), which ``tuned`` loads when evaluated on that env.  Each
point is appended to ``<out>.jsonl`` as it is produced, so a killed search resumes where it
stopped.  Cost: 36 x --episodes episodes (a Colon-v0 episode that times out takes ~6 s on
one core).
"""

import argparse
import json
import sys
from pathlib import Path

import evertgym  # noqa: F401
from evertgym.agents.tuned import tune_operator, tuned_path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="evertgym/Colon-v0", help="the env to tune on (its training scenes)")
    ap.add_argument("--episodes", type=int, default=8, help="training episodes per grid point")
    ap.add_argument("--out", default=None, help="result file (default: the env's file in agents/)")
    args = ap.parse_args(argv)
    try:
        out = Path(args.out) if args.out else tuned_path(args.env, Path(__file__).resolve().parents[1] / "agents")
        result = tune_operator(args.env, args.episodes, log=out.with_suffix(".jsonl"),
                               on_result=lambda rec: print(json.dumps(rec), flush=True))
    except ValueError as e:
        print(f"tune_operator: error: {e}", file=sys.stderr)
        return 2
    out.write_text(json.dumps(result, indent=2) + "\n")
    print("best:", json.dumps(result["best"]))
    print(f"-> {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
