"""The sim layer: a 2-D pymunk eversion simulator calibrated from the rod model."""

from evertgym.sim.config import SimConfig, parse_sim
from evertgym.sim.simulator import EversionSim, NumericalInstabilityError

__all__ = ["EversionSim", "NumericalInstabilityError", "SimConfig", "parse_sim"]
