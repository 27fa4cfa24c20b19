"""The agents layer: baseline pressure policies, SB3 training and evaluation."""

from evertgym.agents.baselines import ConstantPressure, OperatorProtocol, Policy, PressureCycling, make_baseline, pressure_to_action

__all__ = ["ConstantPressure", "OperatorProtocol", "Policy", "PressureCycling", "make_baseline", "pressure_to_action"]
