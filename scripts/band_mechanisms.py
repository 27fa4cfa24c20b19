"""The band-mechanism study (issue 26): every candidate law on the quasi-static engine, the no-band
rows refitted, the full U-bend table with Wilson intervals, +-10% of each fitted parameter, the
issue's criteria and the jam anatomy; writes docs/bands_study.md (and --json prints the study).

    python scripts/band_mechanisms.py                       # all candidates, 12 trials per cell
    python scripts/band_mechanisms.py --candidates hinges   # one

Resumable: every trial is kept in --db; a rerun after a kill skips what is stored.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> dict:
    from evertgym.experiments.mechanisms import CANDIDATES, report, run_study

    keys = [c.key for c in CANDIDATES]
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--candidates", default=",".join(keys), help=f"comma-separated, from {', '.join(keys)}")
    ap.add_argument("--trials", type=int, default=12, help="trials per cell, [1, 100]")
    ap.add_argument("--db", default="runs/band_mechanisms.sqlite", help="result store (resumable)")
    ap.add_argument("--write", default=str(ROOT / "docs" / "bands_study.md"), help="page to write ('' for none)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    chosen = [k.strip() for k in args.candidates.split(",") if k.strip()]
    bad = [k for k in chosen if k not in keys]
    if bad or not chosen:
        sys.exit(f"--candidates = {args.candidates!r} is out of range: allowed a comma-separated subset of {', '.join(keys)}")
    if not 1 <= args.trials <= 100:
        sys.exit(f"--trials = {args.trials!r} is out of range: allowed [1, 100]")
    log = (lambda m: print(m, file=sys.stderr)) if args.json else print
    study = run_study(args.db, chosen, args.trials, log=log)
    text = report(study)
    if args.write:
        Path(args.write).write_text("# The band-mechanism study (generated)\n\nRegenerate: `python scripts/band_mechanisms.py` "
                                    f"({args.trials} trials per cell; quasi-static engine).  Read docs/bands.md first.\n\n" + text + "\n")
    if args.json:
        print(json.dumps(study, default=str))
    else:
        print(text)
    return study


if __name__ == "__main__":
    main()
