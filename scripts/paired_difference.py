"""Paired difference of one per-episode figure between two policies on the same held-out episodes.

Reads both policies' episodes from evaluation stores (``evertgym eval --db``, ``scripts/baseline_table.py
--db``) and prints, over the episodes both have, the two means, the mean difference (second minus first)
with its normal 95% interval, the Wilcoxon signed-rank p-value and in how many episodes the second is lower; then
the two successes over the same episodes with the exact McNemar test on the discordant ones (passed by one policy
only), so a lower force can be read beside what it cost in passes.
``--env-kwargs`` picks the episodes played with those env kwargs (default the randomised regulator lag, or none for an
id whose preset draws the lag itself, such as TortuousHard-v0), e.g. an outcome check's replays (``evertgym eval
--check-outcomes`` stores them with the changed setting in ``sim_config``), so a difference can be shown to survive the solver's numerical settings.

    python scripts/paired_difference.py --env evertgym/UBend-v0 \\
        --a runs/baseline_table.sqlite:tuned \\
        --b runs/tries/ubend_force_heldout.sqlite:runs/tries/ubend_ppo_operator_force/final.zip
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
from scipy import stats

from evertgym.agents.stored import RANDOMISED_LAG, parse_env_kwargs, policy_episodes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", required=True)
    ap.add_argument("--a", required=True, help="STORE:POLICY, the first policy")
    ap.add_argument("--b", required=True, help="STORE:POLICY, the second policy")
    ap.add_argument("--key", default="max_contact_force_n", help="the per-episode figure (default max_contact_force_n)")
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--env-kwargs", default=None,
                    help=f"the env kwargs the episodes were played with, as JSON (default {json.dumps(RANDOMISED_LAG)}, or "
                         "{} for an id whose preset draws the regulator lag itself); an outcome check's replay adds e.g. "
                         '"sim_config": {"solver_tolerance": 0.0001}')
    args = ap.parse_args()
    try:
        env_kwargs = parse_env_kwargs("--env-kwargs", args.env_kwargs, args.env)
        ra = policy_episodes("--a", args.a, args.env, args.episodes, env_kwargs)[2]
        rb = policy_episodes("--b", args.b, args.env, args.episodes, env_kwargs)[2]
    except ValueError as e:
        sys.exit(str(e))
    seeds = sorted(set(ra) & set(rb))
    if len(seeds) < 2:
        sys.exit(f"only {len(seeds)} episodes in both stores for {args.env} with env kwargs {json.dumps(env_kwargs)}")
    a = {s: float(ra[s][args.key]) for s in seeds}
    b = {s: float(rb[s][args.key]) for s in seeds}
    d = np.array([b[s] - a[s] for s in seeds])
    half = 1.96 * d.std(ddof=1) / math.sqrt(len(d))
    print(f"{args.env}, {len(seeds)} episodes in both, {args.key}: first {np.mean(list(a.values())):.4f}, "
          f"second {np.mean(list(b.values())):.4f}")
    print(f"second - first: {d.mean():+.4f}, 95% interval [{d.mean() - half:+.4f}, {d.mean() + half:+.4f}], "
          f"Wilcoxon p = {stats.wilcoxon(d).pvalue:.2g}, second lower in {(d < 0).sum()} of {len(d)}")
    print(_success_line(ra, rb, seeds))


def _success_line(ra: dict[int, dict], rb: dict[int, dict], seeds: list[int]) -> str:
    """Both successes over the shared episodes and the exact (binomial) McNemar test on the discordant ones."""
    sa = [bool(ra[s]["success"]) for s in seeds]
    sb = [bool(rb[s]["success"]) for s in seeds]
    only_a = sum(x and not y for x, y in zip(sa, sb))
    only_b = sum(y and not x for x, y in zip(sa, sb))
    p = stats.binomtest(only_a, only_a + only_b, 0.5).pvalue if only_a + only_b else 1.0
    return (f"success: first {sum(sa)}/{len(seeds)}, second {sum(sb)}/{len(seeds)}; passed by the first only "
            f"{only_a}, by the second only {only_b}, exact McNemar p = {p:.2g}")


if __name__ == "__main__":
    main()
