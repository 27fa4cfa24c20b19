"""Where a compiled solve's time goes, part by part: a Newton iteration's gradient and Hessian, linear solve,
step caps and line search, and per solve the Newton solve with its friction lag, the candidate listing and the
friction entries.

Captures the first ``--windows`` solves of ``--steps`` random-action steps (seed 0) of ``--env`` on the
quasi-static default, then times each part on each captured window in a compiled loop of ``--repeats`` calls
(so with warm caches: a run's solves cost more), and prints the mean per window in microseconds.

    python scripts/kernel_parts.py                                   # UBend-v0, 400 windows
    python scripts/kernel_parts.py --env evertgym/Colon-v0 --windows 200
"""

from __future__ import annotations

import argparse
import sys
import time


def capture(env_id: str, steps: int, windows: int) -> list[tuple]:
    """The arguments of the first ``windows`` calls of the compiled solve that see a wall."""
    import gymnasium as gym
    import numpy as np

    import evertgym  # noqa: F401  (registers the envs)
    from evertgym.sim import quasistatic as qs

    env = gym.make(env_id, sim_config={"engine": "quasistatic"})
    inner = qs.qk.solve_increment
    caps: list[tuple] = []

    def keep(*args):
        if len(caps) < windows and args[0].walls.a.shape[0] > 0:
            caps.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        return inner(*args)

    qs.qk.solve_increment = keep
    rng = np.random.default_rng(0)
    try:
        env.reset(seed=0)
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32))
            if (term or trunc) and len(caps) < windows:
                env.reset()
            if len(caps) >= windows:
                break
    finally:
        qs.qk.solve_increment = inner
    env.close()
    return caps


def _drivers():
    """Compiled loops that call one part ``k`` times (built on first use: numba compiles them)."""
    import numba as nb
    import numpy as np

    from evertgym.sim.kernel.contacts import contacts, rows_where
    from evertgym.sim.kernel.friction import new_entries
    from evertgym.sim.kernel.newton import direction, line_search, solve, step_caps
    from evertgym.sim.kernel.potential import energy, grad_hess

    @nb.njit
    def newton_parts(problem, phi, u, fr, nodes, lst, rho, e0, semi, part, k):
        m, npc = phi.shape[0], u.shape[0]
        energy(problem, phi, u, nodes, lst.near, fr, lst.geo)  # (the pairs' geometry at phi, which a line search overwrites)
        g, hs = grad_hess(problem, phi, u, nodes, lst.near, fr, lst.geo, True, semi)
        step, _ = direction(hs, g, m, npc, semi, 0.0)
        scale, whole, nodes1 = step_caps(problem, phi, nodes, step, 0.002)
        slope = 0.0
        for i in range(step.shape[0]):
            slope += g[i] * step[i]
        first = nodes1 if whole else np.empty((0, 2))
        out = 0.0
        for _ in range(k):
            if part == 0:
                out += grad_hess(problem, phi, u, nodes, lst.near, fr, lst.geo, True, semi)[0][0]
            elif part == 1:
                out += direction(hs, g, m, npc, semi, 0.0)[0][0]
            elif part == 2:
                out += step_caps(problem, phi, nodes, step, 0.002)[0]
            elif part == 3:  # the line search, then the geometry at phi again (part 4 alone, subtracted)
                out += line_search(problem, fr, phi, u, nodes, e0, step, slope, scale, first, lst, rho).alpha
                out += energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
            else:
                out += energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
        return out

    @nb.njit
    def solve_parts(problem, phi, u, entries, lag, rows0, settings, part, k):
        dhat = problem.contact.dhat
        reach = 2.0 * settings.max_move + dhat
        out = 0.0
        its = 0
        for _ in range(k):
            if part == 0:
                p, uu = phi.copy(), u.copy()
                its += solve(problem, p, uu, entries, lag, settings, rows0)[1]
            elif part == 1:
                out += contacts(problem.chain, phi, problem.walls, problem.pieces.pc0, u, dhat, reach).shape[0]
            else:
                rows = rows_where(rows0, dhat)
                out += new_entries(rows, lag.s_nodes, problem.chain.seg_len, lag.robot_mu, lag.wall_mu, problem.walls,
                                   problem.pieces.pc0, u, problem.contact).s.shape[0]
        return its, out  # (out: so that no call is optimised away)

    return newton_parts, solve_parts


