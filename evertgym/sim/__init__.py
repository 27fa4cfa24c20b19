"""The sim layer: a growing eversion robot in a 2-D scene, on two engines behind one interface,
:class:`EversionSim`: :class:`QuasiStaticSim` (the default) and the dynamic pymunk chain, :class:`DynamicSim`.
``EversionSim(design, scene, config)`` builds the one ``config.engine`` names (both are imported here, so
both are known to it)."""

from evertgym.sim.config import SimConfig, parse_sim
from evertgym.sim.quasistatic import QuasiStaticSim
from evertgym.sim.simulator import DynamicSim, NumericalInstabilityError
from evertgym.sim.tube import EversionSim

__all__ = ["DynamicSim", "EversionSim", "NumericalInstabilityError", "QuasiStaticSim", "SimConfig", "parse_sim"]
