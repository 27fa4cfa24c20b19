"""Where the quasi-static engine's compiled solve spends its time: solves by their Newton iterations.

Plays ``--steps`` random-action steps (seed 0) of each env on the quasi-static default, timing every call
of the compiled solve (:func:`evertgym.sim.kernel.newton.solve_increment`, its friction lag included), and
prints the solves grouped by their Newton iterations: how many, their share of the iterations and of the
compiled time, their friction-lag refreshes per solve, and the share of the run's wall time spent outside
the compiled solve (the engine's and the env's Python).

    python scripts/solve_iterations.py                          # UBend-v0 300 steps, Colon-v0 150
    python scripts/solve_iterations.py --env evertgym/Tortuous-v0 --steps 200
"""

from __future__ import annotations

import argparse
import sys
import time

_BUCKETS = ((0, 1), (1, 8), (8, 13), (13, 20), (20, 40), (40, 80), (80, 10**9))


def measure(env_id: str, steps: int, sim: dict | None = None) -> dict:
    """Per-solve iterations and compiled time of ``steps`` random-action steps of ``env_id`` (``sim``: further
    quasi-static SimConfig fields)."""
    import gymnasium as gym
    import numpy as np

    import evertgym  # noqa: F401  (registers the envs)
    from evertgym.sim import quasistatic as qs

    env = gym.make(env_id, sim_config={**(sim or {}), "engine": "quasistatic"})
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, np.float32))  # compile (or load) the kernel outside the timing
    env.reset(seed=0)
    inner = qs.qk.solve_increment
    iters: list[int] = []
    times: list[float] = []
    windows: list[int] = []
    refreshes: list[int] = []

    def timed(*args):
        t0 = time.perf_counter()
        out = inner(*args)
        times.append(time.perf_counter() - t0)
        iters.append(int(out.iterations))
        refreshes.append(int(out.refreshes))
        windows.append(len(args[1]))  # phi
        return out

    qs.qk.solve_increment = timed
    rng = np.random.default_rng(0)
    try:
        t0 = time.perf_counter()
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
            if term or trunc:
                env.reset()
        wall = time.perf_counter() - t0
    finally:
        qs.qk.solve_increment = inner
    env.close()
    it, t, rf = np.array(iters), np.array(times), np.array(refreshes)
    rows = []
    for lo, hi in _BUCKETS:
        s = (it >= lo) & (it < hi)
        rows.append({"iterations": f"{lo}" if hi == lo + 1 else (f"{lo}+" if hi > 10**6 else f"{lo}-{hi - 1}"),
                     "solves": int(s.sum()), "time_share": float(t[s].sum() / t.sum()) if t.sum() else 0.0,
                     "iteration_share": float(it[s].sum() / it.sum()) if it.sum() else 0.0,
                     "refreshes_per_solve": float(rf[s].mean()) if s.any() else 0.0})
    return {"env_id": env_id, "steps": steps, "steps_per_s": steps / wall, "solves": len(it),
            "iterations_per_solve": float(it.mean()) if len(it) else 0.0,
            "refreshes_per_solve": float(rf.mean()) if len(rf) else 0.0, "joints_per_solve": float(np.mean(windows)) if windows else 0.0,
            "compiled_share": float(t.sum() / wall), "buckets": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", action="append", help="env id (repeatable; default UBend-v0 and Colon-v0)")
    ap.add_argument("--steps", type=int, default=0, help="random-action steps per env (default 300 for UBend-v0, 150 otherwise)")
    ap.add_argument("--sim", default="", help="quasi-static SimConfig fields as JSON, e.g. '{\"linear_solver\": \"dense\"}' "
                    "(the solver the docs' tables of 2026-12-05 were made with)")
    args = ap.parse_args(argv)
    from evertgym.sim.config import parse_sim

    try:
        sim = parse_sim(args.sim, engine="quasistatic")
    except ValueError as e:
        print(f"--sim: {e}", file=sys.stderr)
        return 2
    if args.steps < 0:
        print(f"--steps = {args.steps} is out of range: allowed 1 or more (0: the default)", file=sys.stderr)
        return 2
    import gymnasium as gym

    import evertgym  # noqa: F401  (registers the envs)

    for env_id in args.env or []:
        if env_id not in gym.registry:
            print(f"--env = {env_id!r} is not an env id: allowed one of {sorted(k for k in gym.registry if k.startswith('evertgym/'))}",
                  file=sys.stderr)
            return 2
    for env_id in args.env or ["evertgym/UBend-v0", "evertgym/Colon-v0"]:
        steps = args.steps or (300 if "UBend" in env_id else 150)
        r = measure(env_id, steps, sim)
        print(f"{env_id}: {steps} steps, {r['steps_per_s']:.0f} steps/s, {r['solves']} solves, {r['iterations_per_solve']:.2f} Newton "
              f"iterations and {r['refreshes_per_solve']:.2f} friction-lag refreshes per solve, {r['joints_per_solve']:.1f} joints per "
              f"window; the compiled solve is {100 * r['compiled_share']:.0f}% of the wall time")
        print("  iterations   solves   share of the iterations   of the compiled time   lag refreshes per solve")
        for b in r["buckets"]:
            print(f"  {b['iterations']:>10s} {b['solves']:8d}   {100 * b['iteration_share']:22.1f}%   {100 * b['time_share']:19.1f}%"
                  f"   {b['refreshes_per_solve']:23.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
