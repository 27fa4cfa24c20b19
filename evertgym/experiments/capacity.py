"""The tube-capacity check: how hard do walls push on the tip, against what the tube can carry?

Grows a robot at 8 kPa into the 20 mm U-bend, the colon, a tortuous channel and a head-on wall
and reports the largest wall force on the tip against ``p pi r_tip^2``, under the rigid-column
model and under the section law (``python -m evertgym.experiments.capacity``; asserted by
``tests/test_section_law.py``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import pymunk

from evertgym.design import TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim, SimConfig

PRESSURE_PA = 8000.0


class HeadOnWall:
    """A flat wall across the robot's path, 150 mm ahead (friction 0.5)."""

    def build(self, space: pymunk.Space, dt: float | None = None) -> None:
        seg = pymunk.Segment(space.static_body, (0.15, -0.3), (0.15, 0.3), 0.002)
        seg.friction = 0.5
        space.add(seg)


#: case -> (scene factory, robot diameter m, robot length m, run time s)
CASES: dict[str, tuple[Callable[[], Any], float, float, float]] = {
    "ubend 20 mm": (lambda: make_scene({"family": "ubend", "params": {"radius_mm": 20.0}, "seed": 0}), 0.040, 0.9, 10.0),
    "colon": (lambda: make_scene({"family": "colon", "params": {}, "seed": 0}), 0.020, 0.8, 12.0),
    "tortuous": (lambda: make_scene({"family": "tortuous", "params": {}, "seed": 3}), 0.040, 1.2, 12.0),
    "head-on wall": (HeadOnWall, 0.040, 0.6, 6.0),
}


def max_tip_force(case: str, section_law: bool) -> dict[str, Any]:
    """The largest wall force on the tip (N) over the run, the capacity ``p pi r^2`` and their ratio."""
    scene, diameter_m, length_m, run_s = CASES[case]
    t0 = time.perf_counter()
    sim = EversionSim(TubeDesign(diameter_m=diameter_m, length_m=length_m), scene=scene(),
                      config=SimConfig(engine="dynamic", section_law=section_law))
    sim.set_pressure_command(PRESSURE_PA)
    sim.run(run_s)
    capacity = PRESSURE_PA * math.pi * (diameter_m / 2) ** 2
    return {"case": case, "model": "section law" if section_law else "rigid column", "max_tip_force_n": sim.max_contact_force,
            "capacity_n": capacity, "ratio": sim.max_contact_force / capacity, "insertion_mm": sim.length * 1e3,
            "wall_s": time.perf_counter() - t0}


def main() -> None:
    """``python -m evertgym.experiments.capacity``: the table of docs/sim.md (about 1 min)."""
    print("| case | model | max tip force (N) | p pi r^2 (N) | ratio | insertion (mm) |")
    print("|---|---|---:|---:|---:|---:|")
    for case in CASES:
        for law in (False, True):
            r = max_tip_force(case, law)
            print(f"| {case} | {r['model']} | {r['max_tip_force_n']:.2f} | {r['capacity_n']:.2f} | {r['ratio']:.2f} | {r['insertion_mm']:.0f} |")


if __name__ == "__main__":
    main()
