#!/usr/bin/env python
"""Is passing the colon bend by pressure cycling physics or an artefact of the scaled dynamics?

    python scripts/check_colon_cycling.py [--episodes 20] [--workers 2]

The simulator's masses, inertias and damping are scaled for speed: only its quasi-static
answers are meant to be meaningful (docs/sim.md).  The trained Colon-v0 policy and the
``cycle`` baseline pass the bend by deflating and re-inflating.  This runs the shipped PPO
policy, ``cycle`` (1 <-> 8 kPa, 2 s period) and the operator protocol on the same held-out
Colon-v0 episodes on the dynamic engine with its default settings, half the time step, and twice the inertia and mass; if the
success rates hold, the mechanism is a sequence of quasi-static states, not a dynamic kick.
"""

from __future__ import annotations

import argparse

from evertgym.agents.evaluate import evaluate

SETTINGS = {
    "dynamic": {"engine": "dynamic"},
    "dynamic, dt_s=0.001": {"engine": "dynamic", "dt_s": 0.001},
    "dynamic, inertia x2, mass x2": {"engine": "dynamic", "inertia_factor": 6.0, "mass_ratio": 0.02},
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--policies", default="agents/colon_ppo/final.zip,cycle,operator",
                    help="comma-separated policies (default: the shipped PPO policy, cycle, operator)")
    args = ap.parse_args(argv)
    print(f"{'setting':22s} {'policy':28s} {'episodes':>8s} {'success':>8s} {'95% CI':>14s} {'peak_kpa':>9s}")
    for label, cfg in SETTINGS.items():
        rows = evaluate(args.policies.split(","), "evertgym/Colon-v0", args.episodes, env_kwargs={"sim_config": cfg},
                        workers=args.workers)
        for r in rows:
            print(f"{label:22s} {r['policy']:28s} {r['episodes']:>8d} {r['success_rate']:>8.2f} "
                  f"[{r['ci_low']:.2f}, {r['ci_high']:.2f}] {r['mean_peak_pressure_kpa']:>9.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
