"""One scored trial: a design grows through a scene under a pressure policy.

``TrialSpec.scene`` is a scene spec (``family``, ``params``, ``seed``) plus an optional
``episode`` table: ``max_s`` (time limit, default 20 s), ``control_hz`` (10),
``band_offset_mm`` and ``entry_offset_mm`` (``[lo, hi]`` ranges drawn per trial from the
trial's seed: the paper's randomisation of band position against the bend and of the
robot's start), ``variation`` (the robot's and the trial's spread, :mod:`evertgym.sim.variation`:
``"calibrated"`` when absent, ``"off"`` or a dict of its fields; the draws are in the result's
``variation``) and ``sim`` (fields of :class:`~evertgym.sim.config.SimConfig` that override
its defaults, e.g. ``{"mass_ratio": 0.1}``; absent: the defaults).  ``TrialSpec.policy`` names a policy: ``{"name": "constant",
"pressure_kpa": 3}``, ``{"name": "operator", ...}``, ``{"name": "tuned"}`` or
``{"name": "agent", "path": "agents/colon_ppo_operator/final.zip"}``.

A trial ends at the goal (success), at full length, at the time limit, or early once
the robot has been stalled for ``give_up_s`` with the policy at its highest pressure
(the outcome can no longer change).  A failed trial's result also holds ``jam``, the
:func:`~evertgym.sim.diagnostics.jam_anatomy` of the robot where it stopped.
"""

from __future__ import annotations

from evertgym.agents.evaluate import run_episode
from evertgym.agents.policies import make_policy
from evertgym.env.eversion_env import EversionEnv
from evertgym.scoring.spec import TrialSpec
from evertgym.sim.diagnostics import jam_anatomy

GIVE_UP_S = 2.0


def make_trial_env(spec: TrialSpec) -> EversionEnv:
    scene = dict(spec.scene)
    episode = dict(scene.pop("episode", {}))
    return EversionEnv(
        scene=scene,
        design=spec.design,
        band_offset_mm=tuple(episode.get("band_offset_mm", (0.0, 0.0))),
        entry_offset_mm=tuple(episode.get("entry_offset_mm", (0.0, 0.0))),
        control_hz=float(episode.get("control_hz", 10.0)),
        max_episode_s=float(episode.get("max_s", 20.0)),
        sim_config=episode.get("sim"),
        variation=episode.get("variation", "calibrated"),
    )


def play_trial(spec: TrialSpec, trust: bool = False) -> tuple[EversionEnv, dict, list[tuple[float, float]]]:
    """Play one trial to its end; returns the finished environment (its ``sim`` holds the
    final state), the last step's info and the (insertion mm, pressure kPa) trace.  ``trust``
    (the caller's, never the spec's) loads a saved model that is not a shipped policy."""
    env = make_trial_env(spec)
    policy = make_policy(dict(spec.policy), trust=trust)
    max_command_pa = policy.max_command_kpa * 1e3
    pressures: list[tuple[float, float]] = []
    stalled_at_max = 0.0

    def give_up(env: EversionEnv, info: dict) -> bool:
        """Record the trace; end once the robot has stalled at the policy's highest pressure."""
        nonlocal stalled_at_max
        sim = env.sim
        pressures.append((sim.length * 1e3, sim.pressure / 1e3))
        at_max = sim.regulator.command >= max_command_pa - 0.5  # Pa: float32 actions round the command
        stalled_at_max = stalled_at_max + env.control_dt if (sim.stalled and at_max) else 0.0
        return stalled_at_max >= GIVE_UP_S

    info = run_episode(env, policy, int(spec.seed), stop=give_up)
    return env, info, pressures


def run_trial(spec: TrialSpec, trust: bool = False) -> dict:
    """Run one trial; the result has the keys of ``REQUIRED_RESULT_KEYS`` and more, among them
    ``unconverged_solves`` (the quasi-static solves that ended above the tolerance; 0 on the
    dynamic engine): a trial with any has an outcome the solver settings may have chosen.
    ``trust`` loads a saved model that is not a shipped policy (:func:`trusted_run_trial`)."""
    env, info, pressures = play_trial(spec, trust)
    stall_events = [e for e in env.sim.events if e.kind == "stall"]
    result = {
        "success": bool(info["success"]),
        "time_s": float(info["time_s"]),
        "peak_pressure_kpa": float(info["peak_pressure_kpa"]),
        "max_contact_force_n": float(info["max_contact_force_n"]),
        "stall_position_mm": None if info["success"] else (stall_events[-1].insertion_mm if stall_events else float(info["insertion_length_mm"])),
        "insertion_length_mm": float(info["insertion_length_mm"]),
        "tip_arclength_mm": float(info["tip_arclength_mm"]),
        "stall_count": int(info["stall_count"]),
        "pressure_position": [[round(x, 1), round(p, 3)] for x, p in pressures[:: max(1, len(pressures) // 60)]],
        "scene_params": {k: v for k, v in env.scene.params.items() if isinstance(v, (int, float, str, bool))},
        "engine": env.sim.cfg.engine,
        "variation": info.get("variation", {}),
        **env.sim.solve_stats,  # the quasi-static engine's solves and the ones that ended above tolerance
        "unconverged_solves": int(env.sim.solve_stats.get("solve_failures", 0)),
    }
    if not info["success"]:  # where and why it stopped (evertgym.sim.diagnostics)
        result["jam"] = jam_anatomy(env.sim, env.scene)
    return result


def trusted_run_trial(spec: TrialSpec) -> dict:
    """:func:`run_trial` with ``trust=True``: the trial function a run passes to its workers when the
    person running it opted in (``--trust-model``); the spec itself never carries trust."""
    return run_trial(spec, trust=True)
