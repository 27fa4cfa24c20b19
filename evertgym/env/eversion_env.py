"""Gymnasium environment: schedule the pressure of an eversion robot through a scene."""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from evertgym._validate import check_bool, check_int, check_pair, check_range
from evertgym.design import Band, TubeDesign
from evertgym.env.presets import sample_params
from evertgym.render import FrameRenderer, Overlay
from evertgym.scenes import FAMILIES, Scene, SceneSpec, make_scene
from evertgym.sim import EversionSim, SimConfig
from evertgym.sim.growth import MAX_PRESSURE_PA
from evertgym.sim.simulator import check_buildable
from evertgym.sim.variation import draw as draw_variation
from evertgym.sim.variation import resolve as resolve_variation
from evertgym.sim.variation import robot_index

_LOOKAHEAD_M = (0.02, 0.04, 0.06, 0.08, 0.10)
_CLIP = 10.0  # upper bound of the unbounded ratios (tip force, lumen width)
_REWARD_TERMS = ("progress", "pressure", "contact", "stall", "success")
#: Scene seeds drawn for episodes stay below this; evaluation on held-out scenes uses
#: seeds from here up (``reset(options={"scene_seed": ...})``).
HELD_OUT_SEED_BASE = 1_000_000_000
#: Validation episodes (``evertgym eval --validation``) use seeds from here up: neither a
#: training scene (below :data:`HELD_OUT_SEED_BASE`) nor a held-out one (below
#: ``HELD_OUT_SEED_BASE + MAX_EPISODES``), for choosing a setting (an action mode, a
#: checkpoint) without looking at the held-out episodes.
VALIDATION_SEED_BASE = 2_000_000_000

#: Env arguments that shape the observation and not the physics: a trained policy carries
#: these to every env it is evaluated in (everything else, e.g. a randomised regulator lag,
#: is the evaluation's choice, the same for every policy compared).
OBSERVATION_KWARGS = ("history", "tip_sensing", "scene_ahead")


def engine_of(env_kwargs: dict) -> str:
    """The simulator engine an env built with ``env_kwargs`` runs: the one its ``sim_config`` (a
    :class:`SimConfig` or a dict of its fields) names, else this release's default."""
    sim = env_kwargs.get("sim_config")
    if isinstance(sim, SimConfig):
        return sim.engine
    return str(dict(sim or {}).get("engine", SimConfig().engine))


