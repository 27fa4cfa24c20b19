"""How many Colon-v0 rule outcomes a change of the command by about 6e-8 of itself flips (issue 25's knife edge).

Each rule of the Colon-v0 baseline table plays the 200 held-out episodes (regulator lag U(0.1, 0.6) s) as
given and with one of its pressure levels moved by about 6e-8 of itself: 2 or 3 float32 steps of the action
(the env's actions are float32, so a change below one step does not reach it).  Printed
per rule: successes both ways, the episodes whose outcome differs, and for the episodes whose outcome is
the same the largest change of the peak contact force and of the final insertion length.

    python scripts/colon_ulp_flips.py --db runs/colon_rules_1thread.sqlite   # reuses the rules' stored episodes

Every episode is kept in ``--db`` (a killed run resumes); 1,000 new episodes take about 25 min on one core.
"""

from __future__ import annotations

import argparse

import evertgym  # noqa: F401  (registers the envs)
from evertgym.agents.baselines import pressure_to_action
from evertgym.agents.evaluate import evaluate
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.scoring.store import ResultStore

ENV = "evertgym/Colon-v0"
KW = {"regulator_tau_s": [0.1, 0.6]}
#: (rule as in the baseline table, the same rule with one level moved, the level as given and moved, kPa)
PAIRS = [
    ("cycle", "cycle:high_kpa=7.9999995", 8.0, 7.9999995),
    ("cycle:low_kpa=0,high_kpa=3,period_s=1", "cycle:low_kpa=0,high_kpa=3.0000002,period_s=1", 3.0, 3.0000002),
    ("constant:pressure_kpa=3", "constant:pressure_kpa=3.0000002", 3.0, 3.0000002),
    ("operator", "operator:start_kpa=2.0000002", 2.0, 2.0000002),
    ("deflate:high_kpa=3,low_kpa=0,deflate_s=0.5", "deflate:high_kpa=3.0000002,low_kpa=0,deflate_s=0.5", 3.0, 3.0000002),
]


def _by_seed(store: ResultStore, group: str, episodes: int) -> dict[int, dict]:
    seeds = list(range(HELD_OUT_SEED_BASE, HELD_OUT_SEED_BASE + episodes))
    out = {}
    for rec in store.results(group=group, seed=seeds):
        out[rec.spec.seed] = rec.result  # the newest row of a seed wins
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--db", default="runs/colon_ulp_flips.sqlite")
    args = ap.parse_args()
    for _, moved, level, level_moved in PAIRS:  # the change reaches the env: a float32 action a few steps away
        a0, a1 = pressure_to_action(level)[0], pressure_to_action(level_moved)[0]
        assert 1 <= abs(int(a0.view("int32")) - int(a1.view("int32"))) <= 3, moved
    evaluate([p for pair in PAIRS for p in pair[:2]], ENV, args.episodes, env_kwargs=KW, db=args.db, progress=True)
    print(f"{ENV}: {args.episodes} held-out episodes, env kwargs {KW}; one level moved by about 6e-8 of itself")
    print(f"{'rule':46s} {'as given':>8s} {'moved':>6s} {'flipped':>7s}  {'max |dF| N':>10s} {'max |dL| mm':>11s}  flipped seeds")
    total = flips = 0
    with ResultStore(args.db) as store:
        for base, moved, _, _ in PAIRS:
            a, b = _by_seed(store, base, args.episodes), _by_seed(store, moved, args.episodes)
            flipped = sorted(s for s in a if s in b and a[s]["success"] != b[s]["success"])
            same = [s for s in a if s in b and s not in flipped]
            d_f = max(abs(a[s]["max_contact_force_n"] - b[s]["max_contact_force_n"]) for s in same)
            d_l = max(abs(a[s]["insertion_length_mm"] - b[s]["insertion_length_mm"]) for s in same)
            total += len(a)
            flips += len(flipped)
            print(f"{base:46s} {sum(r['success'] for r in a.values()):8d} {sum(r['success'] for r in b.values()):6d} "
                  f"{len(flipped):7d}  {d_f:10.3g} {d_l:11.3g}  {' '.join(str(s - HELD_OUT_SEED_BASE) for s in flipped)}")
    print(f"outcomes flipped: {flips} of {total}; seeds are printed as offsets from {HELD_OUT_SEED_BASE}")


if __name__ == "__main__":
    main()
