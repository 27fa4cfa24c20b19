"""Residual policies: a learned correction on top of a rule (residual RL).

A residual policy acts ``clip(a_rule + scale x a_learned, -1, 1)`` in the env's absolute-pressure
action (``p = (a + 1) / 2 x 8 kPa``, so ``scale`` 0.25 lets it move the rule's command by at most
1 kPa).  It starts where the rule is (a learned action of 0 is the rule's action) and learns what
to change (Johannink et al., "Residual Reinforcement Learning for Robot Control", ICRA 2019;
Silver et al., "Residual Policy Learning", 2018).  The learner observes the env's observation with
the rule's action appended, so it knows what it corrects.  The rule reads what it reads without a
residual (for the operator baselines: the insertion length and the clock), so a residual on an
operator-only rule is operator-only too.

A training config names the rule and the scale (``residual = "tuned"``, ``residual_scale = 0.25``);
the trained model's ``final_env.json`` carries them, and :class:`~evertgym.agents.policies.SB3Policy`
plays the model with its rule, so ``evertgym eval`` and ``rollout`` take a residual model like any
other.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from evertgym.agents.baselines import BASELINES, Policy
from evertgym.agents.describe import for_env, make_baseline, policy_desc
from evertgym.sim.growth import MAX_PRESSURE_PA

#: the largest ``residual_scale`` accepted (action units; 2 spans the whole action range)
MAX_RESIDUAL_SCALE = 2.0


def check_residual(spec: Any) -> dict | None:
    """``{"rule": description, "scale": s}`` from a config's or a model's ``residual`` entry (None
    without one); a one-line ``ValueError`` naming the field otherwise.  ``rule`` is a baseline's
    description as the CLI spells it (``"tuned"``, ``"operator"``,
    ``"cycle:low_kpa=0,high_kpa=3,period_s=1"``); a trained model is refused (a residual on a
    residual is not supported)."""
    if spec is None:
        return None
    if not isinstance(spec, dict) or set(spec) - {"rule", "scale"} or "rule" not in spec:
        raise ValueError(f"residual = {spec!r} is not allowed: allowed {{'rule': a baseline, 'scale': a number in "
                         f"(0, {MAX_RESIDUAL_SCALE:g}]}}")
    rule = spec["rule"]
    name = policy_desc(rule).get("name") if isinstance(rule, (str, dict)) else None
    if name not in set(BASELINES) | {"tuned"}:
        raise ValueError(f"residual = {rule!r} is out of range: allowed a baseline ({', '.join(sorted(BASELINES) + ['tuned'])}, "
                         "with parameters as the CLI spells them)")
    scale = spec.get("scale", 0.25)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0.0 < float(scale) <= MAX_RESIDUAL_SCALE:
        raise ValueError(f"residual_scale = {scale!r} is out of range: allowed (0, {MAX_RESIDUAL_SCALE:g}] (action units; "
                         "0.25 is 1 kPa)")
    return {"rule": rule, "scale": float(scale)}


def make_rule(spec: dict, env_id: str) -> Policy:
    """The rule of a residual ``spec`` (:func:`check_residual`) as it acts on ``env_id`` (``tuned``
    takes the parameters tuned on that env)."""
    desc = for_env(spec["rule"], env_id)
    return make_baseline(desc.pop("name"), **desc)


def combine(base: np.ndarray, learned: np.ndarray, scale: float) -> np.ndarray:
    """The action played: ``clip(base + scale x learned, -1, 1)`` (float32, shape (1,))."""
    a = np.asarray(base, dtype=np.float64).reshape(1) + scale * np.asarray(learned, dtype=np.float64).reshape(1)
    return np.clip(a, -1.0, 1.0).astype(np.float32)


def with_base(obs: np.ndarray, base: np.ndarray) -> np.ndarray:
    """The learner's observation: the env's with the rule's action appended."""
    return np.concatenate([np.asarray(obs, dtype=np.float32).reshape(-1), np.asarray(base, dtype=np.float32).reshape(1)])


class ResidualOnRule(gym.Wrapper):
    """An env whose action is a correction of ``rule``'s (:func:`combine`) and whose observation
    carries the rule's action last (:func:`with_base`).  ``info["rule_command_kpa"]`` is the rule's
    command for the next step."""

    def __init__(self, env: gym.Env, rule: Policy, scale: float):
        super().__init__(env)
        self.rule, self.scale = rule, float(scale)
        space = env.observation_space
        assert isinstance(space, gym.spaces.Box)
        low, high = space.low, space.high
        self.observation_space = gym.spaces.Box(np.append(low, -1.0).astype(np.float32), np.append(high, 1.0).astype(np.float32),
                                                dtype=np.float32)
        self._base = np.zeros(1, np.float32)

    def _observe(self, obs: np.ndarray, info: dict) -> np.ndarray:
        self._base = np.asarray(self.rule.act(obs, info), dtype=np.float32).reshape(1)
        info["rule_command_kpa"] = float((self._base[0] + 1.0) / 2.0 * MAX_PRESSURE_PA / 1e3)
        return with_base(obs, self._base)

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self.rule.reset(self.env)
        return self._observe(obs, info), info

    def step(self, action):
        obs, reward, term, trunc, info = self.env.step(combine(self._base, action, self.scale))
        return self._observe(obs, info), reward, term, trunc, info