class EversionEnv(gym.Env):
    """Grow an eversion robot through a scene by scheduling its pressure.

    The robot (a thin-walled inflated tube with constrictive bands) grows from its base at
    the scene's entry by everting at the tip; the agent sets the pressure command each
    control step; the tip must reach the scene's goal.  Presets: ``evertgym/UBend-v0``,
    ``evertgym/Tortuous-v0``, ``evertgym/Colon-v0`` (``docs/envs.md``).

    **Action space** ``Box(-1, 1, (1,), float32)``

    ==========  ==================================================================  ======
    action_mode  meaning of ``a``                                                   unit
    ==========  ==================================================================  ======
    absolute    pressure command ``p = (a + 1) / 2 * 8``                            kPa
    increment   change of the command ``dp = a * max_increment_kpa`` per step       kPa
    ==========  ==================================================================  ======

    The command is clipped to [0, 8] kPa (the seal ruptures above it); the regulator's lag
    (``SimConfig.regulator_tau_s``) applies.  An action outside [-1, 1] (a pressure in kPa passed
    as the action, say) is clipped to it with a ``UserWarning``, once per env.  A NaN or
    infinite action raises ``ValueError``.

    **Observation space** ``Box(low, high, (n,), float32)``, ``n = 3 (history + 1)
    + 2 tip_sensing + 10 scene_ahead``.  By default only what an operator has.  For ``k = 0
    .. history``, oldest first (``k = history`` the current step, ``k`` the sample of
    ``history - k`` steps ago), indices ``3 k``, ``3 k + 1``, ``3 k + 2``:

    =====  ============================================  =====================  ======  ======
    index  observation                                   unit (divided by)      low     high
    =====  ============================================  =====================  ======  ======
    3k     measured pressure                             / 8 kPa                0       1
    3k+1   insertion length (everted length)             / robot length         0       1
    3k+2   growth speed                                  / max growth speed     0       1
    =====  ============================================  =====================  ======  ======

    Then, with ``tip_sensing=True`` (a force sensor at the tip):

    =====  ============================================  =====================  ======  ======
    +0     tip axial contact force (clipped at 10)       / 8 kPa x tip area     0       10
    +1     tip in contact with a wall                    flag                   0       1
    =====  ============================================  =====================  ======  ======

    Then, with ``scene_ahead=True`` (**privileged**: a map of the channel), for each
    ``d`` in 20, 40, 60, 80, 100 mm ahead of the tip along the centreline, two values:

    =====  ============================================  =====================  ======  ======
    +2j    turn of the centreline vs tip heading         / pi rad               -1      1
    +2j+1  lumen width (clipped at 10)                   / robot diameter       0       10
    =====  ============================================  =====================  ======  ======

    :meth:`observation_names` names every index.

    **Rewards**, per control step of ``dt = 1 / control_hz``; each term is in ``info``:

    ===================  ==============================================================
    info key             term
    ===================  ==============================================================
    reward_progress      ``progress_weight * ds / 10 mm``, tip progress along the centreline
    reward_pressure      ``- pressure_weight * (p_mean / 8 kPa)^2``, mean pressure in the step
    reward_contact       ``- contact_weight * F_max / 1 N``, largest tip contact force in the step;
                         with ``contact_reward="peak"``, ``- contact_weight * (F_peak - F_peak') / 1 N``,
                         the rise of the episode's peak tip force in the step (the terms sum to
                         ``- contact_weight * F_peak``, the force the evaluation reports)
    reward_stall         ``- stall_weight`` while stalled (no growth for ``SimConfig.stall_time_s``)
    reward_success       ``+ success_weight`` once, on reaching the goal
    ===================  ==============================================================

    **Starting state**: ``reset(seed=s)`` draws the scene parameters (preset
    distributions), the scene seed (below :data:`HELD_OUT_SEED_BASE`; fix one with
    ``reset(options={"scene_seed": k})``, held-out evaluation uses seeds from
    :data:`HELD_OUT_SEED_BASE` up), the band offset (``band_offset_mm``) and the base's
    lateral offset at the entry (``entry_offset_mm``).  The robot starts unpressurised,
    with its first everted segment at the entry, command 0; the history holds copies of
    the first sample.  The same seed gives the same episode.

    **Episode end**: ``terminated`` when the tip passes the goal (success), when the
    robot has fully everted, or on rupture (measured pressure above ``rupture_kpa``; with
    the default 8 kPa clip it cannot happen).  ``truncated`` at ``max_episode_s``; the
    registered ids also carry ``max_episode_steps = max_episode_s * control_hz`` (pass
    ``max_episode_steps`` to ``gym.make`` too when overriding ``max_episode_s``).

    **Info** (the same keys from ``reset`` and ``step``): ``success``, ``ruptured``,
    ``outcome`` (``running``, ``success``, ``stalled``, ``ruptured``, ``everted``,
    ``time out``), ``time_s``, ``command_kpa``, ``pressure_kpa`` (measured),
    ``peak_pressure_kpa``, ``insertion_length_mm``, ``max_contact_force_n``,
    ``stall_count``, the five ``reward_*`` terms (0 at reset) and, **privileged** (need
    the channel map), ``tip_arclength_mm`` (tip's progress along the centreline),
    ``peak_pressure_time_s`` (when the episode's peak pressure was reached),
    ``peak_pressure_bend_kpa`` (peak measured pressure while the tip is in one of the
    scene's bends, :meth:`~evertgym.scenes.scene.Scene.bend_regions` entered one robot
    diameter early; 0 until it gets there) and ``bend_entry_time_s`` (``None`` until then).

    **Arguments**

    ====================  ======================  ==============================================
    argument              default                 meaning
    ====================  ======================  ==============================================
    scene                 ubend, default params   ``{"family", "params", "seed"}``; params may be
                                                  distributions (:mod:`evertgym.env.presets`);
                                                  seed ``"episode"`` draws one per episode
    design                900 mm, 40 mm, no band  :class:`TubeDesign` or a design-file dict (mm)
    band_offset_mm        (0, 0)                  all bands shift by U(lo, hi) mm per episode, [-1000, 1000]
    entry_offset_mm       (0, 0)                  base starts U(lo, hi) mm across the channel, [-100, 100]
    control_hz            10                      control steps per second [1 / max_episode_s, 1000];
                                                  1 / control_hz a whole number of simulator steps
    max_episode_s         30                      time limit (s), (0, 1e5]
    action_mode           "absolute"              "absolute" or "increment"
    max_increment_kpa     1                       increment mode's largest step (kPa), (0, 8]
    history               4                       past steps in the observation, [0, 100]
    tip_sensing           False                   append tip force and contact flag
    scene_ahead           False                   append the channel ahead (privileged)
    rupture_kpa           8                       rupture pressure (kPa), (0, 1000]
    progress_weight       1                       reward weight, [0, 1e6]
    pressure_weight       0.05                    reward weight, [0, 1e6]
    contact_weight        0.02                    reward weight, [0, 1e6]
    contact_reward        "step"                  "step" (charge each step's largest force) or
                                                  "peak" (charge each rise of the episode's peak)
    stall_weight          0.1                     reward weight, [0, 1e6]
    success_weight        10                      reward weight, [0, 1e6]
    sim_config            SimConfig()             a :class:`SimConfig` or a dict of its fields
    render_mode           None                    "rgb_array" or "human"
    variation             "calibrated"            the robot-to-robot and trial-to-trial spread
                                                  (:mod:`evertgym.sim.variation`): "calibrated",
                                                  "off" / None, or a dict of Variation fields;
                                                  the episode's draws are in ``info["variation"]``
    ====================  ======================  ==============================================

    **Rendering**: ``rgb_array`` frames (480 x 480) from :class:`evertgym.render.FrameRenderer`
    show the bands as narrowed dark sections, compliant walls where the robot pushed them,
    and an overlay with time, pressure (measured and command), insertion and outcome.
    ``human`` shows them in a matplotlib window; without a display it warns once and
    shows nothing.

    **Version history**: v0 (0.1.0): first release.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        scene: dict | None = None,
        design: TubeDesign | dict | None = None,
        band_offset_mm: tuple[float, float] = (0.0, 0.0),
        entry_offset_mm: tuple[float, float] = (0.0, 0.0),
        control_hz: float = 10.0,
        max_episode_s: float = 30.0,
        action_mode: str = "absolute",
        max_increment_kpa: float = 1.0,
        history: int = 4,
        tip_sensing: bool = False,
        scene_ahead: bool = False,
        rupture_kpa: float = 8.0,
        progress_weight: float = 1.0,
        pressure_weight: float = 0.05,
        contact_weight: float = 0.02,
        contact_reward: str = "step",
        stall_weight: float = 0.1,
        success_weight: float = 10.0,
        sim_config: SimConfig | dict | None = None,
        render_mode: str | None = None,
        regulator_tau_s: tuple[float, float] | None = None,
        wall_friction: tuple[float, float] | None = None,
        pressure_noise_kpa: float = 0.0,
        insertion_noise_mm: float = 0.0,
        variation: dict | str | None = "calibrated",
    ):
        self.design = design if isinstance(design, TubeDesign) else TubeDesign.from_dict({"tube": {"length_mm": 900.0}} if design is None else design)
        self.scene_cfg = dict(_check_scene({"family": "ubend", "params": {}} if scene is None else scene, self.design))
        lo, hi = check_pair("band_offset_mm", band_offset_mm, -1e3, 1e3, "mm")
        for off in (lo, hi):  # every band must stay on the body at either end of the range
            try:
                TubeDesign(self.design.diameter_m, self.design.wall_thickness_m, self.design.length_m,
                           tuple(Band(b.position_m + off / 1e3, b.reduction, b.width_m) for b in self.design.bands))
            except ValueError as e:
                raise ValueError(f"band_offset_mm = {band_offset_mm!r} moves a band off the body or onto another ({e})") from None
        self.band_offset = (lo / 1e3, hi / 1e3)
        elo, ehi = check_pair("entry_offset_mm", entry_offset_mm, -100.0, 100.0, "mm")
        self.entry_offset = (elo / 1e3, ehi / 1e3)
        check_range("control_hz", control_hz, 0.0, 1000.0, lo_open=True, unit="Hz")
        check_range("max_episode_s", max_episode_s, 0.0, 1e5, lo_open=True, unit="s")
        if 1.0 / control_hz > max_episode_s:  # one step would outlast the episode (and cost as much)
            raise ValueError(f"control_hz = {control_hz!r} is out of range: one control step (1 / control_hz = "
                             f"{1.0 / control_hz:g} s) is longer than max_episode_s = {max_episode_s!r} s; "
                             f"allowed [{1.0 / max_episode_s:g}, 1000] Hz")
        if action_mode not in ("absolute", "increment"):
            raise ValueError(f"action_mode = {action_mode!r}: allowed 'absolute' or 'increment'")
        check_range("max_increment_kpa", max_increment_kpa, 0.0, 8.0, lo_open=True, unit="kPa")
        check_int("history", history, 0, 100)
        check_bool("tip_sensing", tip_sensing)
        check_bool("scene_ahead", scene_ahead)
        check_range("rupture_kpa", rupture_kpa, 0.0, 1e3, lo_open=True, unit="kPa")
        for name, w in (("progress_weight", progress_weight), ("pressure_weight", pressure_weight),
                        ("contact_weight", contact_weight), ("stall_weight", stall_weight), ("success_weight", success_weight)):
            check_range(name, w, 0.0, 1e6)
        if contact_reward not in ("step", "peak"):
            raise ValueError(f"contact_reward = {contact_reward!r}: allowed 'step' or 'peak'")
        self.contact_reward = contact_reward
        # domain randomisation of what the paper does not give: drawn per episode, after the
        # scene, band and entry draws (so an env without it draws exactly as before)
        self.regulator_tau_range = None if regulator_tau_s is None else check_pair("regulator_tau_s", regulator_tau_s, 0.0, 10.0, "s")
        self.wall_friction_range = None if wall_friction is None else check_pair("wall_friction", wall_friction, 0.0, 5.0)
        self.pressure_noise_pa = check_range("pressure_noise_kpa", pressure_noise_kpa, 0.0, 8.0, unit="kPa") * 1e3
        self.insertion_noise_m = check_range("insertion_noise_mm", insertion_noise_mm, 0.0, 1000.0, unit="mm") / 1e3
        self.variation = resolve_variation(variation)
        self._variation_record: dict = {}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: allowed {self.metadata['render_modes']} or None")
        self.control_dt = 1.0 / control_hz
        self.max_episode_s = float(max_episode_s)
        self.action_mode = action_mode
        self.max_increment_pa = max_increment_kpa * 1e3
        self._warned_action = False  # an action outside the action space is clipped with one warning per env
        self.history = history
        self.tip_sensing = tip_sensing
        self.scene_ahead = scene_ahead
        self.rupture_pa = rupture_kpa * 1e3
        self.w = dict(progress=progress_weight, pressure=pressure_weight, contact=contact_weight, stall=stall_weight, success=success_weight)
        if sim_config is not None and not isinstance(sim_config, (SimConfig, dict)):
            raise ValueError(f"sim_config = {sim_config!r:.80} is not allowed: allowed a SimConfig, a dict of its fields or None")
        try:
            self.sim_config = sim_config if isinstance(sim_config, SimConfig) else SimConfig(**(sim_config or {}))
        except TypeError as e:  # an unknown field
            raise ValueError(f"sim_config = {sim_config!r:.80}: {e}") from None
        n_sub = round(self.control_dt / self.sim_config.dt_s)
        if n_sub < 1 or abs(n_sub * self.sim_config.dt_s - self.control_dt) > 1e-9 * self.control_dt:
            raise ValueError(f"control_hz = {control_hz!r} is not allowed: 1 / control_hz must be a whole number of simulator "
                             f"steps (dt_s = {self.sim_config.dt_s:g} s), e.g. 10, 20, 50, 100 Hz")
        check_buildable(self.design, self.sim_config)
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=int(round(control_hz)))

        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        low, high = [0.0, 0.0, 0.0] * (history + 1), [1.0, 1.0, 1.0] * (history + 1)
        if tip_sensing:
            low, high = low + [0.0, 0.0], high + [_CLIP, 1.0]
        if scene_ahead:
            low, high = low + [-1.0, 0.0] * len(_LOOKAHEAD_M), high + [1.0, _CLIP] * len(_LOOKAHEAD_M)
        self._low, self._high = np.array(low, np.float32), np.array(high, np.float32)
        self.observation_space = spaces.Box(self._low, self._high, dtype=np.float32)
        self._sim: EversionSim | None = None
        self._ended = False
        self._scene: Scene | None = None
        self._fig = None
        self._renderer: FrameRenderer | None = None
        self._headless_warned = False

    @property
    def sim(self) -> EversionSim:
        """The episode's simulator (after :meth:`reset`)."""
        if self._sim is None:
            raise RuntimeError("call reset() before using the simulator")
        return self._sim

    @property
    def scene(self) -> Scene:
        """The episode's scene (after :meth:`reset`)."""
        if self._scene is None:
            raise RuntimeError("call reset() before using the scene")
        return self._scene

    # ---- episode --------------------------------------------------------------
    def _draw_episode(self, scene_seed: int | None, episode_seed: int | None = None) -> tuple[Scene, TubeDesign, np.ndarray, SimConfig]:
        rng = self.np_random
        params = sample_params(dict(self.scene_cfg.get("params", {})), rng)
        seed = self.scene_cfg.get("seed", "episode")
        drawn = int(rng.integers(HELD_OUT_SEED_BASE))
        if scene_seed is not None:
            seed = int(scene_seed)
        elif seed == "episode":
            seed = drawn
        scene = make_scene(SceneSpec(self.scene_cfg["family"], params, seed))
        design = self.design
        if design.bands and self.band_offset[1] > self.band_offset[0]:
            off = float(rng.uniform(*self.band_offset))
            design = TubeDesign(
                design.diameter_m, design.wall_thickness_m, design.length_m,
                tuple(Band(b.position_m + off, b.reduction, b.width_m) for b in design.bands),
                design.membrane_modulus_pa, design.pressure_stiffening,
            )
        lateral = float(rng.uniform(*self.entry_offset)) if self.entry_offset[1] > self.entry_offset[0] else 0.0
        d = np.asarray(scene.entry_direction, dtype=float)
        base = np.asarray(scene.entry, dtype=float) + lateral * np.array([-d[1], d[0]])
        changes: dict[str, Any] = {}
        if self.regulator_tau_range is not None:
            changes["regulator_tau_s"] = float(rng.uniform(*self.regulator_tau_range))
        if self.wall_friction_range is not None:
            changes["wall_friction"] = float(rng.uniform(*self.wall_friction_range))
        self._variation_record = {}
        cfg = self.sim_config
        if self.variation is not None and cfg.engine == "quasistatic":
            # the robot and the trial (sim.variation), after every other draw; the bend model is the
            # quasi-static engine's (the dynamic chain keeps its own calibration)
            robot = robot_index(self.variation, episode_seed, rng)
            varied, self._variation_record = draw_variation(self.variation, robot, rng, changes.get("wall_friction", cfg.wall_friction),
                                                            cfg.tip_friction)
            changes.update(varied)
        config = dataclasses.replace(self.sim_config, **changes) if changes else self.sim_config
        return scene, design, base, config

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if options is not None and not isinstance(options, dict):
            raise ValueError(f"options = {options!r:.80} is not allowed: allowed a dict such as {{'scene_seed': 3}} or None")
        scene_seed = (options or {}).get("scene_seed")
        if scene_seed is not None and (isinstance(scene_seed, (bool, np.bool_)) or not isinstance(scene_seed, (int, np.integer))
                                       or scene_seed < 0):
            raise ValueError(f"options['scene_seed'] = {scene_seed!r:.80} is not allowed: allowed an integer >= 0 (or None)")
        scene_seed = None if scene_seed is None else int(scene_seed)
        super().reset(seed=seed)
        # the last episode's simulator and scene go before the next are built, not after (the
        # colon's 2,000 wall shapes otherwise coexist for a moment, about 10 MB of peak memory)
        self._sim = self._scene = self._renderer = None
        self._scene, design, base, config = self._draw_episode(scene_seed, seed)
        self._sim = EversionSim(design, scene=self._scene, config=config, base=tuple(base))
        self.command_pa = 0.0
        self._s_tip = self._tip_arclength()
        # where "at the bend" is: the scene's tightest bends, entered one robot diameter early
        self._bends = self._scene.bend_regions(approach_m=design.diameter_m)
        self._bend_peak_pa = 0.0
        self._bend_entry_s: float | None = None
        self._peak_seen_pa = self._sim.peak_pressure
        self._peak_time_s = 0.0
        self._hist = [self._sample()] * (self.history + 1)
        self._success = False
        self._ruptured = False
        self._outcome = "running"
        self._ended = False
        self._terms = dict.fromkeys(_REWARD_TERMS, 0.0)
        self._charged_force = self._sim.max_contact_force
        self.episode_design = design
        return self._obs(), self._info()

    def step(self, action):
        raw = np.asarray(action)
        if raw.dtype.kind not in "fiu":  # strings, complex, bools and objects are not pressures
            raise ValueError(f"action = {action!r:.80}: expected one finite number in [-1, 1], got dtype {raw.dtype}")
        a = raw.astype(np.float64).reshape(-1)
        if a.shape != (1,) or not np.all(np.isfinite(a)):
            raise ValueError(f"action = {action!r}: expected one finite number in [-1, 1] (NaN and inf are rejected)")
        if self._sim is None:
            raise RuntimeError("call reset() before step()")
        if self._ended:
            raise RuntimeError(f"step() after the episode ended ({self._outcome}): call reset() to start the next episode")
        u = float(np.clip(a[0], -1.0, 1.0))
        if u != a[0] and abs(u - a[0]) > 1e-6 and not self._warned_action:
            self._warned_action = True
            meaning = ("the command is p = (a + 1) / 2 * 8 kPa" if self.action_mode == "absolute"
                       else f"the command changes by a * {self.max_increment_pa / 1e3:g} kPa per step")
            warnings.warn(f"action = {a[0]:g} is outside the action space [-1, 1] and is clipped to {u:g}: actions are scaled, "
                          f"not kPa ({meaning}); warned once per env", UserWarning, stacklevel=2)
        if self.action_mode == "absolute":
            self.command_pa = (u + 1.0) / 2.0 * MAX_PRESSURE_PA
        else:
            self.command_pa = min(max(self.command_pa + u * self.max_increment_pa, 0.0), MAX_PRESSURE_PA)
        sim = self.sim
        sim.set_pressure_command(self.command_pa)
        n = max(1, int(round(self.control_dt / sim.cfg.dt_s)))
        sim.step(n)
        if self.contact_reward == "step":
            f_max = sim.step_max_contact_force
        else:  # the rise of the episode's peak: the terms sum to the peak the evaluation reports
            f_max = sim.max_contact_force - self._charged_force
            self._charged_force = sim.max_contact_force
        s_new = self._tip_arclength()
        ds = s_new - self._s_tip
        self._s_tip = s_new
        p_mean = sim.step_mean_pressure
        self._track_peaks(s_new)
        reached = s_new >= self.scene.goal_arclength
        terms = {
            "progress": self.w["progress"] * ds / 0.01,
            "pressure": -self.w["pressure"] * (p_mean / MAX_PRESSURE_PA) ** 2,
            "contact": -self.w["contact"] * f_max,
            "stall": -self.w["stall"] if sim.stalled else 0.0,
            "success": self.w["success"] if reached and not self._success else 0.0,
        }
        reward = terms["progress"] + terms["pressure"] + terms["contact"] + terms["stall"] + terms["success"]
        self._success = self._success or bool(reached)
        self._terms = terms
        ruptured = sim.pressure > self.rupture_pa
        self._ruptured = bool(ruptured)
        everted = sim.length >= sim.design.length_m - 1e-9
        terminated = bool(reached or ruptured or everted)
        truncated = bool(not terminated and sim.t >= self.max_episode_s - 1e-9)
        self._ended = terminated or truncated
        self._outcome = ("success" if reached else "ruptured" if ruptured else "everted" if everted
                         else "time out" if truncated else "stalled" if sim.stalled else "running")
        self._hist = self._hist[1:] + [self._sample()]
        info = self._info()
        if self.render_mode == "human":
            self.render()
        return self._obs(), float(reward), terminated, truncated, info

    def _track_peaks(self, s_tip: float) -> None:
        """When the episode's peak pressure was reached, and the peak while the tip is in a bend."""
        sim = self.sim
        if sim.peak_pressure > self._peak_seen_pa:
            self._peak_seen_pa = sim.peak_pressure
            self._peak_time_s = sim.t
        if any(a <= s_tip <= b for a, b in self._bends):
            if self._bend_entry_s is None:
                self._bend_entry_s = sim.t
            self._bend_peak_pa = max(self._bend_peak_pa, sim.pressure, sim.step_mean_pressure)

    # ---- observation ------------------------------------------------------------
    def _tip_arclength(self) -> float:
        s, _ = self.scene.project(self.sim.tip_position)
        return float(s)

    def _sample(self) -> tuple[float, float, float]:
        """One history sample: pressure, insertion and growth speed, each scaled to [0, 1];
        the pressure and insertion as their sensors read them (``pressure_noise_kpa``,
        ``insertion_noise_mm``: Gaussian, drawn from the env's generator)."""
        sim = self.sim
        p, length = sim.pressure, sim.length
        if self.pressure_noise_pa > 0:
            p += self.pressure_noise_pa * float(self.np_random.normal())
        if self.insertion_noise_m > 0:
            length += self.insertion_noise_m * float(self.np_random.normal())
        return (p / MAX_PRESSURE_PA, length / sim.design.length_m, sim.growth_speed / sim.cfg.max_growth_speed_m_per_s)

    def _obs(self) -> np.ndarray:
        parts = [v for sample in self._hist for v in sample]
        sim = self.sim
        if self.tip_sensing:
            f_ref = MAX_PRESSURE_PA * math.pi * sim.design.radius_m**2
            parts += [sim.tip_force / f_ref, 1.0 if sim.in_contact else 0.0]
        if self.scene_ahead:
            scene = self.scene
            t = sim.tip_direction
            heading = math.atan2(t[1], t[0])
            for d in _LOOKAHEAD_M:
                s = min(self._s_tip + d, scene.length)
                i = int(np.clip(np.searchsorted(scene.arclength, s), 1, len(scene.arclength) - 1))
                seg = scene.centreline[i] - scene.centreline[i - 1]
                turn = (math.atan2(seg[1], seg[0]) - heading + math.pi) % (2 * math.pi) - math.pi
                parts += [turn / math.pi, float(scene.lumen_at(s)) / sim.design.diameter_m]
        return np.clip(np.asarray(parts, dtype=np.float32), self._low, self._high)

    def observation_names(self) -> list[str]:
        """A name for every observation index (``pressure[t-1]``, ``tip_force``, ``turn@20mm``, ...)."""
        names = []
        for k in range(self.history + 1):  # oldest first: the current step's sample is the last
            ago = self.history - k
            lag = "t" if ago == 0 else f"t-{ago}"
            names += [f"pressure[{lag}]", f"insertion[{lag}]", f"growth_speed[{lag}]"]
        if self.tip_sensing:
            names += ["tip_force", "tip_contact"]
        if self.scene_ahead:
            for d in _LOOKAHEAD_M:
                names += [f"turn@{d * 1e3:.0f}mm", f"lumen@{d * 1e3:.0f}mm"]
        return names

    def _info(self) -> dict:
        sim = self.sim
        info = {
            "success": bool(self._success),
            "ruptured": self._ruptured,
            "outcome": self._outcome,
            "time_s": sim.t,
            "command_kpa": self.command_pa / 1e3,
            "pressure_kpa": sim.pressure / 1e3,
            "peak_pressure_kpa": sim.peak_pressure / 1e3,
            "peak_pressure_time_s": self._peak_time_s,
            "peak_pressure_bend_kpa": self._bend_peak_pa / 1e3,
            "bend_entry_time_s": self._bend_entry_s,
            "insertion_length_mm": sim.length * 1e3,
            "max_contact_force_n": sim.max_contact_force,
            "stall_count": sim.stall_count,
            "tip_arclength_mm": self._s_tip * 1e3,
            "regulator_tau_s": sim.cfg.regulator_tau_s,
            "wall_friction": sim.cfg.wall_friction,
            "engine": sim.cfg.engine,
            "variation": dict(self._variation_record),
        }
        info.update(sim.solve_stats)  # quasi-static engine: solves, solve_failures, ... (never hidden)
        info["unconverged_solves"] = int(sim.solve_stats.get("solve_failures", 0))  # both engines (dynamic: relaxations cut)
        info.update({f"reward_{k}": float(v) for k, v in self._terms.items()})
        return info

    # ---- rendering -----------------------------------------------------------------
    def render(self):
        """``rgb_array``: the frame (480, 480, 3) uint8; ``human``: shows it (None)."""
        if self.render_mode is None or self._sim is None:
            return None
        sim = self.sim
        if self._renderer is None:
            self._renderer = FrameRenderer(self.scene, handles=sim.scene_handles)
        overlay = Overlay(sim.t, self.command_pa, sim.pressure, sim.length, sim.design.length_m, self._outcome)
        bands = [(b.position_m, b.reduction, b.width_m) for b in sim.design.bands]
        img = self._renderer.frame(sim.centreline(), sim.design.radius_m, bands, sim.scene_handles, overlay)
        if self.render_mode == "rgb_array":
            return img
        import matplotlib
        import matplotlib.pyplot as plt

        if not _interactive_backend(matplotlib.get_backend()):
            if not self._headless_warned:
                warnings.warn(f"render_mode='human': matplotlib backend {matplotlib.get_backend()!r} cannot show a "
                              "window (no display?); frames are not shown. Use render_mode='rgb_array'.", stacklevel=2)
                self._headless_warned = True
            return None
        if self._fig is None:
            plt.ion()
            self._fig, ax = plt.subplots()
            self._im = ax.imshow(img)
            ax.set_axis_off()
        else:
            self._im.set_data(img)
        self._fig.canvas.draw_idle()
        plt.pause(1e-3)
        return None

    def close(self):
        if self._fig is not None:
            import matplotlib.pyplot as plt

            plt.close(self._fig)
            self._fig = None


