"""Which Colon-v0 rule outcomes a change of the command by about 6e-8 of itself, or a solver setting, flips
(issue 25's knife edge, docs/quasistatic.md).

Each rule of the Colon-v0 baseline table plays the 200 held-out episodes (regulator lag U(0.1, 0.6) s) as
given and with one of its pressure levels moved by about 6e-8 of itself: 2 or 3 float32 steps of the action
(the env's actions are float32, so a change below one step does not reach it).  The 1 <-> 8 kPa wave, whose
outcomes the level change flips, also plays them with the solver's tolerance 10 times tighter and with half
the growth increment.  Printed per comparison: successes both ways, the episodes whose outcome differs, and
for the episodes whose outcome is the same the largest change of the peak contact force and of the final
insertion length.  Then the shipped ``colon_ppo_operator``'s failed episodes are replayed under the same solver
settings.

    python scripts/colon_ulp_flips.py --db runs/colon_rules_1thread.sqlite   # reuses the rules' stored episodes

Every episode is kept in ``--db`` (a killed run resumes); 1,400 new episodes take about 35 min on one core.
"""

from __future__ import annotations

import argparse
import json

import evertgym  # noqa: F401  (registers the envs)
from evertgym.agents.baselines import pressure_to_action
from evertgym.agents.evaluate import evaluate
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.scoring.store import ResultStore

ENV = "evertgym/Colon-v0"
KW = {"regulator_tau_s": [0.1, 0.6]}
#: (rule as in the baseline table, the same rule with one level moved, the level as given and moved, kPa)
LEVELS = [
    ("cycle", "cycle:high_kpa=7.9999995", 8.0, 7.9999995),
    ("cycle:low_kpa=0,high_kpa=3,period_s=1", "cycle:low_kpa=0,high_kpa=3.0000002,period_s=1", 3.0, 3.0000002),
    ("constant:pressure_kpa=3", "constant:pressure_kpa=3.0000002", 3.0, 3.0000002),
    ("operator", "operator:start_kpa=2.0000002", 2.0, 2.0000002),
    ("deflate:high_kpa=3,low_kpa=0,deflate_s=0.5", "deflate:high_kpa=3.0000002,low_kpa=0,deflate_s=0.5", 3.0, 3.0000002),
]
#: solver settings under which the 1 <-> 8 kPa wave is replayed (SimConfig fields)
KNOBS = [{"solver_tolerance": 1e-4}, {"growth_increment_m": 0.0005}]


def _by_seed(store: ResultStore, group: str, kwargs: dict, episodes: int) -> dict[int, dict]:
    seeds = list(range(HELD_OUT_SEED_BASE, HELD_OUT_SEED_BASE + episodes))
    return {rec.spec.seed: rec.result for rec in store.results(group=group, seed=seeds) if rec.spec.scene["params"] == kwargs}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--db", default="runs/colon_ulp_flips.sqlite")
    args = ap.parse_args()
    for _, moved, level, level_moved in LEVELS:  # the change reaches the env: a float32 action a few steps away
        a0, a1 = pressure_to_action(level)[0], pressure_to_action(level_moved)[0]
        assert 1 <= abs(int(a0.view("int32")) - int(a1.view("int32"))) <= 3, moved
    comparisons = [(base, KW, moved, KW, "level moved by 6e-8") for base, moved, _, _ in LEVELS]
    comparisons += [("cycle", KW, "cycle", {**KW, "sim_config": knob}, f"sim_config {knob}") for knob in KNOBS]
    evaluate([p for pair in LEVELS for p in pair[:2]], ENV, args.episodes, env_kwargs=KW, db=args.db, progress=True)
    for knob in KNOBS:
        evaluate(["cycle"], ENV, args.episodes, env_kwargs={**KW, "sim_config": knob}, db=args.db, progress=True)
    print(f"{ENV}: {args.episodes} held-out episodes, env kwargs {KW}")
    print(f"{'rule':44s} {'change':42s} {'given':>5s} {'moved':>5s} {'flips':>5s} {'max |dF| N':>10s} {'max |dL| mm':>11s}  flipped")
    total = flips = 0
    with ResultStore(args.db) as store:
        for base, kw_a, moved, kw_b, what in comparisons:
            a, b = _by_seed(store, base, kw_a, args.episodes), _by_seed(store, moved, kw_b, args.episodes)
            flipped = sorted(s for s in a if s in b and a[s]["success"] != b[s]["success"])
            same = [s for s in a if s in b and s not in flipped]
            d_f = max(abs(a[s]["max_contact_force_n"] - b[s]["max_contact_force_n"]) for s in same)
            d_l = max(abs(a[s]["insertion_length_mm"] - b[s]["insertion_length_mm"]) for s in same)
            total += len(a)
            flips += len(flipped)
            print(f"{base:44s} {what:42s} {sum(r['success'] for r in a.values()):5d} {sum(r['success'] for r in b.values()):5d} "
                  f"{len(flipped):5d} {d_f:10.3g} {d_l:11.3g}  {' '.join(str(s - HELD_OUT_SEED_BASE) for s in flipped)}")
    print(f"outcomes flipped: {flips} of {total} episode pairs; seeds are printed as offsets from {HELD_OUT_SEED_BASE}")
    # the shipped operator-only policy's failures, replayed under the solver settings
    evaluate(["colon_ppo_operator"], ENV, args.episodes, env_kwargs=KW, db=args.db, progress=True)
    with ResultStore(args.db) as store:
        failed = sorted(s for s, r in _by_seed(store, "colon_ppo_operator", KW, args.episodes).items() if not r["success"])
    print(f"colon_ppo_operator fails {len(failed)} of {args.episodes}; each replayed (1 = passes):")
    for seed in failed:
        cells = []
        for knob in KNOBS:
            r = evaluate(["colon_ppo_operator"], ENV, 1, env_kwargs={**KW, "sim_config": knob}, seed_base=seed, db=args.db)[0]
            cells.append(f"{json.dumps(knob)}: {r['success_rate']:.0f}")
        print(f"  {seed - HELD_OUT_SEED_BASE:4d}  " + "  ".join(cells))


if __name__ == "__main__":
    main()