def measure(caps: list[tuple], repeats: int) -> dict:
    """Mean microseconds per window of each part (and the mean Newton iterations of a solve)."""
    from evertgym.sim.kernel.bundles import LagSource
    from evertgym.sim.kernel.contacts import contacts, rows_where
    from evertgym.sim.kernel.friction import resolve
    from evertgym.sim.kernel.geometry import piece_reach, window_nodes
    from evertgym.sim.kernel.newton import CANDIDATE_STEPS, listing_at, residuals
    from evertgym.sim.kernel.potential import energy, grad_hess

    newton_parts, solve_parts = _drivers()
    names = ("gradient and Hessian", "linear solve", "step caps", "line search", "energy")
    per = {n: 0.0 for n in names + ("solve with the lag", "candidate listing", "friction entries")}
    iterations = 0
    timed = 0
    for problem, phi, phi_ref, u, u_ref, s_nodes, robot_mu, wall_mu, entries, settings in caps:
        chain, dhat = problem.chain, problem.contact.dhat
        rows0 = contacts(chain, phi, problem.walls, problem.pieces.pc0, u, dhat, CANDIDATE_STEPS * settings.max_move + dhat)
        lag = LagSource(window_nodes(chain, phi_ref), u_ref, s_nodes, robot_mu, wall_mu)
        fr = resolve(entries, lag.start_nodes, s_nodes, chain.seg_len, problem.walls.piece, problem.pieces.pc0, u_ref)
        nodes = window_nodes(chain, phi)
        lst = listing_at(rows_where(rows0, dhat + CANDIDATE_STEPS * settings.max_move), nodes, u, dhat)
        rho = piece_reach(problem.walls, u.shape[0])
        e0 = energy(problem, phi, u, nodes, lst.near, fr, lst.geo)
        g, _ = grad_hess(problem, phi, u, nodes, lst.near, fr, lst.geo, False, settings.semi)
        if residuals(g, len(phi), u.shape[0])[0] <= settings.tol_m:
            continue  # converged at its start: no Newton step to time
        args = (problem, phi, u, fr, nodes, lst, rho, e0, settings.semi)
        try:
            newton_parts(*args, 0, 0)
        except ZeroDivisionError:  # a singular Newton matrix without the solver's shift: not a timeable step
            continue
        timed += 1
        for part, name in enumerate(names):  # one part at a time: the loop's time over the repeats, less its set-up's
            newton_parts(*args, part, 1)
            t0 = time.perf_counter()
            newton_parts(*args, part, 0)
            base = time.perf_counter() - t0
            t0 = time.perf_counter()
            newton_parts(*args, part, repeats)
            per[name] += max(0.0, time.perf_counter() - t0 - base) / repeats
        for part, name in enumerate(("solve with the lag", "candidate listing", "friction entries")):
            sargs = (problem, phi, u, entries, lag, rows0, settings, part)
            solve_parts(*sargs, 1)
            t0 = time.perf_counter()
            its, _ = solve_parts(*sargs, repeats)
            per[name] += (time.perf_counter() - t0) / repeats
            if part == 0:
                iterations += its / repeats
    per["line search"] -= per["energy"]
    n = max(timed, 1)
    return {"windows": timed, "captured": len(caps), "us": {k: 1e6 * v / n for k, v in per.items()}, "iterations": iterations / n,
            "joints": sum(len(c[1]) for c in caps) / len(caps)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="evertgym/UBend-v0", help="a registered env id")
    ap.add_argument("--steps", type=int, default=200, help="random-action steps to capture windows from, [1, 100000]")
    ap.add_argument("--windows", type=int, default=400, help="solves captured and timed, [1, 10000]")
    ap.add_argument("--repeats", type=int, default=10, help="calls per part and window, [1, 1000]")
    args = ap.parse_args(argv)
    for name, value, hi in (("--steps", args.steps, 100000), ("--windows", args.windows, 10000), ("--repeats", args.repeats, 1000)):
        if not 1 <= value <= hi:
            print(f"{name} = {value} is out of range: allowed [1, {hi}]", file=sys.stderr)
            return 2
    import gymnasium as gym

    import evertgym  # noqa: F401

    if args.env not in gym.registry:
        print(f"--env = {args.env!r} is not an env id: allowed {', '.join(k for k in gym.registry if k.startswith('evertgym/'))}",
              file=sys.stderr)
        return 2
    caps = capture(args.env, args.steps, args.windows)
    if not caps:
        print(f"{args.env}: no solve met a wall in {args.steps} steps: nothing to time", file=sys.stderr)
        return 1
    r = measure(caps, args.repeats)
    print(f"{args.env}: {r['windows']} of {r['captured']} captured windows (the others converged at their start or had "
          f"a singular Newton matrix) of {r['joints']:.0f} joints on average, each part called {args.repeats} times in a "
          f"compiled loop (warm caches); mean us per window")
    print("per Newton iteration:")
    for name in ("gradient and Hessian", "linear solve", "step caps", "line search", "energy"):
        print(f"  {name:22s} {r['us'][name]:8.1f}" + ("  (one evaluation; the line search makes one or more)" if name == "energy" else ""))
    print("per solve:")
    print(f"  {'solve with the lag':22s} {r['us']['solve with the lag']:8.1f}  ({r['iterations']:.1f} Newton iterations)")
    for name in ("candidate listing", "friction entries"):
        print(f"  {name:22s} {r['us'][name]:8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
