"""Headroom on a benchmark: which stored policies pass the held-out episodes a reference policy fails
(``evertgym headroom``).

Reads every policy's held-out episodes of one env from evaluation stores (``evertgym eval --db``,
``evertgym baselines --db``) and prints, per policy with all ``--episodes`` episodes stored: its passes, how
many of the reference's failures it passes and how many of the reference's passes it fails; then what a per-episode
oracle over all of them (the best stored policy chosen for each episode, which no policy can do) would pass, and the
episodes every stored policy fails.  A reference whose failures no other policy passes leaves a residual around it
little to find.

    evertgym headroom --env evertgym/TortuousHard-v0 \\
        --ref 'runs/tort_hard.sqlite:cycle:low_kpa=2,high_kpa=8,period_s=2' --stores runs/tort_hard.sqlite
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

# the store and env modules load in the functions: `evertgym --help` builds this command's flags without the simulator


def headroom(ref: dict[int, dict], others: dict[str, dict[int, dict]], seeds: list[int]) -> dict:
    """The reference's failures among ``seeds`` and, per policy, its passes over them: a JSON-ready dict."""
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    failed = [s for s in seeds if not ref[s]["success"]]
    passed = [s for s in seeds if ref[s]["success"]]
    rows = [{"policy": name, "successes": sum(bool(eps[s]["success"]) for s in seeds),
             "passes_of_ref_failures": sum(bool(eps[s]["success"]) for s in failed),
             "fails_of_ref_passes": sum(not eps[s]["success"] for s in passed)} for name, eps in others.items()]
    everyone = [ref, *others.values()]
    oracle = [s for s in seeds if any(eps[s]["success"] for eps in everyone)]
    return {"episodes": len(seeds), "ref_successes": len(passed), "ref_failures": len(failed), "rows": rows,
            "oracle_successes": len(oracle), "ref_failures_passed_by_any": len(set(failed) & set(oracle)),
            "failed_by_all": [s - HELD_OUT_SEED_BASE for s in seeds if s not in oracle]}


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command's flags (``evertgym headroom``)."""
    ap.add_argument("--env", required=True, help="env id, e.g. evertgym/TortuousHard-v0")
    ap.add_argument("--ref", required=True, help="STORE:POLICY, the reference (e.g. the best rule)")
    ap.add_argument("--stores", nargs="+", required=True, help="stores whose other policies are compared")
    ap.add_argument("--episodes", type=int, default=200, help="held-out episodes (seeds 1e9 ...), default 200")
    ap.add_argument("--env-kwargs", default=None,
                    help='the env kwargs the episodes were played with, as JSON (default {"regulator_tau_s": [0.1, 0.6]}, '
                         "or {} for an id whose preset draws the regulator lag itself)")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")


def run(args: argparse.Namespace) -> int:
    """Print the headroom table (or JSON) for parsed flags; bad input raises a one-line ``ValueError``."""
    from evertgym.agents.stored import held_out_episodes, parse_env_kwargs, policy_episodes
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE

    if args.episodes < 1:
        raise ValueError(f"--episodes = {args.episodes} is out of range: allowed 1 or more")
    env_kwargs = parse_env_kwargs("--env-kwargs", args.env_kwargs, args.env)
    db, group, ref = policy_episodes("--ref", args.ref, args.env, args.episodes, env_kwargs)
    seeds = list(range(HELD_OUT_SEED_BASE, HELD_OUT_SEED_BASE + args.episodes))
    if len(ref) < args.episodes:
        raise ValueError(f"--ref = {args.ref!r} has {len(ref)} of the {args.episodes} held-out episodes of {args.env} "
                         f"with env kwargs {json.dumps(env_kwargs)}: allowed a policy with all of them")
    found: dict[str, list[tuple[str, dict[int, dict]]]] = {}
    for store in args.stores:
        for name, eps in held_out_episodes(store, args.env, args.episodes, env_kwargs).items():
            found.setdefault(name, []).append((store, eps))
    others, partial = {}, []
    for name, copies in found.items():
        for store, eps in copies:
            if name == group and Path(store).resolve() == Path(db).resolve():
                continue  # the reference itself
            label = name if len(copies) == 1 else f"{store}:{name}"
            if len(eps) == args.episodes:
                others[label] = eps
            else:
                partial.append(f"{label} ({len(eps)})")
    out = headroom(ref, others, seeds)
    if args.json:
        print(json.dumps({"env_id": args.env, "env_kwargs": env_kwargs, "ref": group, "partial": partial, **out}, indent=2))
        return 0
    print(f"{args.env}, {out['episodes']} held-out episodes, env kwargs {json.dumps(env_kwargs)}: the reference {group} "
          f"passes {out['ref_successes']} and fails {out['ref_failures']}")
    width = max([30] + [len(r["policy"]) for r in out["rows"]])
    print(f"{'policy':{width}s} {'passed':>6s} {'of_ref_failures':>15s} {'fails_of_ref_passes':>19s}")
    for r in sorted(out["rows"], key=lambda r: -r["successes"]):
        print(f"{r['policy']:{width}s} {r['successes']:>6d} {r['passes_of_ref_failures']:>15d} {r['fails_of_ref_passes']:>19d}")
    print(f"per-episode oracle over the reference and {len(others)} policies: {out['oracle_successes']}/{out['episodes']}; "
          f"the reference's failures passed by any: {out['ref_failures_passed_by_any']} of {out['ref_failures']}")
    fb = out["failed_by_all"]
    print(f"failed by every policy: {len(fb)}" + (f" (episodes {' '.join(map(str, fb))}, offsets from {HELD_OUT_SEED_BASE})" if fb else ""))
    if partial:
        print(f"left out, fewer than {args.episodes} episodes stored: {', '.join(partial)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m evertgym.agents.headroom``: the same as ``evertgym headroom``."""
    ap = argparse.ArgumentParser(prog="evertgym headroom", description=__doc__.splitlines()[0])
    add_arguments(ap)
    args = ap.parse_args(argv)
    try:
        return run(args)
    except ValueError as e:
        print(f"evertgym headroom: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