def _interactive_backend(name: str) -> bool:
    """Whether matplotlib's backend ``name`` can show a window."""
    try:
        from matplotlib.backends import BackendFilter, backend_registry

        return name.lower() in backend_registry.list_builtin(BackendFilter.INTERACTIVE)
    except ImportError:  # matplotlib < 3.9
        from matplotlib import rcsetup

        return name in getattr(rcsetup, "interactive_bk", ())


def _check_scene(scene: Any, design: TubeDesign) -> dict:
    """The scene config, checked now rather than at ``reset``: a mapping naming a known family
    whose params are valid at both ends of every distribution, with a lumen the robot fits."""
    if not isinstance(scene, dict) or "family" not in scene:
        raise ValueError(f"scene = {scene!r:.80}: expected a mapping naming a family, e.g. {{'family': 'ubend', 'params': {{}}}}")
    unknown = set(scene) - {"family", "params", "seed"}
    if unknown:
        raise ValueError(f"scene: unknown keys {sorted(unknown)}: allowed family, params, seed")
    params = scene.get("params", {})
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise ValueError(f"scene.params = {params!r:.80} is not a mapping of parameter names to values")
    seed = scene.get("seed", "episode")
    if seed != "episode":
        SceneSpec(scene["family"], {}, seed)  # a fixed seed: an integer >= 0 (or None)
    for end in (0, -1):  # each distribution at its low, then its high end
        fixed = {}
        for key, value in params.items():
            if isinstance(value, dict) and set(value) == {"uniform"}:
                fixed[key] = check_pair(f"scene.params.{key}.uniform", value["uniform"], -math.inf, math.inf)[end]
            elif isinstance(value, dict) and set(value) == {"choice"} and isinstance(value["choice"], list) and value["choice"]:
                fixed[key] = value["choice"][end]
            elif isinstance(value, dict):
                raise ValueError(f"scene.params.{key} = {value!r}: a distribution is {{uniform = [lo, hi]}} or {{choice = [...]}}")
            else:
                fixed[key] = value
        spec = SceneSpec(scene["family"], fixed, None)
        lumen = FAMILIES[spec.family].resolve(dict(spec.params), np.random.default_rng(0)).get("lumen_mm")
        narrowest = min(lumen) if isinstance(lumen, tuple) else lumen
        if narrowest is not None and design.diameter_m * 1e3 > narrowest + 1e-6:
            raise ValueError(f"design diameter_mm = {design.diameter_m * 1e3:g} is out of range: allowed up to the "
                             f"scene's lumen_mm = {narrowest:g} mm (the robot must fit the channel)")
    return scene
