"""Two result stores trial by trial: which outcomes differ, and by how much each recorded number moved.

Pairs the trials of two SQLite result stores (``--db`` of ``reproduce``, ``score`` or ``eval``) by their design,
group (unless a store's trials are of one group) and seed (``--group-a`` / ``--group-b`` pick one group of a store
that holds several, e.g. one policy of an ``eval`` store), and prints how many pairs differ in success, and per
number of the trial record (time to the goal, peak pressure, largest contact force) how many pairs differ, the median
and the largest difference and the two means.  For checking that a setting, a solver or a build changes no answer
(docs/quasistatic.md):

    python scripts/compare_stores.py runs/dense.sqlite runs/semi.sqlite
    python scripts/compare_stores.py runs/v1/tort_v1.sqlite semi_wave.sqlite --group-a 'cycle:low_kpa=2,high_kpa=8,period_s=2'
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import statistics
import sys
from pathlib import Path

FIELDS = ("time_s", "peak_pressure_kpa", "max_contact_force_n")


def load(path: str, group: str | None) -> dict[tuple, dict]:
    """``{(design, group, seed): result}`` of a store's trials (of ``group`` only, if given; the group is left
    out of the key when the trials kept are all of one group, so that one policy pairs with another)."""
    if not Path(path).is_file():
        raise ValueError(f"store = {path!r} is not a file: allowed a result store (SQLite) written by --db")
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        rows = con.execute("select design_name, group_name, seed, result_json from trials").fetchall()
    except sqlite3.Error as e:
        raise ValueError(f"store = {path!r} is not a result store ({e})") from None
    rows = [r for r in rows if group is None or r[1] == group]
    if not rows:
        raise ValueError(f"store = {path!r} holds no trials{f' of group {group!r}' if group else ''}")
    one_group = len({r[1] for r in rows}) == 1  # (then the group is not part of a trial's identity)
    return {(design, "" if one_group else grp, seed): json.loads(res) for design, grp, seed, res in rows}


def compare(a: dict[tuple, dict], b: dict[tuple, dict]) -> dict:
    """The paired trials' differences (see the module docstring)."""
    common = sorted(set(a) & set(b))
    out: dict = {"pairs": len(common), "only_a": len(set(a) - set(b)), "only_b": len(set(b) - set(a)),
                 "passed_a": sum(bool(a[k].get("success")) for k in common), "passed_b": sum(bool(b[k].get("success")) for k in common),
                 "success_differs": [list(k) for k in common if bool(a[k].get("success")) != bool(b[k].get("success"))], "fields": {}}
    for f in FIELDS:
        diffs = [abs(float(a[k][f]) - float(b[k][f])) for k in common
                 if isinstance(a[k].get(f), (int, float)) and isinstance(b[k].get(f), (int, float))]
        if diffs:
            both = [k for k in common if isinstance(a[k].get(f), (int, float)) and isinstance(b[k].get(f), (int, float))]
            out["fields"][f] = {"pairs_differing": sum(d > 0 for d in diffs), "median": statistics.median(diffs), "max": max(diffs),
                                "mean_a": statistics.fmean(float(a[k][f]) for k in both),
                                "mean_b": statistics.fmean(float(b[k][f]) for k in both)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("store_a")
    ap.add_argument("store_b")
    ap.add_argument("--group-a", help="only this group (policy) of store A")
    ap.add_argument("--group-b", help="only this group (policy) of store B")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    try:
        r = compare(load(args.store_a, args.group_a), load(args.store_b, args.group_b))
    except ValueError as e:
        print(e, file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(r, indent=1))
        return 0
    print(f"{r['pairs']} paired trials ({r['only_a']} only in A, {r['only_b']} only in B); passed: A {r['passed_a']}, B {r['passed_b']}; "
          f"success differs in {len(r['success_differs'])}")
    for k in r["success_differs"]:
        print(f"  differs: design {k[0]!r} group {k[1]!r} seed {k[2]}")
    for f, d in r["fields"].items():
        print(f"{f:>20s}: differs in {d['pairs_differing']} pairs, median |difference| {d['median']:.3g}, largest {d['max']:.3g}; "
              f"mean A {d['mean_a']:.4f}, B {d['mean_b']:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
