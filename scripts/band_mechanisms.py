"""The band-mechanism study (issue 26): every candidate law on the quasi-static engine, the no-band
rows refitted, the full U-bend table with Wilson intervals, +-10% of each fitted parameter, the
issue's criteria and the jam anatomy; writes docs/bands_study.md (and --json prints the study).

    python scripts/band_mechanisms.py                       # all candidates, 12 trials per cell
    python scripts/band_mechanisms.py --candidates hinges   # one
    python scripts/band_mechanisms.py --sim '{"linear_solver": "dense"}'   # SimConfig fields under every candidate

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
    ap.add_argument("--sim", default="", help="SimConfig fields as JSON under every candidate's switches, in every trial "
                    "(e.g. '{\"linear_solver\": \"semiseparable\"}'); the candidates' own switches win")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    chosen = [k.strip() for k in args.candidates.split(",") if k.strip()]
    bad = [k for k in chosen if k not in keys]
    if bad or not chosen:
        sys.exit(f"--candidates = {args.candidates!r} is out of range: allowed a comma-separated subset of {', '.join(keys)}")
    if not 1 <= args.trials <= 100:
        sys.exit(f"--trials = {args.trials!r} is out of range: allowed [1, 100]")
    sim = _sim(args.sim, [c for c in CANDIDATES if c.key in chosen])
    log = (lambda m: print(m, file=sys.stderr)) if args.json else print
    study = run_study(args.db, chosen, args.trials, log=log, sim=sim)
    text = report(study)
    if args.write:
        flag = f" --sim '{args.sim}'" if sim else ""
        Path(args.write).write_text(f"# The band-mechanism study (generated)\n\nRegenerate: `python scripts/band_mechanisms.py{flag}` "
                                    f"({args.trials} trials per cell; quasi-static engine).  Read docs/bands.md first.\n\n" + text + "\n")
    if args.json:
        print(json.dumps(study, default=str))
    else:
        print(text)
    return study


def _sim(text: str, candidates) -> dict:
    """``--sim``: a JSON object of SimConfig fields, valid under each chosen candidate's switches; one line
    and exit 2 otherwise."""
    from dataclasses import fields

    from evertgym.sim.config import SimConfig

    if not text:
        return {}
    try:
        sim = json.loads(text)
        if not isinstance(sim, dict):
            raise ValueError("not a JSON object of SimConfig fields")
        unknown = sorted(set(sim) - {f.name for f in fields(SimConfig)})
        if unknown:
            raise ValueError(f"unknown SimConfig fields {unknown}")
        if "engine" in sim:
            raise ValueError("the study runs on the quasi-static engine: leave engine out")
        for cand in candidates:
            SimConfig(**{"engine": "quasistatic", **sim, **cand.sim})
    except (ValueError, TypeError) as e:
        sys.exit(f"--sim = {text!r} is not allowed: {e}")
    return sim


if __name__ == "__main__":
    main()
