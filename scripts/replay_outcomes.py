#!/usr/bin/env python
"""Replay chosen held-out episodes of one policy under the outcome check's solver settings.

    python scripts/replay_outcomes.py runs/residual/colon_residual_tuned/final.zip --env evertgym/Colon-v0 \\
        --episodes 133,135 --env-kwargs '{"regulator_tau_s": [0.1, 0.6]}' --trust-model

``evertgym eval --check-outcomes`` plays every episode three times (the settings as given, the solver
tolerance / 10, the growth increment / 2); this plays only the held-out episodes named by their offset
``k`` (episode and scene seed 1e9 + k, as eval's k-th episode), and prints each one's outcome per play.
An episode that fails in every play is a decided loss; one whose outcome changes is undecided.
"""

from __future__ import annotations

import argparse
import json
import sys

import gymnasium as gym

import evertgym  # noqa: F401  (registers the envs)
from evertgym.agents.baselines import run_episode
from evertgym.agents.evaluate import OUTCOME_CHECKS, outcome_check_kwargs
from evertgym.agents.policies import make_policy
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.limits import MAX_EPISODES


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("policy", help="a baseline, a shipped policy or a .zip")
    ap.add_argument("--env", required=True, help="a registered env id")
    ap.add_argument("--episodes", required=True, help="held-out episode offsets k, comma-separated (seed 1e9 + k)")
    ap.add_argument("--env-kwargs", default="{}", help="env arguments, a JSON object (as for eval)")
    ap.add_argument("--trust-model", action="store_true", help="load a model that is not a shipped policy")
    args = ap.parse_args(argv)
    try:
        ks = [int(k) for k in args.episodes.split(",")]
    except ValueError:
        sys.exit(f"--episodes = {args.episodes!r} is not allowed: allowed comma-separated integers in [0, {MAX_EPISODES})")
    if any(not 0 <= k < MAX_EPISODES for k in ks):
        sys.exit(f"--episodes = {args.episodes!r} is out of range: allowed integers in [0, {MAX_EPISODES})")
    if args.env not in gym.registry:
        sys.exit(f"--env = {args.env!r} is not a registered env id: allowed {sorted(k for k in gym.registry if 'evertgym' in k)}")
    try:
        kwargs = json.loads(args.env_kwargs)
        if not isinstance(kwargs, dict):
            raise ValueError("not a JSON object")
        plays = [kwargs] + outcome_check_kwargs(kwargs)
        policy = make_policy(args.policy, trust=args.trust_model)
    except ValueError as e:
        sys.exit(f"replay_outcomes: {e}")
    names = ["as given"] + [f"{name} / {divisor:g}" for name, divisor in OUTCOME_CHECKS]
    envs = [gym.make(args.env, **{**kw, **getattr(policy, "observation_kwargs", {})}) for kw in plays]
    print(f"{args.policy} on {args.env}, held-out episodes {ks}: outcome per play")
    print(f"{'episode':>8}  " + "  ".join(f"{n:>22}" for n in names))
    for k in ks:
        seed = HELD_OUT_SEED_BASE + k
        row = []
        for env in envs:
            info = run_episode(env, policy, seed, options={"scene_seed": seed})
            row.append(f"{info['outcome']} {info['insertion_length_mm']:.1f} mm")
        print(f"{k:>8}  " + "  ".join(f"{c:>22}" for c in row), flush=True)
    for env in envs:
        env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
