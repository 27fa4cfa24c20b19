"""Declared trial-to-trial variation of the robot: what differs between the paper's trials.

The paper's 12 trials per U-bend cell are 3 fabricated robots x 4 trials, with the robot's
orientation and the bands' position randomised.  A :class:`Variation` names each source of spread
as a distribution, drawn per fabricated robot or per trial, and :func:`draw` turns a draw into
:class:`~evertgym.sim.config.SimConfig` changes and a record kept with the trial:

=====================  ===========  ======================================================  ==========================
source                 drawn per    distribution                                             where its spread comes from
=====================  ===========  ======================================================  ==========================
eversion threshold     robot        ``p_y(rho) (1 + z cv(rho))``, ``z ~ N(0, 1)``           measured: Exp 4's SD over median, 9-16%
bending stiffness      robot        ``1 + z cv_k``, ``z ~ N(0, 1)``                          measured: Exp 1 and 3's SDs (median 3.5%)
friction               trial        robot's wall and tip coefficients x ``m exp(s z)``      fitted on the no-band U-bend rows (m, s)
band position          trial        uniform, the caller's range (the paper: +-25 mm)         the paper's protocol
entry across the pipe  trial        uniform, the caller's range (+-5 mm)                     the paper's protocol
=====================  ===========  ======================================================  ==========================

A robot's draws come from its own stream, seeded by the robot's index alone (``robot = seed //
trials_per_robot mod robots`` for an episode seeded ``seed``), so robot ``k`` of every design and
every radius is the same fabricated robot in distribution terms: designs are compared on common
random numbers.  The trial's draws come from the episode's generator after every other draw.  The
calibrated values are in ``evertgym/data/bend_model.json`` (:mod:`evertgym.experiments.bend_model`).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from dataclasses import dataclass

import numpy as np

from evertgym._validate import check_int, check_range
from evertgym.model.params import DATA_DIR, load_measurements

#: the adopted bend model (written by ``evertgym bands fit``)
BEND_MODEL_PATH = DATA_DIR / "bend_model.json"
#: the robot stream's first seed word (any fixed constant: it keeps robot draws apart from trial draws)
_ROBOT_STREAM = 20261206


@functools.lru_cache(maxsize=1)
def stiffness_cv() -> float:
    """Robot-to-robot coefficient of variation of the bending stiffness: the median SD over mean of
    the stiffness rows that may calibrate (Exp 1 and Exp 3, measurements.json)."""
    tests = load_measurements()["stiffness_tests"]
    rows = [r for key in ("experiment_1_band_count", "experiment_3_diameter_reduction") for r in tests[key]["rows"]]
    return float(np.median([r["sd"] / r["k_N_per_m"] for r in rows]))


@dataclass(frozen=True)
class Variation:
    """The declared distributions (see the module docstring).  ``friction_median`` and
    ``friction_sigma``: the lognormal factor on the robot's friction coefficients, per trial;
    ``robot_stiffness`` and ``robot_threshold``: whether the measured robot-to-robot spreads are
    drawn; ``robots`` fabricated robots of ``trials_per_robot`` trials each."""

    friction_median: float = 1.0
    friction_sigma: float = 0.0
    robot_stiffness: bool = True
    robot_threshold: bool = True
    robots: int = 3
    trials_per_robot: int = 4

    def __post_init__(self) -> None:
        check_range("friction_median", self.friction_median, 0.05, 20.0)
        check_range("friction_sigma", self.friction_sigma, 0.0, 1.0, lo_open=False)
        check_int("robots", self.robots, 1, 1000)
        check_int("trials_per_robot", self.trials_per_robot, 1, 1000)
        for name in ("robot_stiffness", "robot_threshold"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"variation.{name} = {getattr(self, name)!r} is out of range: allowed true or false")

    @classmethod
    def from_dict(cls, d: dict) -> Variation:
        """From a JSON object of the fields; one line naming an unknown field."""
        if not isinstance(d, dict):
            raise ValueError(f"variation = {d!r:.60}: allowed a JSON object of {sorted(f.name for f in dataclasses.fields(cls))}, "
                             "'calibrated' or null")
        unknown = sorted(set(d) - {f.name for f in dataclasses.fields(cls)})
        if unknown:
            raise ValueError(f"variation: unknown fields {unknown}: allowed {sorted(f.name for f in dataclasses.fields(cls))}")
        return cls(**d)

    @classmethod
    def calibrated(cls) -> Variation:
        """The calibrated bend model's variation (``evertgym/data/bend_model.json``)."""
        return cls.from_dict(dict(bend_model()["variation"]))

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def resolve(spec: Variation | dict | str | None) -> Variation | None:
    """A :class:`Variation` from an env or trial argument: ``"calibrated"`` (the default model),
    a dict of fields, ``None`` or ``"off"`` (none: every trial the median robot at the robot's own
    friction)."""
    if spec is None or spec == "off":
        return None
    if isinstance(spec, Variation):
        return spec
    if spec == "calibrated":
        return Variation.calibrated()
    if isinstance(spec, str):
        raise ValueError(f"variation = {spec!r} is out of range: allowed 'calibrated', 'off', null or a JSON object")
    return Variation.from_dict(spec)


def robot_index(variation: Variation, seed: int | None, rng: np.random.Generator) -> int:
    """The fabricated robot an episode uses: ``seed // trials_per_robot mod robots`` for a seeded
    episode, else drawn from ``rng``."""
    if seed is None:
        return int(rng.integers(variation.robots))
    return (int(seed) // variation.trials_per_robot) % variation.robots


def draw(variation: Variation, robot: int, rng: np.random.Generator, wall_friction: float,
         tip_friction: float) -> tuple[dict, dict]:
    """``(SimConfig changes, record)`` of one trial of robot ``robot`` (quasi-static engine fields): its
    friction factor from ``rng`` applied to the robot's ``wall_friction`` and ``tip_friction``, and the
    robot's stiffness factor and threshold draw."""
    z_stiff, z_thresh = np.random.default_rng([_ROBOT_STREAM, int(robot)]).standard_normal(2)
    factor = variation.friction_median * math.exp(variation.friction_sigma * float(rng.standard_normal()))
    changes: dict = {"wall_friction": min(wall_friction * factor, 5.0), "tip_friction": min(tip_friction * factor, 5.0)}
    stiff = float(np.clip(1.0 + stiffness_cv() * z_stiff, 0.5, 2.0)) if variation.robot_stiffness else 1.0
    z_t = float(np.clip(z_thresh, -5.0, 5.0)) if variation.robot_threshold else 0.0
    changes.update(stiffness_factor=stiff, threshold_z=z_t)
    return changes, {"robot": int(robot), "friction_factor": factor, "stiffness_factor": stiff, "threshold_z": z_t}


@functools.lru_cache(maxsize=1)
def _bend_model_text() -> str:
    return BEND_MODEL_PATH.read_text()


def bend_model() -> dict:
    """The adopted bend model: candidate, SimConfig switches, variation, fitted values and what they
    were fitted on (``evertgym/data/bend_model.json``, written by ``evertgym bands fit``)."""
    return json.loads(_bend_model_text())
