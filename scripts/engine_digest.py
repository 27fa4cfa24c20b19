"""Digests of random-action episodes on both engines, to show that a change keeps every answer bit for bit.

Each (env, engine) run plays ``steps`` steps of uniform random actions (seed 0, resetting at the end of an
episode) and hashes, per step, the observation, the reward, the info (every key, as JSON with floats
written exactly) and the centreline of the simulator, and per episode the simulator's events.  The same
digests before and after a change mean the same answers: a shipped policy then still retrains exactly
from its config (``evertgym compare-runs``).

    python scripts/engine_digest.py                      # prints one line per (env, engine)
    python scripts/engine_digest.py --json > before.json # ... change ...
    python scripts/engine_digest.py --against before.json  # exit 1 if any digest differs
    python scripts/engine_digest.py --sim '{"linear_solver": "dense"}' --against before.json
                                                          # quasi-static runs with SimConfig fields (e.g. the
                                                          # solver a digest saved before 2026-12-05 was made with)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

#: (env id, engine, steps): the quasi-static default on the three families, the dynamic engine on two.
RUNS = (
    ("evertgym/UBend-v0", "quasistatic", 300),
    ("evertgym/Colon-v0", "quasistatic", 120),
    ("evertgym/Tortuous-v0", "quasistatic", 200),
    ("evertgym/TortuousHard-v0", "quasistatic", 100),
    ("evertgym/UBend-v0", "dynamic", 150),
    ("evertgym/Colon-v0", "dynamic", 60),
)


def _exact(value):
    """``value`` made JSON-serialisable with every float written exactly (its hex form)."""
    import numpy as np

    if isinstance(value, dict):
        return {str(k): _exact(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [_exact(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_exact(v) for v in value.tolist()]
    if isinstance(value, (float, np.floating)):
        return float(value).hex()
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    return str(value)


#: Info keys added after digests were first saved, derived from hashed ones (``solve_failures``): left out,
#: so a digest stays comparable with one made before them.
_DERIVED_INFO = ("unconverged_solves", "solve_budget_cuts")


def digest(env_id: str, engine: str, steps: int, sim: dict | None = None) -> str:
    """SHA-256 of ``steps`` random-action steps of ``env_id`` on ``engine`` (see the module's docstring);
    ``sim``: further SimConfig fields."""
    import gymnasium as gym
    import numpy as np

    import evertgym  # noqa: F401  (registers the envs)

    env = gym.make(env_id, sim_config={**(sim or {}), "engine": engine})
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    h = hashlib.sha256()
    for _ in range(steps):
        action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
        obs, reward, term, trunc, info = env.step(action)
        sim = env.unwrapped.sim
        h.update(np.asarray(obs, np.float64).tobytes())
        h.update(np.float64(reward).tobytes())
        h.update(json.dumps(_exact({k: v for k, v in info.items() if k not in _DERIVED_INFO}), sort_keys=True).encode())
        h.update(np.asarray(sim.centreline(), np.float64).tobytes())
        if term or trunc:
            h.update(json.dumps(_exact(list(getattr(sim, "events", []))), sort_keys=True).encode())
            env.reset()
    env.close()
    return h.hexdigest()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object {'env engine steps': digest}")
    ap.add_argument("--against", metavar="FILE", help="a --json output to compare with; exit 1 if any digest differs")
    ap.add_argument("--sim", default="", help="SimConfig fields as JSON for the quasi-static runs (the dynamic ones run "
                    "their defaults), e.g. '{\"linear_solver\": \"dense\"}'")
    args = ap.parse_args(argv)
    from evertgym.sim.config import parse_sim

    try:
        sim = parse_sim(args.sim, engine="quasistatic")
    except ValueError as e:
        print(f"--sim: {e}", file=sys.stderr)
        return 2
    before = None
    if args.against:
        try:
            with open(args.against) as f:
                before = json.load(f)
        except (OSError, ValueError) as e:
            print(f"--against: cannot read {args.against!r} as this script's --json output ({e})", file=sys.stderr)
            return 2
    out, same = {}, True
    for env_id, engine, steps in RUNS:
        key = f"{env_id} {engine} {steps}"
        out[key] = digest(env_id, engine, steps, sim if engine == "quasistatic" else None)
        if before is not None:
            ok = before.get(key) == out[key]
            same &= ok
            if not args.json:
                print(f"{key:42s} {out[key][:16]}  {'same' if ok else 'DIFFERENT'}")
        elif not args.json:
            print(f"{key:42s} {out[key]}")
    if args.json:
        print(json.dumps(out, indent=1))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
