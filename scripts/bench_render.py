"""Cost of one rendered frame against one env step, Colon-v0 (compliant walls, 3 bands).

    python scripts/bench_render.py [--frames 30]      (prints the table in docs/envs.md)

Grows the shipped scene for 6 s at 4 kPa, then times (median of ``--frames`` calls) a
control step, a frame of ``evertgym.render.FrameRenderer`` (what ``env.render()`` draws)
and a frame of the matplotlib drawing ``evertgym.scenes.render_rgb``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np

import evertgym  # noqa: F401  (registers the envs)
from evertgym.scenes import render_rgb


def _median_ms(fn, n: int) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=30, help="calls timed per row")
    args = ap.parse_args()
    env = gym.make("evertgym/Colon-v0", render_mode="rgb_array")
    env.reset(seed=0)
    hold = np.array([0.0], np.float32)  # 4 kPa
    for _ in range(60):
        env.step(hold)
    u = env.unwrapped
    env.render()  # builds the cached background
    step = _median_ms(lambda: env.step(hold), args.frames)
    fast = _median_ms(env.render, args.frames)
    slow = _median_ms(lambda: render_rgb(u.scene, u.sim.centreline(), u.sim.design.radius_m, handles=u.sim.scene_handles),
                      args.frames)
    print(f"{'Colon-v0, 480 x 480':34s} {'ms':>7s} {'x step':>7s}")
    for name, ms in (("env step (0.1 s simulated)", step), ("frame, evertgym.render", fast), ("frame, matplotlib render_rgb", slow)):
        print(f"{name:34s} {ms:7.1f} {ms / step:7.2f}")


if __name__ == "__main__":
    main()
