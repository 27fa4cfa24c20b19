"""Share of an env step spent in Chipmunk's own ``Space.step``, per env id (one core).

Wraps ``pymunk.Space.step`` with a timer and runs ``--steps`` env steps of uniform random
actions (seed 0); prints env steps/s and the share of the wall time inside ``Space.step``.
The rest is Python: the simulator's bookkeeping, the env and Gymnasium's wrappers.

    python scripts/step_share.py [--steps 300] [--env evertgym/UBend-v0 ...] [--json]

For another build, put its tree first: ``git archive 199a1c1 | tar -x -C /tmp/b`` then
``PYTHONPATH=/tmp/b python scripts/step_share.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import gymnasium as gym
import numpy as np
import pymunk

from evertgym.env import register_envs

IDS = ("evertgym/UBend-v0", "evertgym/Tortuous-v0", "evertgym/Colon-v0")


def share(env_id: str, steps: int) -> dict:
    spent = [0.0]
    original = pymunk.Space.step

    def timed(self: pymunk.Space, dt: float) -> None:
        t = time.perf_counter()
        original(self, dt)
        spent[0] += time.perf_counter() - t

    pymunk.Space.step = timed  # type: ignore[method-assign]
    try:
        env = gym.make(env_id)
        rng = np.random.default_rng(0)
        env.reset(seed=0)
        t0 = time.perf_counter()
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
            if term or trunc:
                env.reset()
        wall = time.perf_counter() - t0
    finally:
        pymunk.Space.step = original  # type: ignore[method-assign]
    return {"env_id": env_id, "steps_per_s": steps / wall, "chipmunk_share": spent[0] / wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--env", action="append")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if not 1 <= args.steps <= 10**6:
        ap.error(f"--steps = {args.steps} is out of range: allowed [1, 1e6]")
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    ids = args.env or list(IDS)
    unknown = [e for e in ids if e not in register_envs()]
    if unknown:
        ap.error(f"--env = {unknown[0]!r} is not an evertgym env: allowed {', '.join(IDS)}")
    rows = [share(e, args.steps) for e in ids]
    if args.json:
        print(json.dumps(rows))
        return
    print(f"{'env_id':24s} {'steps/s':>8s} {'Space.step share':>17s}")
    for r in rows:
        print(f"{r['env_id']:24s} {r['steps_per_s']:>8.0f} {r['chipmunk_share']:>17.2f}")


if __name__ == "__main__":
    main()
