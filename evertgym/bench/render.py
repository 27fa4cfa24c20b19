"""Cost of one rendered frame against one env step, Colon-v0 (compliant walls, 3 bands).

    evertgym bench render [--frames 30]      (prints the table in docs/envs.md)

Grows the shipped scene for 2 s at 4 kPa, then times (median of ``--frames`` calls) a
control step, a frame of ``evertgym.render.FrameRenderer`` (what ``env.render()`` draws)
and a frame of the matplotlib drawing ``evertgym.scenes.render_rgb``.
"""

from __future__ import annotations

import statistics
import time


def _median_ms(fn, n: int) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def bench_render(frames: int = 30) -> list[dict]:
    """Median ms of an env step, of a fast frame and of a matplotlib frame (``frames`` calls each), and
    each against the step."""
    import gymnasium as gym
    import numpy as np

    from evertgym.env import register_envs
    from evertgym.scenes import render_rgb

    if not (isinstance(frames, int) and frames >= 1):
        raise ValueError(f"frames = {frames!r} is out of range: allowed integers >= 1")
    register_envs()
    env = gym.make("evertgym/Colon-v0", render_mode="rgb_array")
    env.reset(seed=0)
    hold = np.array([0.0], np.float32)  # 4 kPa
    for _ in range(20):  # 2 s in: the robot is in the channel and far from the goal
        env.step(hold)
    u = env.unwrapped
    env.render()  # builds the cached background
    step = _median_ms(lambda: env.step(hold), frames)
    fast = _median_ms(env.render, frames)
    slow = _median_ms(lambda: render_rgb(u.scene, u.sim.centreline(), u.sim.design.radius_m,  # type: ignore[attr-defined]
                                         handles=u.sim.scene_handles), frames)  # type: ignore[attr-defined]
    env.close()
    return [{"what": name, "ms": ms, "x_step": ms / step} for name, ms in
            (("env step (0.1 s simulated)", step), ("frame, evertgym.render", fast), ("frame, matplotlib render_rgb", slow))]


def format_render(rows: list[dict]) -> list[str]:
    return [f"{'Colon-v0, 480 x 480':34s} {'ms':>7s} {'x step':>7s}"] + [f"{r['what']:34s} {r['ms']:7.1f} {r['x_step']:7.2f}" for r in rows]
