"""Runs accepted fuzz inputs in a separate process (an interpreter abort must not take the
test run down): reads one JSON line per input, answers ``ok`` or ``error: <message>``."""

import json
import sys

from evertgym.design import TubeDesign
from evertgym.env import EversionEnv
from evertgym.scenes import make_scene
from evertgym.sim import EversionSim


def run(kind: str, data) -> None:
    if kind == "design":
        sim = EversionSim(TubeDesign.from_dict(data))
        sim.set_pressure_command(4000.0)
        sim.run(0.1)
    elif kind == "scene":
        scene = make_scene(data)
        sim = EversionSim(TubeDesign(diameter_m=0.004, wall_thickness_m=0.05e-3, length_m=0.3), scene=scene)
        sim.set_pressure_command(4000.0)
        sim.run(0.1)
    else:
        env = EversionEnv(**data)
        env.reset(seed=0)
        for a in (0.5, 1.0):
            _, _, terminated, truncated, _ = env.step([a])
            if terminated or truncated:  # (step() after the end raises until reset())
                break


for line in sys.stdin:
    msg = json.loads(line)
    try:
        run(msg["kind"], msg["input"])
        print("ok", flush=True)
    except ValueError as e:  # the package's validation errors: allowed
        print("error: " + " ".join(str(e).split()), flush=True)
