"""The two linear solvers of a quasi-static Newton step side by side, on the systems an env really makes.

Plays ``--steps`` random-action steps (seed 0) of the env on the quasi-static engine's dense solver (the default
when docs/quasistatic.md's figures of this script were made, so that they regenerate) and keeps the starting state
of every ``--every``-th solve with at least ``--min-iterations`` Newton iterations (the contact increments, where
the solves cost most).  At each kept state it assembles the Newton system twice, as the dense solver
(``linear_solver="dense"``: the joints' block dense, the compliant wall pieces eliminated by a dense Schur
complement) and as the O(m) solver (``"semiseparable"``: generators, the pieces' couplings as records), solves it
from a Levenberg shift of zero and of one, and prints per state: the window's joints, pieces and wall features (and
the candidate contact pairs within a step's reach), how many coupled
pieces touch one segment, two adjacent ones or more, whether the two solvers chose the same shift, how far their
steps differ (relative to the step), and the time of each solve and assembly (best of ``--repeats`` calls).

    python scripts/linear_solves.py                                   # Colon-v0, 150 steps
    python scripts/linear_solves.py --env evertgym/UBend-v0 --steps 300
"""

from __future__ import annotations

import argparse
import sys
import time


def _best_us(fn, args: tuple, repeats: int) -> float:
    fn(*args)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best * 1e6


def _copied(value):
    """``value`` with every array in it (nested in the kernel's bundles) copied."""
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, tuple):
        items = [_copied(v) for v in value]
        return type(value)(*items) if hasattr(value, "_fields") else tuple(items)
    return value


def capture(env_id: str, steps: int, min_iterations: int, every: int, limit: int) -> list[tuple]:
    """The arguments of the kept solves (copied before the solve changes them)."""
    import gymnasium as gym
    import numpy as np

    import evertgym  # noqa: F401  (registers the envs)
    from evertgym.sim import quasistatic as qs

    env = gym.make(env_id, sim_config={"engine": "quasistatic", "linear_solver": "dense"})
    env.reset(seed=0)
    inner = qs.qk.solve_increment
    kept: list[tuple] = []
    seen = [0]

    def keep(*args):
        start = _copied(args)
        out = inner(*args)
        if out.iterations >= min_iterations and len(kept) < limit:
            if seen[0] % every == 0:
                kept.append(start)
            seen[0] += 1
        return out

    qs.qk.solve_increment = keep
    rng = np.random.default_rng(0)
    try:
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
            if term or trunc:
                env.reset()
    finally:
        qs.qk.solve_increment = inner
    env.close()
    return kept


def compare(args: tuple, repeats: int) -> dict:
    """Both solvers at one kept state (see the module's docstring)."""
    import numpy as np

    from evertgym.sim import kernel as qk
    from evertgym.sim.kernel import linear, newton, potential
    from evertgym.sim.kernel.contacts import rows_to_pairs, rows_where
    from evertgym.sim.kernel.friction import resolve

    problem, phi, phi_ref, u, u_ref, s_nodes, _robot_mu, _wall_mu, entries, settings = args
    chain, walls, dhat = problem.chain, problem.walls, problem.contact.dhat
    start_nodes, _ = qk.chain_nodes(chain.theta0, chain.n0, phi_ref, chain.seg_len)
    fr = resolve(entries, start_nodes, s_nodes, chain.seg_len, walls.piece, problem.pieces.pc0, u_ref)
    rows = qk.contacts(chain, phi, walls, problem.pieces.pc0, u, dhat, 2.0 * settings.max_move + dhat)
    near = rows_to_pairs(rows_where(rows, dhat + newton.NEAR_MARGIN_M))
    nodes, _ = qk.chain_nodes(chain.theta0, chain.n0, phi, chain.seg_len)
    geo = np.empty((len(near), 11))
    common = (problem, phi, u, nodes, near, fr, geo)
    potential.energy(*common)
    grad, (hess, _, hjp, hpp) = potential.grad_hess(*common, True, False)
    grad2, (_, gen, rec, hpp2) = potential.grad_hess(*common, True, True)
    m, npc = len(phi), len(u)
    wa = walls.a
    lo: dict[int, int] = {}
    hi: dict[int, int] = {}
    for r in rec:
        p, k = int(r[0]), int(r[1])
        lo[p] = min(lo.get(p, k), k)
        hi[p] = max(hi.get(p, k), k)
    spans = [hi[p] - lo[p] for p in lo]
    out = {"joints": m, "pieces": npc, "features": len(wa), "candidates": len(rows), "one_segment": spans.count(0), "two_segments": spans.count(1),
           "wider": sum(1 for s in spans if s > 1), "same_gradient": bool(np.array_equal(grad, grad2))}
    for mu0 in (0.0, 1.0):
        x_d, mu_d = linear.schur_solve(hess, hjp, hpp, -grad, m, npc, mu0)
        x_s, mu_s = linear.semi_schur_solve(gen, rec, hpp2, -grad, m, npc, mu0)
        tag = "from_zero" if mu0 == 0.0 else "from_one"
        out[f"same_shift_{tag}"] = bool(mu_d == mu_s)
        out[f"step_difference_{tag}"] = float(np.max(np.abs(x_d - x_s)) / max(np.max(np.abs(x_d)), 1e-300))
        out[f"dense_us_{tag}"] = _best_us(linear.schur_solve, (hess, hjp, hpp, -grad, m, npc, mu0), repeats)
        out[f"semi_us_{tag}"] = _best_us(linear.semi_schur_solve, (gen, rec, hpp2, -grad, m, npc, mu0), repeats)
    out["assembly_dense_us"] = _best_us(potential.grad_hess, (*common, True, False), repeats)
    out["assembly_semi_us"] = _best_us(potential.grad_hess, (*common, True, True), repeats)
    return out


