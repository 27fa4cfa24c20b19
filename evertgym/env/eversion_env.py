"""Gymnasium environment: schedule the pressure of an eversion robot through a scene."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from evertgym._validate import check_bool, check_int, check_pair, check_range
from evertgym.design import Band, TubeDesign
from evertgym.env.presets import sample_params
from evertgym.scenes import FAMILIES, Scene, SceneSpec, make_scene, render_rgb
from evertgym.sim import EversionSim, SimConfig
from evertgym.sim.growth import MAX_PRESSURE_PA
from evertgym.sim.simulator import check_buildable

_LOOKAHEAD_M = (0.02, 0.04, 0.06, 0.08, 0.10)
#: Scene seeds drawn for episodes stay below this; evaluation on held-out scenes uses
#: seeds from here up (``reset(options={"scene_seed": ...})``).
HELD_OUT_SEED_BASE = 1_000_000_000


class EversionEnv(gym.Env):
    """Grow an eversion robot through a scene by scheduling its pressure.

    **Action** (``Box(-1, 1, (1,))``).  ``action_mode="absolute"``: the pressure command,
    ``p = (a + 1) / 2 * 8 kPa``.  ``action_mode="increment"``: a change of the command,
    ``dp = a * max_increment_kpa`` per control step.  Either way the command is clipped to
    [0, 8] kPa (the seal ruptures above it) and the regulator's lag applies.  A NaN or
    infinite action raises ``ValueError`` before it reaches the simulation.

    **Observation** (``Box``, float32), by default only what an operator has: for the
    current and each of the last ``history`` control steps, the measured pressure / 8 kPa,
    the insertion length / robot length and the growth speed / the maximum growth speed.
    ``tip_sensing=True`` appends the tip's axial contact force (/ the tip force at 8 kPa)
    and a contact flag.  ``scene_ahead=True`` (privileged) appends, at 20, 40, 60, 80 and
    100 mm ahead of the tip along the channel, the turn of the centreline relative to the
    tip direction (/ pi) and the lumen width / robot diameter.

    **Reward**, per control step of ``dt = 1 / control_hz``:

    * ``progress_weight * ds / 10 mm``: progress of the tip along the channel centreline;
    * ``- pressure_weight * (p / 8 kPa)^2``: pressure cost (mean over the step);
    * ``- contact_weight * F_max / 1 N``: the largest tip contact force in the step;
    * ``- stall_weight`` while the robot is stalled (no growth for ``stall_time_s``);
    * ``+ success_weight`` once, on reaching the goal.

    **Scenes**: ``reset(seed=...)`` seeds everything drawn for the episode; scene seeds for
    random families are drawn below :data:`HELD_OUT_SEED_BASE`, and
    ``reset(options={"scene_seed": s})`` fixes one (evaluation on held-out scenes).

    **Episode end**: ``terminated`` when the tip passes the scene's goal (success), when
    the robot has fully everted, or on rupture (measured pressure above ``rupture_kpa``;
    with the default 8 kPa clip it cannot happen; set ``rupture_kpa`` lower to model a
    weaker seal); ``truncated`` at ``max_episode_s``.  ``info`` carries ``success``,
    ``peak_pressure_kpa``, ``max_contact_force_n``, ``stall_count``, ``insertion_length_mm``,
    ``tip_arclength_mm`` and ``time_s``.

    Parameters
    ----------
    scene: ``{"family": ..., "params": {...}, "seed": ...}``; params may be distributions
        (see :mod:`evertgym.env.presets`); seed ``"episode"`` draws one per episode.
    design: a :class:`TubeDesign` or a design-file dict (mm).
    band_offset_mm: ``(lo, hi)``: all bands shift by a uniform draw per episode.
    entry_offset_mm: ``(lo, hi)``: the base starts this far across the channel from its
        entry point (a uniform draw per episode; the paper varied the robot's start).
    control_hz, max_episode_s, action_mode, max_increment_kpa, history, tip_sensing,
    scene_ahead, rupture_kpa: see above.  progress_weight, pressure_weight,
    contact_weight, stall_weight, success_weight: reward weights.
    sim_config: a :class:`SimConfig` or a dict of its fields.
    render_mode: ``"rgb_array"`` or ``"human"``.
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
        stall_weight: float = 0.1,
        success_weight: float = 10.0,
        sim_config: SimConfig | dict | None = None,
        render_mode: str | None = None,
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
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: allowed {self.metadata['render_modes']} or None")
        self.control_dt = 1.0 / control_hz
        self.max_episode_s = float(max_episode_s)
        self.action_mode = action_mode
        self.max_increment_pa = max_increment_kpa * 1e3
        self.history = history
        self.tip_sensing = tip_sensing
        self.scene_ahead = scene_ahead
        self.rupture_pa = rupture_kpa * 1e3
        self.w = dict(progress=progress_weight, pressure=pressure_weight, contact=contact_weight, stall=stall_weight, success=success_weight)
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
        n = 3 * (history + 1) + (2 if tip_sensing else 0) + (2 * len(_LOOKAHEAD_M) if scene_ahead else 0)
        self.observation_space = spaces.Box(-10.0, 10.0, (n,), np.float32)
        self._sim: EversionSim | None = None
        self._scene: Scene | None = None
        self._fig = None

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
    def _draw_episode(self, scene_seed: int | None) -> tuple[Scene, TubeDesign, np.ndarray]:
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
        return scene, design, base

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        scene_seed = (options or {}).get("scene_seed")
        self._scene, design, base = self._draw_episode(scene_seed)
        self._sim = EversionSim(design, scene=self._scene, config=self.sim_config, base=tuple(base))
        self.command_pa = 0.0
        self._s_tip = self._tip_arclength()
        self._hist = [self._sample()] * (self.history + 1)
        self._success = False
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
        u = float(np.clip(a[0], -1.0, 1.0))
        if self.action_mode == "absolute":
            self.command_pa = (u + 1.0) / 2.0 * MAX_PRESSURE_PA
        else:
            self.command_pa = min(max(self.command_pa + u * self.max_increment_pa, 0.0), MAX_PRESSURE_PA)
        sim = self.sim
        sim.set_pressure_command(self.command_pa)
        n = max(1, int(round(self.control_dt / sim.cfg.dt_s)))
        p_sum, f_max = 0.0, 0.0
        for _ in range(n):
            sim.step(1)
            p_sum += sim.pressure
            f_max = max(f_max, float(math.hypot(*sim.tip_contact)))
        s_new = self._tip_arclength()
        ds = s_new - self._s_tip
        self._s_tip = s_new
        p_mean = p_sum / n
        reached = s_new >= self.scene.goal_arclength
        reward = (
            self.w["progress"] * ds / 0.01
            - self.w["pressure"] * (p_mean / MAX_PRESSURE_PA) ** 2
            - self.w["contact"] * f_max
            - (self.w["stall"] if sim.stalled else 0.0)
        )
        if reached and not self._success:
            reward += self.w["success"]
            self._success = True
        ruptured = sim.pressure > self.rupture_pa
        terminated = bool(reached or ruptured or sim.length >= sim.design.length_m - 1e-9)
        truncated = bool(not terminated and sim.t >= self.max_episode_s - 1e-9)
        self._hist = self._hist[1:] + [self._sample()]
        info = self._info()
        info["ruptured"] = bool(ruptured)
        if self.render_mode == "human":
            self.render()
        return self._obs(), float(reward), terminated, truncated, info

    # ---- observation ------------------------------------------------------------
    def _tip_arclength(self) -> float:
        s, _ = self.scene.project(self.sim.tip_position)
        return float(s)

    def _sample(self) -> tuple[float, float, float]:
        sim = self.sim
        return (sim.pressure / MAX_PRESSURE_PA, sim.length / sim.design.length_m, sim.growth_speed / sim.cfg.max_growth_speed_m_per_s)

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
        return np.clip(np.asarray(parts, dtype=np.float32), -10.0, 10.0)

    def _info(self) -> dict:
        sim = self.sim
        return {
            "success": bool(self._success),
            "peak_pressure_kpa": sim.peak_pressure / 1e3,
            "max_contact_force_n": sim.max_contact_force,
            "stall_count": sim.stall_count,
            "insertion_length_mm": sim.length * 1e3,
            "tip_arclength_mm": self._s_tip * 1e3,
            "time_s": sim.t,
        }

    # ---- rendering -----------------------------------------------------------------
    def render(self):
        if self.render_mode is None or self._sim is None:
            return None
        img = render_rgb(self.scene, self.sim.centreline(), self.sim.design.radius_m)
        if self.render_mode == "rgb_array":
            return img
        import matplotlib.pyplot as plt

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
