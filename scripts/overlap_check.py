"""Does the robot ever overlap a wall?  Random-action steps of an env on the quasi-static engine,
checking after every step the committed state's smallest robot-wall gap over every wall of the
scene (not only those a solve was given).

A committed state that overlaps a wall is a defect: every later solve starts infeasible and is
refused, so the body stands still until the episode times out.  Before c95c072 a solve that moved
the body by more than its first contact candidates reach (a snap-through) could pass through a
wall; this script found it.

    python scripts/overlap_check.py --env evertgym/Colon-v0 --steps 300 --seed 1 --sim '{"growth_increment_m": 0.002}'
    python scripts/overlap_check.py --env evertgym/Tortuous-v0 --steps 200 --seed 0
    PYTHONPATH=/path/to/a/git-archive python scripts/overlap_check.py ...     # another build
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def smallest_gap(sim) -> tuple[float, int, int]:
    """The committed state's smallest gap (m) between a robot segment and any wall feature, with the
    segment and the feature (1 m and -1, -1 if no feature is within 10 mm)."""
    from evertgym.sim import kernel as qk

    nodes = sim.centreline()
    w = sim._walls
    chain = qk.Chain(sim.base_angle, nodes[0].copy(), sim.seg_len.copy(), sim.seg_rad.copy())
    rows = qk.contacts(chain, sim.phi.copy(), qk.Walls(w.a, w.b, w.piece, w.vertex, w.radius), sim._pc0, sim._u_all, 1e-3, 0.01)
    if len(rows) == 0:
        return 1.0, -1, -1
    i = int(np.argmin(rows[:, 10]))
    return float(rows[i, 10]), int(rows[i, 0]), int(rows[i, 1])


def check(env_id: str, steps: int, seed: int, sim_config: dict) -> dict:
    """Play ``steps`` uniform random actions (``numpy`` generator ``seed``; the env reset with
    ``seed``) and report each episode's end and the first overlapping state."""
    import gymnasium as gym

    import evertgym  # noqa: F401  (registers the envs)

    env = gym.make(env_id, sim_config={"engine": "quasistatic", **sim_config})
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    episodes, first, worst, episode, frozen_from = [], None, 1.0, 0, None
    for i in range(steps):
        _, _, term, trunc, info = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        sim = env.unwrapped.sim
        gap, seg, wall = smallest_gap(sim)
        worst = min(worst, gap)
        if gap < 0 and first is None:
            first = {"step": i, "episode": episode, "gap_mm": 1e3 * gap, "segment": seg, "wall": wall,
                     "insertion_mm": info["insertion_length_mm"], "solves": info["solves"]}
            frozen_from = info["solves"]
        if term or trunc:
            episodes.append({"episode": episode, "end_step": i, "outcome": info["outcome"],
                             "insertion_mm": round(info["insertion_length_mm"], 1), "solves": info["solves"],
                             "solve_failures": info["solve_failures"]})
            if first is not None and first["episode"] == episode:
                first["solves_after"] = info["solves"] - frozen_from
            env.reset()
            episode += 1
    if first is not None and "solves_after" not in first:
        first["solves_after"] = info["solves"] - frozen_from
    return {"env_id": env_id, "steps": steps, "seed": seed, "sim": sim_config, "episodes": episodes,
            "smallest_gap_mm": 1e3 * worst, "first_overlap": first}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="evertgym/Colon-v0")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sim", default=None, help="quasi-static SimConfig fields as JSON")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not 1 <= args.steps <= 100000:
        ap.error(f"--steps = {args.steps} is out of range: allowed [1, 100000]")
    from evertgym.sim.config import parse_sim

    try:
        sim = parse_sim(args.sim, engine="quasistatic")
    except ValueError as e:
        ap.exit(2, f"--sim: {e}\n")
    sim.pop("engine", None)
    out = check(args.env, args.steps, args.seed, sim)
    if args.json:
        print(json.dumps(out, indent=1))
        return out
    print(f"{out['env_id']}, {args.steps} random-action steps (seed {args.seed}), settings {json.dumps(sim) if sim else 'default'}")
    for e in out["episodes"]:
        print(f"  episode {e['episode']}: ends at step {e['end_step']}, {e['outcome']} at {e['insertion_mm']} mm, "
              f"{e['solves']} solves, {e['solve_failures']} above the tolerance")
    print(f"smallest robot-wall gap of any committed state: {out['smallest_gap_mm']:.3f} mm")
    f = out["first_overlap"]
    if f:
        print(f"first overlap: step {f['step']} (episode {f['episode']}, {f['insertion_mm']:.1f} mm grown), gap {f['gap_mm']:.3f} mm "
              f"(segment {f['segment']}, wall feature {f['wall']}); solves in the rest of that episode: {f['solves_after']}")
    else:
        print("no committed state overlaps a wall")
    return out


if __name__ == "__main__":
    main()
