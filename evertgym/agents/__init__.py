"""The agents layer: baseline pressure policies, SB3 training and evaluation."""

from evertgym.agents.baselines import (
    ConstantPressure,
    DeflateOnStall,
    OperatorProtocol,
    Policy,
    PressureCycling,
    pressure_to_action,
)
from evertgym.agents.load import load_policy
from evertgym.agents.policies import make_baseline, make_policy, policy_cards, shipped_policies

__all__ = [
    "ConstantPressure", "DeflateOnStall", "OperatorProtocol", "Policy", "PressureCycling", "load_policy", "make_baseline", "make_policy",
    "policy_cards", "pressure_to_action", "shipped_policies",
]
