"""Baseline pressure policies with the interface every evertgym policy has.

A policy is reset at the start of each episode with the env (so it knows the control
period) and maps the env's observation and info to an action in [-1, 1] (absolute
pressure mode: ``p = (a + 1) / 2 * 8 kPa``).  Baselines read only what an operator sees:
the measured insertion length (``info["insertion_length_mm"]``) and the clock.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from evertgym._validate import check_range
from evertgym.sim.growth import MAX_PRESSURE_PA


def pressure_to_action(pressure_kpa: float) -> np.ndarray:
    """The absolute-mode action for a pressure command (kPa)."""
    return np.array([2.0 * pressure_kpa * 1e3 / MAX_PRESSURE_PA - 1.0], dtype=np.float32)


class Policy(ABC):
    """Interface: ``reset(env)`` then ``act(obs, info) -> action`` each control step."""

    name = "policy"

    @property
    def max_command_kpa(self) -> float:
        """The highest pressure (kPa) this policy ever commands: a robot stalled at it will
        get no more help (scored trials give up on it).  The seal's 8 kPa unless capped."""
        return MAX_PRESSURE_PA / 1e3

    def reset(self, env) -> None:
        self.dt = env.unwrapped.control_dt

    @abstractmethod
    def act(self, obs: np.ndarray, info: dict) -> np.ndarray:
        """The action in [-1, 1] for this control step."""


def run_episode(env: Any, policy: Policy, seed: int, options: dict | None = None,
                stop: Callable[[Any, dict], bool] | None = None) -> dict:
    """Play one episode of ``env`` under ``policy`` from ``reset(seed, options)``; returns the
    last step's ``info``.  ``stop(env, info)``, called after every step, may end it early."""
    obs, info = env.reset(seed=seed, options=options)
    policy.reset(env)
    while True:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        if term or trunc or (stop is not None and stop(env, info)):
            return info


@dataclass
class ConstantPressure(Policy):
    """Hold one pressure (kPa) for the whole episode (the paper's U-bend protocol at 3 kPa)."""

    pressure_kpa: float = 3.0
    name: str = field(default="constant", init=False)

    def __post_init__(self) -> None:
        check_range("pressure_kpa", self.pressure_kpa, 0.0, 8.0, unit="kPa")

    @property
    def max_command_kpa(self) -> float:
        return self.pressure_kpa

    def act(self, obs, info):
        return pressure_to_action(self.pressure_kpa)


@dataclass
class OperatorProtocol(Policy):
    """The paper's operator (colon case study): start low, raise the pressure gradually
    whenever progress stalls, up to 8 kPa.

    Progress stalls when the insertion length grew by less than ``stall_mm`` over the
    last ``stall_s`` seconds; the command then rises by ``step_kpa`` (and the window
    restarts).  With ``relax_kpa_per_s > 0`` the command eases back towards
    ``start_kpa`` while the robot is moving (the paper's operator kept 2-4 kPa on straight
    sections); the default holds it.
    """

    start_kpa: float = 2.0
    step_kpa: float = 0.5
    stall_s: float = 1.0
    stall_mm: float = 2.0
    max_kpa: float = 8.0
    relax_kpa_per_s: float = 0.0
    name: str = field(default="operator", init=False)

    def __post_init__(self) -> None:
        check_range("start_kpa", self.start_kpa, 0.0, 8.0, unit="kPa")
        check_range("step_kpa", self.step_kpa, 0.0, 8.0, unit="kPa")
        check_range("stall_s", self.stall_s, 0.0, 60.0, unit="s")
        check_range("stall_mm", self.stall_mm, 0.0, 1000.0, unit="mm")
        check_range("max_kpa", self.max_kpa, 0.0, 8.0, unit="kPa")
        check_range("relax_kpa_per_s", self.relax_kpa_per_s, 0.0, 100.0, unit="kPa/s")

    @property
    def max_command_kpa(self) -> float:
        return self.max_kpa

    def reset(self, env) -> None:
        super().reset(env)
        self.p = self.start_kpa
        self.window: list[float] = []

    def act(self, obs, info):
        self.window.append(float(info["insertion_length_mm"]))
        n = max(1, int(round(self.stall_s / self.dt)))
        if len(self.window) > n:
            self.window = self.window[-(n + 1) :]
            if self.window[-1] - self.window[0] < self.stall_mm:
                self.p = min(self.p + self.step_kpa, self.max_kpa)
                self.window = self.window[-1:]
            elif self.relax_kpa_per_s > 0:
                self.p = max(self.start_kpa, self.p - self.relax_kpa_per_s * self.dt)
        return pressure_to_action(self.p)