def _positive_int(name: str, value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        v = 0
    if v < 1:
        sys.exit(f"{name} = {value!r} is out of range: allowed a whole number >= 1")
    return v


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", default="evertgym/Colon-v0", help="env id (default Colon-v0)")
    ap.add_argument("--steps", default="150", help="random-action steps (default 150)")
    ap.add_argument("--min-iterations", default="12", help="keep solves with at least this many Newton iterations (default 12)")
    ap.add_argument("--every", default="1", help="keep every N-th such solve (default 1)")
    ap.add_argument("--limit", default="40", help="at most this many states (default 40)")
    ap.add_argument("--repeats", default="200", help="timed calls per solve, the best kept (default 200)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    steps = _positive_int("--steps", args.steps)
    min_it = _positive_int("--min-iterations", args.min_iterations)
    every = _positive_int("--every", args.every)
    limit = _positive_int("--limit", args.limit)
    repeats = _positive_int("--repeats", args.repeats)
    import gymnasium as gym

    import evertgym  # noqa: F401

    if args.env not in gym.registry:
        sys.exit(f"--env = {args.env!r} is not a registered env id: allowed one of "
                 + ", ".join(sorted(k for k in gym.registry if k.startswith("evertgym/"))))
    rows = [compare(a, repeats) for a in capture(args.env, steps, min_it, every, limit)]
    if args.json:
        import json

        print(json.dumps({"env": args.env, "steps": steps, "states": rows}))
        return 0
    print(f"{args.env}: {len(rows)} states (solves with >= {min_it} Newton iterations in {steps} random-action steps)")
    print("joints pieces features pairs  1-seg 2-seg wider  same shift  step diff  | solve from 0 (us)  solve from 1 (us)"
          "  assembly (us)")
    print("                                                 (0 / 1)                  |  dense  O(m)        dense  O(m)"
          "        dense  O(m)")
    for r in rows:
        print(f"{r['joints']:6d} {r['pieces']:6d} {r['features']:8d} {r['candidates']:5d}"
              f"  {r['one_segment']:5d} {r['two_segments']:5d} {r['wider']:5d}"
              f"  {'yes' if r['same_shift_from_zero'] else 'NO':>4} / {'yes' if r['same_shift_from_one'] else 'NO':<4}"
              f"  {max(r['step_difference_from_zero'], r['step_difference_from_one']):9.1e}  |"
              f" {r['dense_us_from_zero']:6.1f} {r['semi_us_from_zero']:5.1f}      {r['dense_us_from_one']:6.1f}"
              f" {r['semi_us_from_one']:5.1f}      {r['assembly_dense_us']:6.1f} {r['assembly_semi_us']:5.1f}")
    if rows:
        same = sum(r["same_shift_from_zero"] and r["same_shift_from_one"] for r in rows)
        worst = max(max(r["step_difference_from_zero"], r["step_difference_from_one"]) for r in rows)
        print(f"same shift in {same} of {len(rows)} states; largest step difference {worst:.1e} of the step")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
