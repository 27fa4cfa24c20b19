"""The hand-written baselines side by side on the same held-out episodes of each env (``evertgym baselines``).

    evertgym baselines [--episodes 20] [--envs evertgym/Colon-v0,...] [--policies ...] [--workers 1]
                       [--env-kwargs JSON] [--db runs/baseline_table.sqlite] [--json]

For every env, every policy plays the same held-out episodes (episode and scene seeds
1e9, 1e9 + 1, ...; training never draws them).  The default policies: ``constant`` at
3 kPa, the paper's ``operator``, ``tuned`` (the operator with the parameters tuned on the
env's own training scenes, ``evertgym tune``), ``cycle`` with its historical
defaults (1 <-> 8 kPa, 2 s), ``cycle`` 0 <-> 3 kPa with a 1 s period, and ``deflate``
(3 kPa; on a stall 0 kPa for 0.5 s).  Columns: success (successes / episodes) with its
Wilson 95% interval, mean time to goal over the successes (s), mean peak pressure (kPa) and
mean max contact force (N) over all episodes, mean peak pressure with the tip in the scene's
bend (kPa, over the episodes that reached it) and how many episodes peaked before the bend
(a start-up or approach peak).  ``--env-kwargs`` applies env arguments to every policy (a
randomised regulator lag: ``'{"regulator_tau_s": [0.1, 0.6]}'``).  Every finished episode is
kept in ``--db`` (keyed by policy, env, env kwargs, engine and model file), so a killed run
resumes where it stopped and a longer run reuses the shorter one's episodes.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

# the evaluation and env modules load in run(): `evertgym --help` builds these flags without the simulator
HELD_OUT_SEED_BASE = 1_000_000_000  # evertgym.env.eversion_env.HELD_OUT_SEED_BASE (tests check they agree)

ENVS = ["evertgym/Colon-v0", "evertgym/UBend-v0", "evertgym/Tortuous-v0"]
POLICIES = ["constant:pressure_kpa=3", "operator", "tuned", "cycle", "cycle:low_kpa=0,high_kpa=3,period_s=1",
            "deflate:high_kpa=3,low_kpa=0,deflate_s=0.5"]


def _row(r: dict) -> str:
    k = round(r["success_rate"] * r["episodes"])
    t = "-" if math.isnan(r["mean_time_to_goal_s"]) else f"{r['mean_time_to_goal_s']:.1f}"
    return (f"{r['policy']:<44s} {k:>3d}/{r['episodes']:<3d} {r['success_rate']:>5.2f}  [{r['ci_low']:.2f}, {r['ci_high']:.2f}]"
            f" {t:>9s} {r['mean_peak_pressure_kpa']:>9.2f} {r['mean_max_contact_force_n']:>12.2f}"
            f" {r['mean_peak_pressure_bend_kpa']:>9.2f} {r['peak_before_bend_episodes']:>9d}")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command's flags (``evertgym baselines``)."""
    ap.add_argument("--episodes", type=int, default=20, help="held-out episodes per env and policy")
    ap.add_argument("--envs", default=",".join(ENVS), help="comma-separated env ids; by default Colon-v0, UBend-v0 and Tortuous-v0")
    ap.add_argument("--policies", default=";".join(POLICIES),
                    help="semicolon-separated policies (CLI spelling); by default the six standard rules: constant 3 kPa, "
                         "operator, tuned, cycle (1 <-> 8 kPa, 2 s), cycle 0 <-> 3 kPa (1 s) and deflate (3 kPa, 0 kPa for 0.5 s)")
    ap.add_argument("--workers", type=int, default=1, help="processes to spread the episodes over")
    ap.add_argument("--env-kwargs", default=None, metavar="JSON",
                    help='env arguments for every env and policy, e.g. \'{"regulator_tau_s": [0.1, 0.6]}\'')
    ap.add_argument("--db", default="runs/baseline_table.sqlite",
                    help="SQLite store of finished episodes (resume after a kill); default %(default)s")
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    ap.add_argument("--trust-model", action="store_true",
                    help="load model files in --policies that are not shipped policies (a run's final.zip): model files are code")


def _env_kwargs(text: str | None, env_id: str) -> dict:
    """``--env-kwargs``: a JSON object of env arguments, checked by building the env once (its own one-line errors)."""
    import gymnasium as gym

    if text is None:
        return {}
    try:
        kwargs = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"--env-kwargs = {text!r:.80}: not JSON ({e.msg} at character {e.pos})") from None
    if not isinstance(kwargs, dict):
        raise ValueError(f"--env-kwargs = {text!r:.80}: expected a JSON object of env arguments")
    try:
        gym.make(env_id, **kwargs).close()
    except TypeError as e:  # an unknown argument name
        raise ValueError(f"--env-kwargs: {str(e).split(' was raised from')[0]}") from None
    return kwargs


def run(args: argparse.Namespace) -> int:
    """Play and print the table (or JSON) for parsed flags; bad input raises a one-line ``ValueError``."""
    from evertgym.agents.evaluate import evaluate
    from evertgym.agents.policies import for_env, make_policy

    envs = [e.strip() for e in args.envs.split(",") if e.strip()]
    policies = [p.strip() for p in args.policies.split(";") if p.strip()]
    out: dict[str, list[dict]] = {}
    for env_id in envs:
        kwargs = _env_kwargs(args.env_kwargs, env_id)
        out[env_id] = evaluate(policies, env_id, args.episodes, env_kwargs=kwargs, workers=args.workers,
                               trust=args.trust_model, db=args.db, progress=True)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    n = args.episodes
    for env_id, rows in out.items():
        print(f"{env_id}: {n} held-out episodes (scene seeds {HELD_OUT_SEED_BASE}-{HELD_OUT_SEED_BASE + n - 1}), "
              "the same for every policy")
        if args.env_kwargs:
            print(f"env kwargs: {args.env_kwargs}")
        print(f"{'policy':<44s} {'success':>13s}  {'95% Wilson':<12s} {'goal_s':>9s} {'peak_kpa':>9s} {'max_force_n':>12s}"
              f" {'bend_kpa':>9s} {'peak<bend':>9s}")
        for r in rows:
            print(_row(r))
        if any(p.split(":")[0] == "tuned" for p in policies):
            t: Any = make_policy(for_env("tuned", env_id))
            print(f"  tuned: operator tuned on {t.tuned_on} training scenes: start {t.start_kpa:g} kPa, step {t.step_kpa:g} kPa, "
                  f"stall window {t.stall_s:g} s, relax {t.relax_kpa_per_s:g} kPa/s")
        print()
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m evertgym.agents.baseline_table``: the same as ``evertgym baselines``."""
    ap = argparse.ArgumentParser(prog="evertgym baselines", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    args = ap.parse_args(argv)
    try:
        return run(args)
    except ValueError as e:
        print(f"evertgym baselines: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