@dataclass
class PressureCycling(Policy):
    """Open-loop pressure cycling: a square wave of the control clock, ``high_kpa`` for the
    first ``duty`` fraction of every ``period_s`` seconds, ``low_kpa`` for the rest.

    Deflating lets a tip jammed against a wall relax and turn before the next inflation
    pushes it on; it needs neither sensing nor a model.  Only a low level below the
    eversion threshold deflates the robot: the default 1 kPa <-> 8 kPa wave (2 s) is the
    historical ``cycle`` baseline; ``cycle:low_kpa=0,high_kpa=3,period_s=1`` is the
    0 <-> 3 kPa, 1 s wave.

    Parameters: ``low_kpa`` and ``high_kpa`` in [0, 8] kPa, ``period_s`` in (0, 600] s,
    ``duty`` (fraction of the period at ``high_kpa``) in (0, 1).
    """

    low_kpa: float = 1.0
    high_kpa: float = 8.0
    period_s: float = 2.0
    duty: float = 0.5
    name: str = field(default="cycle", init=False)

    def __post_init__(self) -> None:
        check_range("low_kpa", self.low_kpa, 0.0, 8.0, unit="kPa")
        check_range("high_kpa", self.high_kpa, 0.0, 8.0, unit="kPa")
        check_range("period_s", self.period_s, 0.0, 600.0, unit="s", lo_open=True)
        check_range("duty", self.duty, 0.0, 1.0, lo_open=True, hi_open=True, unit="(fraction of the period at high_kpa)")

    @property
    def max_command_kpa(self) -> float:
        return max(self.low_kpa, self.high_kpa)

    def reset(self, env) -> None:
        super().reset(env)
        self.steps = 0

    def act(self, obs, info):
        phase = ((self.steps * self.dt + 1e-9) % self.period_s) / self.period_s  # 1e-9 s: float round-off
        self.steps += 1
        return pressure_to_action(self.high_kpa if phase < self.duty else self.low_kpa)


@dataclass
class DeflateOnStall(Policy):
    """Hold ``high_kpa``; when progress stalls, deflate to ``low_kpa`` for ``deflate_s``
    seconds, then inflate again.

    It reads what an operator sees: the measured insertion length
    (``info["insertion_length_mm"]``) and the clock, never the tip force.  Progress stalls
    as for :class:`OperatorProtocol`: the insertion grew by less than ``stall_mm`` over the
    last ``stall_s`` seconds at the high level.  After a deflation the stall window starts
    afresh, so the robot gets a full ``stall_s`` at ``high_kpa`` before the next one.
    ``deflate:high_kpa=3,low_kpa=0,deflate_s=0.5`` is the standard deflate rule.

    Parameters: ``high_kpa`` and ``low_kpa`` in [0, 8] kPa, ``deflate_s`` in (0, 60] s,
    ``stall_s`` in (0, 60] s, ``stall_mm`` in [0, 1000] mm.
    """

    high_kpa: float = 3.0
    low_kpa: float = 0.0
    deflate_s: float = 0.5
    stall_s: float = 1.0
    stall_mm: float = 2.0
    name: str = field(default="deflate", init=False)

    def __post_init__(self) -> None:
        check_range("high_kpa", self.high_kpa, 0.0, 8.0, unit="kPa")
        check_range("low_kpa", self.low_kpa, 0.0, 8.0, unit="kPa")
        check_range("deflate_s", self.deflate_s, 0.0, 60.0, lo_open=True, unit="s")
        check_range("stall_s", self.stall_s, 0.0, 60.0, lo_open=True, unit="s")
        check_range("stall_mm", self.stall_mm, 0.0, 1000.0, unit="mm")

    @property
    def max_command_kpa(self) -> float:
        return max(self.low_kpa, self.high_kpa)

    def reset(self, env) -> None:
        super().reset(env)
        self.window: list[float] = []
        self.deflate_left = 0  # control steps still to spend at low_kpa
        self.deflations = 0  # stalls answered this episode

    def act(self, obs, info):
        if self.deflate_left > 0:
            self.deflate_left -= 1
            return pressure_to_action(self.low_kpa)
        self.window.append(float(info["insertion_length_mm"]))
        n = max(1, int(round(self.stall_s / self.dt)))
        if len(self.window) > n:
            self.window = self.window[-(n + 1) :]
            if self.window[-1] - self.window[0] < self.stall_mm:
                self.deflations += 1
                self.window = []
                self.deflate_left = max(1, int(round(self.deflate_s / self.dt))) - 1
                return pressure_to_action(self.low_kpa)
        return pressure_to_action(self.high_kpa)


BASELINES = {"constant": ConstantPressure, "operator": OperatorProtocol, "cycle": PressureCycling, "deflate": DeflateOnStall}
