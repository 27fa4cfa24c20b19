"""The ``evertgym`` command line.  Units at this edge: mm and kPa, named in the flags.

    evertgym reproduce stiffness [--json] [--plot docs/stiffness_fig3.png] [--no-sim]
    evertgym reproduce eversion [--json] [--step-kpa 0.01]
    evertgym bench env [--json] [--steps 500] [--env ID] [--against REV [--repeats 5]]
    evertgym bench pool [--trials 16] [--trial-s 0.3] [--real] [--no-dask] [--json]
    evertgym stiffness [--length-mm L] [--bands-from-tip-mm 50,100 --reduction 0.3]
                       [--pressure-kpa 6.9] [--displacement-mm D] [--design FILE] [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from evertgym._validate import check_range
from evertgym.cli_guard import check_input_file, dumps, no_abbreviations, run_command


class CLIError(ValueError):
    """A bad flag value; the message names the flag and its allowed range."""


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Help that shows the default of every option that takes a value (once: not when its
    help already names it, and not for on/off flags) and keeps the description's layout."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if action.nargs == 0 or action.required or "default" in text:
            return text
        return super()._get_help_string(action)


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose subcommands inherit the defaults-showing help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)


_JSON_HELP = "print one JSON object (for machines) instead of the table"
_BACKEND_HELP = "where trials run: process pool, serial in this process, or a Dask cluster"


def _sub(subparsers: argparse._SubParsersAction, name: str, text: str) -> argparse.ArgumentParser:
    """A subcommand whose one-line help is also its description."""
    p = subparsers.add_parser(name, help=text, description=text.replace("%%", "%"))
    p.set_defaults(_parser=p)  # the innermost subcommand's parser reports its own unknown flags (main)
    return p


def _scene_families() -> str:
    from evertgym.scenes import FAMILIES

    return ", ".join(sorted(FAMILIES))


def _float_list(flag: str, text: str) -> list[float]:
    if not text:
        return []
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CLIError(f"{flag} = {text!r}: expected comma-separated numbers in mm, e.g. 50,100") from None
    for v in vals:
        if not math.isfinite(v) or v <= 0:
            raise CLIError(f"{flag} = {text!r}: every value must be in (0, inf) mm")
    return vals


def _check(flag: str, value: float, lo: float, hi: float, unit: str, hi_open: bool = False) -> float:
    return check_range(flag, value, lo, hi, unit=unit, error=CLIError, hi_open=hi_open)


# ---- reproduce stiffness ---------------------------------------------------------------
def _stiffness_curves(result: dict, n_points: int = 11) -> list[dict]:
    from evertgym.model.stiffness import force_displacement_curve, paper_prototype

    disp_mm = np.linspace(0.0, 20.0, n_points)
    curves = []
    for r in result["rows"]:
        design = paper_prototype(r["bands_from_tip_mm"], r["reduction"])
        f = force_displacement_curve(design, disp_mm / 1e3)
        label = (
            "no bands"
            if not r["bands_from_tip_mm"]
            else f"{int(r['reduction'] * 100)}% @ {','.join(str(int(d)) for d in r['bands_from_tip_mm'])} mm"
        )
        curves.append(
            {
                "experiment": r["experiment"],
                "label": label,
                "displacement_mm": disp_mm,
                "cosserat_force_n": f,
                "measured_n_per_m": r["measured_n_per_m"],
                "sd_n_per_m": r["sd_n_per_m"],
            }
        )
    return curves


def cmd_reproduce_stiffness(args: argparse.Namespace) -> int:
    from evertgym.experiments.stiffness import reproduce_stiffness

    t0 = time.perf_counter()
    result = reproduce_stiffness()
    if not args.no_sim:
        from evertgym.experiments.stiffness import add_sim_columns

        add_sim_columns(result)
    if args.plot:
        from evertgym.experiments.plots import plot_stiffness_curves

        plot_stiffness_curves(_stiffness_curves(result), args.plot)
    if args.json:
        print(dumps(result))
        return 0
    print("Virtual tensile test: 6.9 kPa, 20 mm lateral tip displacement, k = F / 0.02 m")
    print(f"parameter file version: {result['params_version']}")
    sim = "sim_n_per_m" in result["rows"][0]
    head = f"{'exp':>3} {'role':>9} {'bands from tip (mm)':>20} {'red.':>5} {'measured':>9} {'sd':>5} {'cosserat':>9} {'error':>7}"
    print(head + (f" {'sim':>7} {'sim vs rod':>10}" if sim else ""))
    for r in result["rows"]:
        bands = ",".join(f"{d:g}" for d in r["bands_from_tip_mm"]) or "-"
        line = (
            f"{r['experiment']:>3} {r['role']:>9} {bands:>20} {r['reduction']:>5.2f} {r['measured_n_per_m']:>9.2f} "
            f"{r['sd_n_per_m']:>5.2f} {r['cosserat_n_per_m']:>9.2f} {100 * r['cosserat_rel_error']:>+6.1f}%"
        )
        if sim:
            line += f" {r['sim_n_per_m']:>7.2f} {100 * r['sim_rel_error_vs_cosserat']:>+9.2f}%"
        print(line)
    rms = result["rms"]
    print(f"RMS relative error, calibrate rows (Exp 1, 3): {100 * rms['calibrate']:.1f}%")
    print(f"RMS relative error, predict rows (Exp 2):      {100 * rms['predict']:.1f}%")
    print(f"  of which configurations never seen in calibration: {100 * rms['predict_unseen_configurations']:.1f}%")
    if args.plot:
        print(f"plot: {args.plot}")
    print(f"time: {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_reproduce_eversion(args: argparse.Namespace) -> int:
    from evertgym.experiments.eversion import reproduce_eversion

    step = _check("--step-kpa", args.step_kpa, 0.001, 1.0, "kPa")
    t0 = time.perf_counter()
    result = reproduce_eversion(step_pa=step * 1e3, progress=not args.json)
    if args.json:
        print(dumps(result))
        return 0
    print("Minimum eversion pressure (vertical, against gravity, full eversion within 20 s, <= 8 kPa)")
    print(f"{'reduction':>9} {'measured_kpa':>12} {'sd_kpa':>7} {'simulated_kpa':>13} {'within 1 SD':>11}")
    for r in result["rows"]:
        meas = "-" if r["measured_kpa"] is None else f"{r['measured_kpa']:.2f}"
        sd = "-" if r["sd_kpa"] is None else f"{r['sd_kpa']:.2f}"
        sim = "never" if r["simulated_kpa"] is None else f"{r['simulated_kpa']:.2f}"
        ok = "-"
        if r["measured_kpa"] is not None and r["simulated_kpa"] is not None:
            ok = "yes" if abs(r["simulated_kpa"] - r["measured_kpa"]) <= r["sd_kpa"] else "no"
        print(f"{r['reduction']:>9.2f} {meas:>12} {sd:>7} {sim:>13} {ok:>11}")
    print(f"time: {time.perf_counter() - t0:.1f} s")
    return 0


# ---- stiffness ---------------------------------------------------------------------------
def cmd_stiffness(args: argparse.Namespace) -> int:
    from evertgym.design import TubeDesign
    from evertgym.model.params import load_params
    from evertgym.model.stiffness import tensile_rod

    params = load_params()
    pressure_pa = _check("--pressure-kpa", args.pressure_kpa, 0.01, 8.0, "kPa (at 0 the wrinkling law switches off)") * 1e3
    disp = _check("--displacement-mm", args.displacement_mm, -60.0, 60.0, "mm") / 1e3
    if args.design:
        design = TubeDesign.load(check_input_file("--design", args.design))
        if args.bands_from_tip_mm:
            raise CLIError("--bands-from-tip-mm cannot be combined with --design (the file holds the bands)")
    else:
        length_total = 600.0
        design = TubeDesign(_check("--diameter-mm", args.diameter_mm, 1.0, 500.0, "mm") / 1e3, 0.05e-3, length_total / 1e3)
        bands = _float_list("--bands-from-tip-mm", args.bands_from_tip_mm)
        if bands:
            red = _check("--reduction", args.reduction, 0.0, 0.6, "(fraction of the diameter)", hi_open=True)
            design = design.with_bands_from_tip([b / 1e3 for b in bands], red)
    free_mm = params.free_length_m * 1e3 if args.length_mm is None else args.length_mm
    free_source = "calibrated (the paper's rig)" if args.length_mm is None else "--length-mm"
    _check("--length-mm", free_mm, 1.0, design.length_m * 1e3, "mm (free length, clamp to tip)")
    rod = tensile_rod(design, pressure_pa, free_mm / 1e3, params)
    sol = rod.solve_lateral_displacement(disp)
    out: dict = {
        "cosserat_force_n": sol.force[1],
        "cosserat_n_per_m": sol.force[1] / disp if disp else float("nan"),
        "tip_x_mm": sol.tip_x * 1e3,
        "tip_y_mm": sol.tip_y * 1e3,
        "tip_angle_deg": math.degrees(sol.tip_angle),
        "max_moment_fraction_of_collapse": sol.max_moment_fraction,
        "wrinkled": sol.wrinkled,
        "kinked": sol.kinked,
        "length_mm": free_mm,
        "pressure_kpa": pressure_pa / 1e3,
        "displacement_mm": disp * 1e3,
    }
    if not args.no_sim and disp != 0:
        from evertgym.sim.tensile import sim_tensile_test

        res = sim_tensile_test(design, disp, pressure_pa, free_mm / 1e3, params=params)
        out.update(sim_force_n=res.force_n, sim_n_per_m=res.n_per_m, sim_converged=res.converged)
    if args.json:
        print(dumps(out))
        return 0
    print(f"free length (clamp to tip): {free_mm:.1f} mm, {free_source}; robot length {design.length_m * 1e3:.0f} mm"
          + (" (from the design file)" if args.design else ""))
    if args.design and args.length_mm is None:
        print("  (the design's own length is not used: pass --length-mm to test another free length)")
    for k, v in out.items():
        print(f"{k:34s} {v:.5g}" if isinstance(v, float) else f"{k:34s} {v}")
    return 0


def cmd_bench_accuracy(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from evertgym.bench.accuracy import default_settings, run_sweep

    settings = default_settings(args.quick)
    with tqdm(total=len(settings), desc="bench accuracy", unit="setting", disable=args.json) as bar:
        result = run_sweep(settings, quick=args.quick, on_row=lambda _row: bar.update(1))
    if args.json:
        print(dumps({"rows": result["rows"], "default": result["default"]}, default=float))
        return 0
    print(f"{'setting':44s} {'force_err':>9s} {'pose_mm':>8s} {'ubend':>6s} {'vs_qs':>6s} {'wall/sim':>9s}")
    current = result["default"].get("simconfig_default")
    for r in result["rows"]:
        mark = " <- SimConfig default" if r["setting"] == current else ""
        print(f"{r.get('label', str(r['setting']))[:44]:44s} {100 * r['tip_force_error']:>8.2f}% {r['tip_pose_error_mm']:>8.2f} "
              f"{r['ubend_disagreement']:>6.2f} {r.get('ubend_disagreement_quasistatic', float('nan')):>6.2f} "
              f"{r['wall_s_per_sim_s']:>9.4f}{mark}")
    print("ubend: share of U-bend outcomes unlike the finest setting's; vs_qs: unlike the quasi-static engine's")
    print(f"default (fastest within 3%): {result['default'].get('label', result['default'])}")
    print("docs/benchmarks.md is written by: python -m evertgym.bench.accuracy_page")
    return 0


def cmd_bench_render(args: argparse.Namespace) -> int:
    from evertgym.bench.render import bench_render, format_render

    rows = bench_render(args.frames)
    print(dumps({"rows": rows}) if args.json else "\n".join(format_render(rows)))
    return 0


def cmd_bench_rod(args: argparse.Namespace) -> int:
    from evertgym.bench.rod import bench_rod, format_rod

    rows = bench_rod(args.repeats)
    print(dumps({"rows": rows}) if args.json else "\n".join(format_rod(rows)))
    return 0


def cmd_bench_peers(args: argparse.Namespace) -> int:
    from evertgym.bench.peers import compare, format_table

    result = compare()
    print(dumps(result) if args.json else "\n".join(format_table(result)))
    return 0


def cmd_bench_pool(args: argparse.Namespace) -> int:
    from evertgym.bench.pool import bench_pool, format_pool

    if args.trials < 1:
        raise CLIError(f"--trials = {args.trials} is out of range: allowed >= 1")
    if not 0.01 <= args.trial_s <= 60:
        raise CLIError(f"--trial-s = {args.trial_s} is out of range: allowed [0.01, 60] s")
    result = bench_pool(args.trials, args.trial_s, real=args.real, dask=not args.no_dask)
    print(dumps(result) if args.json else "\n".join(format_pool(result)))
    return 0


def cmd_bench_env(args: argparse.Namespace) -> int:
    import os

    from evertgym.env import register_envs
    from evertgym.env.bench import bench_env

    if hasattr(os, "sched_setaffinity") and args.one_core:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    steps = args.steps if args.steps is not None else (200 if args.against else 500)
    if args.sim and not args.against:
        raise CLIError("--sim is only used with --against: allowed together with --against REV")
    if args.env_kwargs and not args.against:
        raise CLIError("--env-kwargs is only used with --against: allowed together with --against REV")
    tree_kwargs = {}
    if args.env_kwargs:
        try:
            tree_kwargs = json.loads(args.env_kwargs)
        except json.JSONDecodeError as e:
            raise CLIError(f"--env-kwargs = {args.env_kwargs!r} is not JSON ({e.msg}): allowed a JSON object of env kwargs") from None
        if not isinstance(tree_kwargs, dict) or "sim_config" in tree_kwargs:
            raise CLIError(f"--env-kwargs = {args.env_kwargs!r} is not allowed: a JSON object of env kwargs, sim_config "
                           "left to --sim")
    if not (1 <= steps <= 10**7):
        raise CLIError(f"--steps = {steps} is out of range: allowed [1, 1e7]")
    if not (1 <= args.repeats <= 100):
        raise CLIError(f"--repeats = {args.repeats} is out of range: allowed [1, 100]")
    ids = args.env or register_envs()
    unknown = [e for e in ids if e not in register_envs()]
    if unknown:
        raise CLIError(f"--env = {unknown[0]!r} is not an evertgym env: allowed {', '.join(register_envs())}")
    from tqdm import tqdm

    if args.against:
        from evertgym.bench.against import BuildError, bench_against, format_against

        with tqdm(total=len(ids) * 2 * args.repeats, desc="bench env --against", unit="run", disable=args.json) as bar:
            try:
                result = bench_against(args.against, ids, steps, args.repeats, progress=bar.update, sim=_sim_overrides(args.sim) or None,
                                       env_kwargs=tree_kwargs or None)
            except BuildError as e:
                raise CLIError(str(e)) from None
        print(dumps(result) if args.json else "\n".join(format_against(result)))
        return 0
    args.steps = steps

    rows = [bench_env(env_id, args.steps) for env_id in tqdm(ids, desc="bench env", unit="env", disable=args.json)]
    if args.json:
        print(dumps({"rows": rows}))
        return 0
    print(f"{'env_id':28s} {'steps_per_s':>11s} {'sim_seconds_per_step':>20s} {'steps':>6s}")
    for r in rows:
        print(f"{r['env_id']:28s} {r['steps_per_s']:>11.0f} {r['sim_seconds_per_step']:>20.3f} {r['steps']:>6d}")
    return 0


def sim_overrides(text: str | None, extra: dict | None = None) -> dict:
    """``--sim`` JSON: SimConfig fields, checked before work starts (:func:`evertgym.sim.config.parse_sim`);
    ``extra`` fields are added.  Raises :class:`CLIError`, ``--sim: `` and parse_sim's one line."""
    from evertgym.sim.config import parse_sim

    try:
        return parse_sim(text, extra)
    except ValueError as e:
        raise CLIError(f"--sim: {e}") from None


_sim_overrides = sim_overrides


def _number_list(text: str | None, flag: str, lo: float, hi: float, unit: str) -> list[float] | None:
    """A comma-separated list of numbers in [lo, hi] (``--radii``, ``--reductions``)."""
    if text is None:
        return None
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise CLIError(f"{flag} = {text!r}: expected comma-separated numbers, e.g. 30,25") from None
    if not values:
        raise CLIError(f"{flag} = {text!r}: expected at least one number")
    for v in values:
        _check(flag, v, lo, hi, unit)
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise CLIError(f"{flag} = {text!r}: {', '.join(f'{v:g}' for v in repeated)} given more than once: allowed distinct values")
    return values


def cmd_diagnose(args: argparse.Namespace) -> int:
    from evertgym.experiments.diagnose import plot_trace, trace_ubend

    _check("--radius-mm", args.radius_mm, 20.0, 40.0, "mm")
    _check("--reduction", args.reduction, 0.0, 0.5, "")
    if args.casing_friction is not None:
        _check("--casing-friction", args.casing_friction, 0.0, 5.0, "")
    if args.seed < 0:
        raise CLIError(f"--seed = {args.seed!r} is out of range: allowed integers >= 0")
    sim = _sim_overrides(args.sim, {"engine": "dynamic", "section_law": True} if args.section_law else None)
    scene_params = {"wall_friction": args.casing_friction} if args.casing_friction is not None else None
    trace = trace_ubend(args.radius_mm, args.reduction, args.seed, sim=sim or None, scene_params=scene_params)
    if args.plot:
        plot_trace(trace, args.plot)
    if args.json:
        print(dumps(trace))
        return 0
    s = trace["samples"]
    peak = max(s, key=lambda x: x["tip_force_n"])
    print(f"U-bend {args.radius_mm:g} mm, reduction {args.reduction:g}, trial {args.seed}: "
          f"{'passed' if trace['success'] else 'jammed'} at {s[-1]['insertion_mm']:.0f} mm after {s[-1]['t_s']:.1f} s")
    if peak.get("push_capacity_n") is not None:  # the quasi-static engine
        print(f"largest wall force on the tip {peak['tip_force_n']:.2f} N at {peak['t_s']:.1f} s, {peak['tip_axial_force_n']:.2f} N "
              f"of it against growth (the push the tip could deliver then {peak['push_capacity_n']:.2f} N)")
    else:
        print(f"largest wall force on the tip {peak['tip_force_n']:.2f} N at {peak['t_s']:.1f} s "
              f"(capacity of the weakest section then {peak['tip_capacity_n']:.2f} N)")
    last = s[-1]
    if last["moment_ratio"]:
        j = max(range(len(last["moment_ratio"])), key=lambda k: last["moment_ratio"][k])
        print(f"at the end: peak |M|/M_c {last['moment_ratio'][j]:.2f} at {last['joint_mm'][j]:.0f} mm; "
              f"smallest T_wall {min(last['wall_tension_n']):.2f} N; bands at {trace['bands_mm']} mm")
    if args.plot:
        print(f"figure: {args.plot}")
    return 0


def _stores(args: argparse.Namespace, *flags: str) -> None:
    """``--wait`` for every store the command opens, and each of ``flags``' store identified (read-only)
    before any work: a file that is not an evertgym store of this version is refused unchanged."""
    from evertgym.cli_guard import check_store
    from evertgym.scoring.store import set_default_wait

    if not (math.isfinite(args.wait) and 0 <= args.wait <= 86400):
        raise CLIError(f"--wait = {args.wait} is out of range: allowed [0, 86400] s")
    set_default_wait(args.wait)
    for flag in flags:
        value = getattr(args, flag.lstrip("-").replace("-", "_"))
        if value is not None:
            check_store(flag, value)


def _physics(sim: dict | None) -> str:
    """Which physics (engine, the adopted bend model and what it was fitted on) a result was made with."""
    from evertgym.experiments.bend_model import physics_note

    return physics_note(sim)


_TABLE_START, _TABLE_END = "<!-- likelihood table: evertgym bands fit -->", "<!-- end of likelihood table -->"


def _write_table(path: Path, table: str) -> None:
    """Write the likelihood table to ``path``: between its markers where the page has them, else the whole file."""
    text = path.read_text() if path.exists() else ""
    if _TABLE_START in text and _TABLE_END in text:
        head, rest = text.split(_TABLE_START, 1)
        _, tail = rest.split(_TABLE_END, 1)
        path.write_text(f"{head}{_TABLE_START}\n{table}{_TABLE_END}{tail}")
    else:
        path.write_text(table)


def cmd_bands_fit(args: argparse.Namespace) -> int:
    from evertgym.experiments.bend_model import CANDIDATES, candidate, likelihood_table, run_study, select, write_model
    from evertgym.limits import check_workers
    from evertgym.sim.variation import BEND_MODEL_PATH

    check_workers(args.workers, args.force_workers, "--workers")
    names = [c.name for c in CANDIDATES] if args.candidates is None else [n.strip() for n in args.candidates.split(",")]
    for name in names:
        try:
            candidate(name)
        except ValueError as e:
            raise CLIError(f"--candidates: {e}") from None
    if len(set(names)) != len(names):
        raise CLIError(f"--candidates = {args.candidates!r} names a candidate twice")
    study = run_study(names, args.db, args.summary, workers=args.workers, progress=not args.json)
    best = select(study)
    beats = best["loglik_prediction"] > study["previous"]["loglik_prediction"]
    table = likelihood_table(study)
    if args.out:
        _write_table(Path(args.out), table)
    adopted = None
    if args.adopt and beats:
        write_model(best, BEND_MODEL_PATH)
        adopted = best["candidate"]
    if args.json:
        print(dumps({**study, "best": best["candidate"], "beats_previous": beats, "adopted": adopted}, default=float))
        return 0
    print(table, end="")
    print(f"best by prediction log-likelihood among those meeting the 20%/30% order: ({best['candidate']}) {best['label']}: "
          f"{best['loglik_prediction']:.2f} against "
          f"{study['previous']['loglik_prediction']:.2f} for the engine before the bend model"
          + (f"; adopted, written to {BEND_MODEL_PATH}" if adopted else ("" if beats else "; it does not beat it: nothing adopted")))
    return 0


def cmd_bands_critical(args: argparse.Namespace) -> int:
    from evertgym.experiments.bend_model import critical_friction, critical_text, robot_means
    from evertgym.experiments.paper import UBEND_RADII_MM
    from evertgym.limits import check_workers
    from evertgym.sim.variation import bend_model

    check_workers(args.workers, args.force_workers, "--workers")
    sim = _sim_overrides(args.sim)
    radii = _number_list(args.radii, "--radii", 20.0, 40.0, "mm") or list(UBEND_RADII_MM)
    if not (math.isfinite(args.reduction) and 0.0 <= args.reduction <= 0.5):
        raise CLIError(f"--reduction = {args.reduction} is out of range: allowed [0, 0.5]")
    _stores(args, "--db")
    switches = {**bend_model()["switches"], **sim}
    f = critical_friction(args.db, switches, [(args.reduction, r) for r in radii], args.workers, not args.json)
    if args.json:
        print(dumps({"physics": _physics(sim or None), "cells": [
            {"reduction": red, "radius_mm": r, "robot_means": robot_means(v), "trials": [float(x) for x in v]} for (red, r), v in f.items()]}))
        return 0
    print("\n".join(critical_text(f)))
    print(_physics(sim or None))
    return 0


def cmd_reproduce_ubend(args: argparse.Namespace) -> int:
    from evertgym.experiments.paper import plot_ubend, reproduce_ubend

    if not (1 <= args.trials <= 1000):
        raise CLIError(f"--trials = {args.trials} is out of range: allowed [1, 1000]")
    from evertgym.limits import check_workers

    check_workers(args.workers, args.force_workers, "--workers")
    from evertgym.experiments.paper import UBEND_RADII_MM, UBEND_REDUCTIONS

    sim = _sim_overrides(args.sim)
    _stores(args, "--db")
    radii = _number_list(args.radii, "--radii", 20.0, 40.0, "mm") or UBEND_RADII_MM
    reductions = _number_list(args.reductions, "--reductions", 0.0, 0.5, "") or UBEND_REDUCTIONS
    result = reproduce_ubend(args.db, trials=args.trials, backend=args.backend, workers=args.workers, progress=not args.json,
                             sim=sim or None, radii=radii, reductions=reductions)
    if args.plot:
        plot_ubend(result, args.plot)
    if args.json:
        out = {"rows": result["rows"], "unconverged_solves": result["solves"]["solve_failures"]}
        if result["solves"]["solves"]:  # the quasi-static engine's equilibrium solves and how many ended above tolerance
            out["solves"] = result["solves"]
        if args.anatomy:
            out["jam_anatomy"] = result["jams"]
        out["physics"] = _physics(sim)
        print(dumps(out))
        return 0
    radii = sorted({r["radius_mm"] for r in result["rows"]}, reverse=True)
    reds = sorted({r["reduction"] for r in result["rows"]})
    cell = {(r["reduction"], r["radius_mm"]): r for r in result["rows"]}
    print("U-bend at 3 kPa: successes / trials per inner radius (mm)")
    print(f"{'design':>10} " + " ".join(f"{r:>6g}" for r in radii) + f" {'total':>6} {'unconverged':>11}")
    for red in reds:
        cells = [cell[(red, r)] for r in radii]
        name = "no bands" if red == 0 else f"3 x {round(red * 100)}%"
        print(f"{name:>10} " + " ".join(f"{c['successes']:>3}/{c['trials']:<2}" for c in cells) + f" {sum(c['successes'] for c in cells):>6}"
              + f" {sum(c.get('unconverged_solves', 0) for c in cells):>11}")
    print("unconverged: the quasi-static solves of the row's trials that ended above the tolerance (0: every outcome "
          "is the physics', not the solver settings')")
    sv = result["solves"]
    if sv["solves"]:
        print(f"equilibrium solves: {sv['solves']}, ended above the tolerance: {sv['solve_failures']} "
              f"({100 * sv['failure_share']:.3f}%, in {sv['trials_with_failures']} trials; largest residual "
              f"{sv['max_residual_ratio']:.2g} of p pi r^2); increments retried at half length: {sv['solve_retries']}, "
              f"solves rerun with a larger Newton budget: {sv['solve_escalations']}, "
              f"rerun seeing farther walls: {sv['solve_reselections']}, "
              f"friction lag still changing after its re-solves: {sv['friction_lag_unconverged']}")
    print(f"time: {result['wall_s']:.1f} s (store: {args.db})")
    print(_physics(sim))
    if args.anatomy:
        from evertgym.experiments.paper import ubend_jam_table

        print("\nWhere the failed trials jammed (medians; docs/scoring.md explains the columns):\n")
        print(ubend_jam_table(result["jams"]), end="")
    return 0


def cmd_reproduce_colon(args: argparse.Namespace) -> int:
    from evertgym.experiments.paper import reproduce_colon

    sim = _sim_overrides(args.sim)
    _stores(args, "--db")
    result = reproduce_colon(args.db, progress=not args.json, sim=sim or None)
    if args.plot:
        from evertgym.experiments.plots import plot_pressure_position

        plot_pressure_position(result["rows"], args.plot)
    if args.json:
        keys = ("reduction", "passed", "stall_position_mm", "peak_pressure_kpa", "unconverged_solves") + (("jam",) if args.anatomy else ())
        print(dumps({"rows": [{k: r[k] for k in keys} for r in result["rows"]], "physics": _physics(sim)}))
        return 0
    print("Colon phantom, operator protocol (2 kPa, +0.5 kPa per 1 s stall, up to 8 kPa)")
    for r in result["rows"]:
        name = "no bands" if r["reduction"] == 0 else f"3 x {round(r['reduction'] * 100)}%"
        stall = "-" if r["stall_position_mm"] is None else f"{r['stall_position_mm']:.0f} mm"
        print(f"{name:>10}: passed={r['passed']} stall={stall} peak={r['peak_pressure_kpa']:.2f} kPa "
              f"unconverged solves={r.get('unconverged_solves', 0)}")
        if args.anatomy and r["jam"]:
            j = r["jam"]
            print(f"{'':>12}jam: tip {j['heading_error_deg']:+.1f} deg off the channel, wall pushes back {j['tip_axial_force_n']:.2f} N "
                  f"along the tip, free span {j['free_span_mm']:.1f} mm, span max M/Mc {j['span_peak_moment_ratio']:.2f}, "
                  f"pressure margin {j['pressure_margin_kpa']:+.2f} kPa")
    print(_physics(sim))
    return 0


def _policy_arg(text: str) -> dict:
    """``operator``, ``constant:pressure_kpa=3``, a JSON object or a saved model path."""
    from evertgym.agents.policies import policy_desc

    text = text.strip()
    if text.startswith("{"):
        try:
            parsed = json.loads(text)
        except json.JSONDecodeError as e:
            raise CLIError(f"--policy = {text!r}: malformed JSON: {e}") from None
        return parsed
    try:
        return policy_desc(text)
    except ValueError as e:
        raise CLIError(f"--policy: {e}") from None


def _warn_unconverged(rows: list[dict]) -> None:
    """One line when any trial had a solve that ended above the tolerance: its outcome may be the solver's."""
    trials = sum(r.get("trials_unconverged", 0) for r in rows)
    if trials:
        print(f"warning: {trials} trial(s) had {sum(r.get('unconverged_solves', 0) for r in rows)} unconverged solve(s): their outcomes "
              "may depend on the solver settings (--sim), not the physics; see docs/robustness.md")


def _differences(rows: list[dict], names: list[str]) -> list[dict]:
    """The first of ``names`` against each other one: success-rate difference with its
    Newcombe 95% interval and verdict (:func:`evertgym.scoring.stats.compare_rates`)."""
    from evertgym.scoring.stats import compare_rates

    by_name = {r["design_name"]: r for r in rows}
    names = [name for name in names if name in by_name]  # a design without trials has no rate
    if not names:
        return []
    first = by_name[names[0]]
    return [compare_rates(names[0], first["successes"], first["n"], name, by_name[name]["successes"], by_name[name]["n"])
            for name in names[1:]]


def _print_differences(differences: list[dict]) -> None:
    """One line per comparison: the difference, its interval and the verdict."""
    for c in differences:
        print(f"{c['design']} - {c['other']}: {c['difference']:+.2f} [{c['ci_lo']:+.2f}, {c['ci_hi']:+.2f}] (Newcombe 95%); {c['verdict']}")


def cmd_score(args: argparse.Namespace) -> int:
    from evertgym.cli_guard import check_score_flags
    from evertgym.design import TubeDesign
    from evertgym.experiments.sweep import design_from_flags, plot_summary, sweep_specs
    from evertgym.experiments.trial import run_trial, trusted_run_trial
    from evertgym.scoring.runner import run_trials
    from evertgym.scoring.stats import summarize
    from evertgym.scoring.store import ResultStore

    designs: dict[str, dict] = {}
    for path in args.design or []:
        designs[Path(path).stem] = TubeDesign.load(check_input_file("--design", path)).to_dict()
    if args.bands_mm is not None or not designs:
        bands = _float_list("--bands-mm", args.bands_mm or "")
        red = _check("--reduction", args.reduction, 0.0, 0.6, "(fraction of the diameter)", hi_open=True)
        name = f"{len(bands)} x {round(red * 100)}%" if bands else "no bands"
        designs[name] = design_from_flags(args.diameter_mm, args.length_mm, bands, red)
    try:
        params = json.loads(args.scene_params)
    except json.JSONDecodeError as e:
        raise CLIError(f"--scene-params = {args.scene_params!r}: malformed JSON: {e}") from None
    episode = {"max_s": args.max_s, "band_offset_mm": [-args.band_jitter_mm, args.band_jitter_mm], "entry_offset_mm": [-5.0, 5.0],
               "sim": _sim_overrides(args.sim)}
    policy = check_score_flags(args, designs, params, episode, _policy_arg(args.policy))
    _stores(args, "--db")
    specs = sweep_specs(designs, {"family": args.scene, "params": params}, args.scenes, args.trials, policy, episode)
    Path(args.db).parent.mkdir(parents=True, exist_ok=True)
    with ResultStore(args.db) as store:
        kw = {"address": args.address} if args.address else {"workers": args.workers}
        trial_fn = trusted_run_trial if args.trust_model else run_trial  # trust from the flag, never from the spec
        records = run_trials(specs, trial_fn, store, backend=args.backend, progress=not args.json, **kw)
    rows = summarize(records, by="design_name")
    differences = _differences(rows, list(designs))
    policy = _policy_arg(args.policy)
    policy_text = policy.get("path") or ", ".join([policy["name"]] + [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                                      for k, v in policy.items() if k != "name"])
    scene_text = f"{args.scene} {json.dumps(params)}" if params else f"{args.scene} (default parameters)"
    if args.plot:
        plot_summary(rows, args.plot, title=f"{scene_text}; policy {policy_text}; "
                                            f"{args.scenes} scenes x {args.trials} trials per design")
    if args.json:
        print(dumps({"rows": rows, "differences": differences, "physics": _physics(episode["sim"]),
                     "unconverged_solves": sum(r["unconverged_solves"] for r in rows),
                     "trials_unconverged": sum(r["trials_unconverged"] for r in rows)}, default=float))
        return 0
    print(f"policy: {policy_text}")
    print(f"scene:  {scene_text}, seeds 0-{args.scenes - 1}; {args.trials} trials per scene "
          f"(bands +/- {args.band_jitter_mm:g} mm, entry +/- 5 mm), limit {args.max_s:g} s")
    print(f"designs: {len(designs)}, {len(specs)} trials in all")
    width = max([14] + [len(name) for name in designs])
    print(f"{'design':>{width}} {'n':>5} {'success':>8} {'95% CI':>15} {'time_s':>7} {'peak_kpa':>9} {'max_force_n':>11} "
          f"{'unconverged':>11}   (medians; unconverged: solves above the tolerance, in all trials)")
    by_name = {r["design_name"]: r for r in rows}
    for r in (by_name[name] for name in designs if name in by_name):  # in the order given: the first is the reference
        t, pk, f = ("-" if r.get(k) is None else f"{r[k]:.2f}" for k in ("median_time_s", "median_peak_pressure_kpa", "median_max_contact_force_n"))
        ci = f"[{r['success_ci_lo']:.2f}, {r['success_ci_hi']:.2f}]"
        print(f"{r['design_name']:>{width}} {r['n']:>5} {r['success_rate']:>8.2f} {ci:>15} {t:>7} {pk:>9} {f:>11} {r['unconverged_solves']:>11}")
    _print_differences(differences)
    _warn_unconverged(rows)
    print(f"store: {args.db}" + (f"; plot: {args.plot}" if args.plot else ""))
    print(_physics(episode["sim"]))
    return 0


def cmd_optimize(args: argparse.Namespace) -> int:
    from evertgym.experiments.optimize import BARE_NAME, PAPER_NAME, optimize_bands, study_text

    try:
        params = json.loads(args.scene_params)
    except json.JSONDecodeError as e:
        raise CLIError(f"--scene-params = {args.scene_params!r}: malformed JSON: {e}") from None
    from evertgym.cli_guard import check_optimize_flags

    sim = _sim_overrides(args.sim)
    check_optimize_flags(args, params, sim)
    _stores(args)
    out = optimize_bands(
        {"family": args.scene, "params": params}, args.study, args.db, n_trials=args.trials, n_scenes=args.scenes,
        trials_per_scene=args.trials_per_scene, held_out_scenes=args.held_out, budget_kpa=args.budget_kpa,
        policy=args.policy, diameter_mm=args.diameter_mm, length_mm=args.length_mm, max_s=args.max_s, backend=args.backend,
        progress=not args.json, sim=sim,
    )
    # the best against the paper's design and the bare robot, and the paper's design against the bare robot
    out["differences"] = (_differences(out["held_out"], ["best", PAPER_NAME, BARE_NAME])
                          + _differences(out["held_out"], [PAPER_NAME, BARE_NAME]))
    if args.json:
        print(dumps({**out, "physics": _physics(sim)}, default=float))
        return 0
    print(study_text(out["study"]))
    print(out["objective"])
    print(f"best after {out['trials']} designs: {_best_design_text(out['best_design'], out['best_params'])}")
    print("held-out scenes:")
    for r in out["held_out"]:
        print(f"  {r['design_name']:>24}: success {r['success_rate']:.2f} [{r['success_ci_lo']:.2f}, {r['success_ci_hi']:.2f}] (n={r['n']}), "
              f"unconverged solves {r.get('unconverged_solves', 0)}")
    _print_differences(out["differences"])
    _warn_unconverged(out["held_out"])
    print(_physics(sim))
    return 0


def _best_design_text(design: dict, params: dict) -> str:
    """The bands the search found; without bands, spacing and reduction are absent, not numbers."""
    bands = design["bands"]
    if not bands:
        return f"no bands (n_bands = {params['n_bands']}; spacing, reduction and last band: absent)"
    where = ", ".join(f"{b['position_mm']:.0f}" for b in bands)
    spacing = f", spacing {params['spacing_mm']:.1f} mm" if len(bands) > 1 else ""
    return f"{len(bands)} band{'s' if len(bands) > 1 else ''} at {where} mm from the base{spacing}, reduction {params['reduction']:.3f}"


def cmd_train(args: argparse.Namespace) -> int:
    from evertgym.agents.train import run_status, train

    status = run_status(args.config, args.out, args.seed, args.timesteps)
    if status["finished"]:
        print(f"evertgym: {status['run_dir']} is already trained to {status['n_timesteps']} steps: nothing to do "
              f"(remove the folder, or pass --out or --seed, to train again)", file=sys.stderr)
    elif status["checkpoint_steps"] is not None:
        print(f"evertgym: resuming {status['run_dir']} from its checkpoint at {status['checkpoint_steps']} of "
              f"{status['n_timesteps']} steps (remove the folder to train from step 0)", file=sys.stderr)
    elif args.resume:
        raise CLIError(f"--resume: {status['run_dir']} has no complete checkpoint: allowed without --resume (a fresh run)")
    summary = train(args.config, out_dir=args.out, resume=None, progress=args.progress and not args.json, seed=args.seed,
                    timesteps=args.timesteps)
    if args.json:
        print(dumps(summary, indent=2))
        return 0
    run_dir = Path(summary["run_dir"])
    if not summary["already_trained"]:
        start = summary.get("resumed_from_steps") or 0
        steps = (f"{summary['num_timesteps'] - start} env steps (from the checkpoint at {start} to {summary['num_timesteps']})"
                 if start else f"{summary['num_timesteps']} env steps")
        print(f"trained {steps} in {summary['train_wall_s'] / 60:.1f} min; model: {run_dir / 'final.zip'} "
              f"(TensorBoard: tensorboard --logdir {run_dir / 'tb'})")
    else:
        print(f"{summary['num_timesteps']} env steps; model: {run_dir / 'final.zip'}")
    rows = summary.get("eval", [])
    width = max([40] + [len(r["policy"]) for r in rows])
    for r in rows:
        print(f"  {r['policy']:{width}s} success {r['success_rate']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] "
              f"over {r['episodes']} held-out episodes")
    return 0


def cmd_tune(args: argparse.Namespace) -> int:
    from evertgym.agents.tuned import shipped_dir, tune_operator, tuned_path
    from evertgym.cli_guard import check_env_id
    from evertgym.limits import MAX_EPISODES

    check_env_id("--env", args.env)
    if not 1 <= args.episodes <= MAX_EPISODES:
        raise CLIError(f"--episodes = {args.episodes} is out of range: allowed [1, {MAX_EPISODES}]")
    out = Path(args.out) if args.out else tuned_path(args.env, shipped_dir())
    result = tune_operator(args.env, args.episodes, log=out.with_suffix(".jsonl"),
                           on_result=None if args.json else (lambda rec: print(dumps(rec), flush=True)))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    if args.json:
        print(dumps({**result, "out": str(out)}))
        return 0
    print("best:", dumps(result["best"]))
    print(f"-> {out} (the tuned baseline loads it on {args.env})")
    return 0


def cmd_baselines(args: argparse.Namespace) -> int:
    from evertgym.agents.baseline_table import run

    return run(args)


def cmd_headroom(args: argparse.Namespace) -> int:
    from evertgym.agents.headroom import run

    return run(args)


def cmd_compare_runs(args: argparse.Namespace) -> int:
    from evertgym.agents.compare import main as compare

    return compare(args.first, args.second)


def cmd_paired(args: argparse.Namespace) -> int:
    from evertgym.agents.stored import paired_difference, parse_env_kwargs
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE

    env_kwargs = parse_env_kwargs("--env-kwargs", args.env_kwargs, args.env)
    seed_base = VALIDATION_SEED_BASE if args.validation else HELD_OUT_SEED_BASE
    print("\n".join(paired_difference(args.env, args.a, args.b, args.key, args.episodes, env_kwargs, seed_base)))
    return 0


def cmd_eval(args: argparse.Namespace) -> int:
    from evertgym.agents.evaluate import OUTCOME_CHECKS, evaluate, outcome_check_kwargs
    from evertgym.agents.policies import on_trained_engine
    from evertgym.cli_guard import check_eval_flags
    from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE, engine_of

    given = check_eval_flags(args)
    _stores(args)
    env_kwargs = on_trained_engine(args.policies, given, args.allow_engine_mismatch)
    seed_base = VALIDATION_SEED_BASE if args.validation else HELD_OUT_SEED_BASE
    rows = evaluate(args.policies, args.env, args.episodes, env_kwargs=env_kwargs, workers=args.workers,
                    trust=args.trust_model, progress=not args.json, seed_base=seed_base, db=args.db,
                    check_outcomes=args.check_outcomes, allow_engine_mismatch=args.allow_engine_mismatch)
    engine = engine_of(env_kwargs or {})
    own = " (the trained policies' own)" if env_kwargs != given else ""
    if args.json:
        extra = {}
        if args.check_outcomes:
            extra["outcome_checks"] = [{name: kw["sim_config"][name]} for (name, _), kw
                                       in zip(OUTCOME_CHECKS, outcome_check_kwargs(env_kwargs))]
        print(dumps({"rows": rows, "seed_base": seed_base, "env_id": args.env, "env_kwargs": env_kwargs or {}, "engine": engine,
                     **extra}))
        return 0
    print(f"{'validation' if args.validation else 'held-out'} episodes: episode and scene seeds {seed_base}-{seed_base + args.episodes - 1}, "
          f"{engine} engine{own}")
    width = max([30] + [len(r["policy"]) for r in rows])  # a name is never cut
    print(f"{'policy':{width}s} {'episodes':>8s} {'passed':>6s} {'success':>8s} {'95% CI':>14s} {'time_to_goal_s':>14s} "
          f"{'peak_kpa':>9s} {'max_force_n':>11s} {'bend_peak_kpa':>13s} {'peak<bend':>9s}")
    for r in rows:
        print(
            f"{r['policy']:{width}s} {r['episodes']:>8d} {r['successes']:>6d} {r['success_rate']:>8.3f} "
            f"[{r['ci_low']:.3f}, {r['ci_high']:.3f}]".ljust(width + 40)
            + f" {r['mean_time_to_goal_s']:>14.2f} {r['mean_peak_pressure_kpa']:>9.2f} {r['mean_max_contact_force_n']:>11.2f}"
            + f" {r['mean_peak_pressure_bend_kpa']:>13.2f} {r['peak_before_bend_episodes']:>9d}"
        )
    print("bend_peak_kpa: peak measured pressure with the tip in the scene's bend (mean over the episodes that reached it); "
          "peak<bend: episodes whose peak came before the bend (start-up or approach)")
    for r in rows:
        if r.get("unconverged_solves"):
            print(f"warning: {r['policy']}: {r.get('episodes_unconverged')} episode(s) had {r['unconverged_solves']} unconverged solve(s): "
                  "their outcomes may depend on the solver settings, not the physics")
    if args.check_outcomes:
        checks = ", ".join(f"{name} / {d:g}" for name, d in OUTCOME_CHECKS)
        print(f"outcome check: every episode replayed with {checks}; an undecided episode's outcome moves with them")
        for r in rows:
            seeds = " ".join(str(s - seed_base) for s in r["undecided_seeds"][:20]) + (" ..." if r["undecided_episodes"] > 20 else "")
            print(f"  {r['policy']:{width}s} undecided {r['undecided_episodes']:>3d} of {r['episodes']}, success between "
                  f"{r['success_low']:.3f} and {r['success_high']:.3f}" + (f" (episodes {seeds}, as offsets from {seed_base})" if seeds else ""))
    return 0


def cmd_policies(args: argparse.Namespace) -> int:
    from evertgym.agents.policies import policy_cards

    rows = policy_cards()
    if args.json:
        print(dumps({"rows": rows}))
        return 0

    def shown(path: str | None) -> str:  # relative to here when the file is below this folder
        if path is None:
            return "-"
        p = Path(path)
        return str(p.relative_to(Path.cwd())) if p.is_relative_to(Path.cwd()) else str(p)

    import textwrap

    from evertgym.sim.growth import MAX_PRESSURE_PA

    kpa_per_action = MAX_PRESSURE_PA / 1e3 / 2  # an action unit in kPa: a in [-1, 1] spans 0-8 kPa
    print(f"{'policy':30s} {'env':16s} {'trained on':12s} held-out success (Wilson 95%), engine")
    for r in rows:
        h = r["held_out"]
        held = "-" if h is None else f"{h['successes']}/{h['episodes']} [{h['ci_low']:.2f}, {h['ci_high']:.2f}] on {h['engine']}"
        env = (r["env_id"] or "-").removeprefix("evertgym/")
        print(f"{r['name']:30s} {env:16s} {r['engine']:12s} {held}")
        obs = ", ".join(f"{k}={json.dumps(v)}" for k, v in r["observations"].items()) or "the env's defaults"
        if r["senses_tip"]:
            obs += " (senses the tip)"
        acts = "its mean action" if r["deterministic"] else "a sampled action"
        if r["residual"] is not None:
            acts += f", correcting {r['residual']['rule']} by at most {r['residual']['scale'] * kpa_per_action:g} kPa"
        details = [f"observes {obs}; plays {acts}", f"trained from {shown(r['config'])}"]
        if h is not None and h["env_kwargs"]:
            details[-1] += "; held out with " + ", ".join(f"{k}={json.dumps(v)}" for k, v in h["env_kwargs"].items())
        for line in details:
            print(textwrap.fill(line, width=100, initial_indent="    ", subsequent_indent="      "))
    print("use one by name: evertgym eval NAME --env ENV, evertgym rollout NAME --env ENV --out x.gif,\n"
          "load_policy(NAME) in Python (docs/agents.md); each runs on the engine it was trained on")
    return 0


def cmd_rollout(args: argparse.Namespace) -> int:
    from evertgym.agents.policies import on_trained_engine
    from evertgym.agents.rollout import rollout_gif
    from evertgym.cli_guard import check_rollout_flags
    from evertgym.env.eversion_env import engine_of

    env_kwargs = on_trained_engine([args.policy], check_rollout_flags(args), args.allow_engine_mismatch)
    info = rollout_gif(args.policy, args.env, args.out, seed=args.seed, trust=args.trust_model, progress=not args.json,
                       env_kwargs=env_kwargs, allow_engine_mismatch=args.allow_engine_mismatch)
    if args.json:
        print(dumps(info))
        return 0
    cmd = np.asarray(info["command_kpa"])
    print(f"held-out episode {args.seed} (seed {info['episode_seed']}): "
          f"{'success' if info['success'] else 'no success'} after {info['time_s']:.1f} s ({len(cmd)} control steps); "
          f"peak pressure {info['peak_pressure_kpa']:.2f} kPa; {engine_of(env_kwargs)} engine")
    if len(cmd):
        print(f"pressure command: mean {cmd.mean():.2f} kPa, range {cmd.min():.2f}-{cmd.max():.2f} kPa "
              "(--json lists every step)")
    print(f"{info['frames']} frames -> {info['out']}")
    return 0


_ENGINE_HELP = ("run a trained model on another simulator engine than the one it was trained on (without it, the episodes run "
                "on the model's own engine, and --env-kwargs naming another engine is refused)")


def build_parser() -> argparse.ArgumentParser:
    from evertgym._version import __version__

    p = _Parser(prog="evertgym", description=__doc__)
    p.add_argument("--version", action="version", version=f"evertgym {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    rep = _sub(sub, "reproduce", "reproduce a figure or table of the paper")
    rep_sub = rep.add_subparsers(dest="target", required=True)
    rs = _sub(rep_sub, "stiffness", "Exp 1-3: stiffness index per row, model against measured")
    rs.add_argument("--json", action="store_true", help=_JSON_HELP)
    rs.add_argument("--plot", default=None, help="write a force-displacement plot (PNG) here")
    rs.add_argument("--no-sim", action="store_true", help="skip the pymunk simulator's columns")
    rs.set_defaults(func=cmd_reproduce_stiffness)

    dg = _sub(sub, "diagnose", "the section law over time for one U-bend trial: wall tension, M/M_c, tip force vs capacity")
    dg.add_argument("--radius-mm", type=float, default=30.0, help="U-bend inner radius (mm), [20, 40]")
    dg.add_argument("--reduction", type=float, default=0.0, help="band reduction of the 3-band design (0: no bands)")
    dg.add_argument("--seed", type=int, default=0, help="trial number of reproduce ubend (its seed)")
    dg.add_argument("--section-law", action="store_true", help="simulate with the section law (SimConfig(section_law=True))")
    dg.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"bend_loss_per_rad": 0.6}\'')
    dg.add_argument("--casing-friction", type=float, default=None, help="the U-bend casing's friction factor (default: the family's)")
    dg.add_argument("--plot", default=None, help="write the figure here (PNG)")
    dg.add_argument("--json", action="store_true", help="print the trace as JSON")
    dg.set_defaults(func=cmd_diagnose)

    ru = _sub(rep_sub, "ubend", "validation experiment: U-bend success rates (Fig. 4d)")
    ru.add_argument("--json", action="store_true", help=_JSON_HELP)
    ru.add_argument("--trials", type=int, default=12, help="trials per design and radius")
    ru.add_argument("--db", default="runs/reproduce_ubend.sqlite", help="result store (resumable)")
    ru.add_argument("--backend", choices=["process", "serial", "dask"], default="process", help=_BACKEND_HELP)
    ru.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core)")
    ru.add_argument("--force-workers", action="store_true", help="allow more --workers than CPUs")
    ru.add_argument("--plot", default=None, help="write the success-rate plot (PNG) here")
    ru.add_argument("--anatomy", action="store_true",
                    help="also where the failed trials jammed (free span, tip angle, M/Mc at the bands); "
                         "--json adds it under 'jam_anatomy'")
    ru.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"engine": "dynamic"}\'')
    ru.add_argument("--radii", default=None, help="inner radii (mm) to run, comma-separated (default: the paper's 40..20 mm)")
    ru.add_argument("--reductions", default=None, help="band reductions to run, comma-separated, 0 = no bands (default: 0,0.1,0.2,0.3)")
    ru.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    ru.set_defaults(func=cmd_reproduce_ubend)

    bd = _sub(sub, "bands", "the calibrated bend model: fit its candidates and rank them by likelihood")
    bd_sub = bd.add_subparsers(dest="target", required=True)
    bf = _sub(bd_sub, "fit", "fit every candidate bend model on the paper's calibration cells and rank them by the "
                             "binomial log-likelihood of its prediction cells (resumable)")
    bf.add_argument("--candidates", default=None, help="comma-separated candidate names (default: all of docs/bands.md's)")
    bf.add_argument("--db", default="runs/bands.sqlite", help="result store of every trial (resumable)")
    bf.add_argument("--summary", default="runs/bands_candidates.json", help="per-candidate summaries kept as they finish")
    bf.add_argument("--out", default=None, help="write the likelihood table (markdown) here: between the page's table markers "
                                                "where it has them (docs/bands.md), else the whole file")
    bf.add_argument("--adopt", action="store_true",
                    help="write the best candidate to evertgym/data/bend_model.json if it beats the engine before the bend model")
    bf.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core)")
    bf.add_argument("--force-workers", action="store_true", help="allow more --workers than CPUs")
    bf.add_argument("--json", action="store_true", help=_JSON_HELP)
    bf.set_defaults(func=cmd_bands_fit)
    bc = _sub(bd_sub, "critical", "each U-bend trial's critical friction factor (the friction at which it stops passing), by "
                                  "bisection on the default model, per robot and trial (resumable): how close a cell is to its knife edges")
    bc.add_argument("--radii", default=None, help="inner radii (mm) to run, comma-separated, [20, 40] (default: the paper's nine)")
    bc.add_argument("--reduction", type=float, default=0.0, help="the three bands' reduction, [0, 0.5] (default 0: no bands)")
    bc.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"segment_length_m": 0.00375}\'')
    bc.add_argument("--db", default="runs/bands_critical.sqlite", help="result store of every trial (resumable)")
    bc.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    bc.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core)")
    bc.add_argument("--force-workers", action="store_true", help="allow more --workers than CPUs")
    bc.add_argument("--json", action="store_true", help=_JSON_HELP)
    bc.set_defaults(func=cmd_bands_critical)

    rc = _sub(rep_sub, "colon", "colon phantom case study (Fig. 5d)")
    rc.add_argument("--json", action="store_true", help=_JSON_HELP)
    rc.add_argument("--db", default="runs/reproduce_colon.sqlite", help="result store (resumable)")
    rc.add_argument("--plot", default=None, help="write the pressure-position plot (PNG) here")
    rc.add_argument("--anatomy", action="store_true", help="also where a stalled robot jammed (--json: each row's 'jam')")
    rc.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"engine": "dynamic"}\'')
    rc.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    rc.set_defaults(func=cmd_reproduce_colon)

    rv = _sub(rep_sub, "eversion", "Exp 4: minimum eversion pressure per band reduction, simulated")
    rv.add_argument("--json", action="store_true", help=_JSON_HELP)
    rv.add_argument("--step-kpa", type=float, default=0.01, help="pressure step of the protocol (kPa)")
    rv.set_defaults(func=cmd_reproduce_eversion)

    st = _sub(sub, "stiffness", "virtual tensile test of any design")
    st.add_argument("--length-mm", type=float, default=None, help="free length, clamp to tip (default: calibrated, about 200)")
    st.add_argument("--bands-from-tip-mm", default="", help="band centres from the tip, e.g. 50,100")
    st.add_argument("--reduction", type=float, default=0.5, help="band diameter reduction in [0, 0.6)")
    st.add_argument("--pressure-kpa", type=float, default=6.9, help="inflation pressure, [0, 8] kPa")
    st.add_argument("--displacement-mm", type=float, default=20.0, help="lateral tip displacement, |D| <= 60")
    st.add_argument("--diameter-mm", type=float, default=40.0, help="tube diameter (without --design), [1, 500] mm")
    st.add_argument("--design", default=None, help="design file (TOML or JSON) instead of the band flags")
    st.add_argument("--json", action="store_true", help=_JSON_HELP)
    st.add_argument("--no-sim", action="store_true", help="skip the pymunk simulator's figure")
    st.set_defaults(func=cmd_stiffness)
    sc = _sub(sub, "score", "score band designs on a scene distribution (resumable SQLite store)")
    sc.add_argument("--design", action="append", help="a design file (TOML/JSON); repeatable")
    sc.add_argument("--bands-mm", default=None, help="band positions from the base in mm, e.g. 200,250,300; with --design, "
                    "--bands-mm '' adds a bare robot (no bands) beside the design file's")
    sc.add_argument("--reduction", type=float, default=0.1, help="band diameter reduction of --bands-mm, [0, 0.6)")
    sc.add_argument("--diameter-mm", type=float, default=40.0, help="tube diameter of the flag design (mm)")
    sc.add_argument("--length-mm", type=float, default=900.0, help="robot length of the flag design (mm)")
    sc.add_argument("--scene", default="ubend", help=f"scene family: {_scene_families()}")
    sc.add_argument("--scene-params", default="{}", help='JSON, e.g. \'{"radius_mm": 30}\'')
    sc.add_argument("--scenes", type=int, default=5, help="number of scene seeds")
    sc.add_argument("--trials", type=int, default=4, help="trials per scene")
    sc.add_argument("--policy", default="constant:pressure_kpa=3",
                    help="constant:pressure_kpa=3, operator, tuned, cycle:low_kpa=0,high_kpa=3,period_s=1, a .zip, or JSON")
    sc.add_argument("--max-s", type=float, default=20.0, help="time limit per trial (s)")
    sc.add_argument("--band-jitter-mm", type=float, default=25.0, help="band position randomisation (+/- mm)")
    sc.add_argument("--db", default="runs/score.sqlite", help="result store (resumable: finished trials are not rerun)")
    sc.add_argument("--backend", choices=["process", "serial", "dask"], default="process", help=_BACKEND_HELP)
    sc.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core)")
    sc.add_argument("--force-workers", action="store_true", help="allow more --workers than CPUs")
    sc.add_argument("--address", default=None, help="Dask scheduler address (with --backend dask)")
    sc.add_argument("--trust-cluster", action="store_true", help="no warning for a Dask --address that is not local")
    sc.add_argument("--trust-model", action="store_true", help="load a model file that is not a shipped policy: model files are code "
                         "(pickles) and run when loaded")
    sc.add_argument("--plot", default=None, help="write the success-rate plot (PNG) here")
    sc.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"engine": "dynamic"}\' (default: the quasi-static engine)')
    sc.add_argument("--json", action="store_true", help=_JSON_HELP)
    sc.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    sc.set_defaults(func=cmd_score)

    op = _sub(sub, "optimize", "search band designs (optuna) and compare the best with the paper's on held-out scenes")
    op.add_argument("--scene", default="ubend", help=f"scene family: {_scene_families()}")
    op.add_argument("--scene-params", default='{"radius_mm": 30}', help="scene parameters, JSON")
    op.add_argument("--trials", type=int, default=20, help="designs to try")
    op.add_argument("--scenes", type=int, default=4, help="training scene seeds per design")
    op.add_argument("--trials-per-scene", type=int, default=2, help="randomised trials per training scene")
    op.add_argument("--held-out", type=int, default=8, help="held-out scene seeds for the final comparison")
    op.add_argument("--budget-kpa", type=float, default=3.0, help="pressure budget")
    op.add_argument("--policy", choices=["constant", "operator"], default="constant", help="pressure policy of every trial")
    op.add_argument("--diameter-mm", type=float, default=40.0, help="tube diameter of every design (mm), [5, 500]")
    op.add_argument("--length-mm", type=float, default=900.0, help="robot length of every design (mm), [100, 20000]")
    op.add_argument("--max-s", type=float, default=20.0, help="time limit per trial (s), [0.1, 3600]")
    op.add_argument("--study", default="runs/optimize_study.sqlite", help="optuna study (resumable)")
    op.add_argument("--db", default="runs/optimize_trials.sqlite", help="result store of the trials (resumable)")
    op.add_argument("--backend", choices=["process", "serial", "dask"], default="process", help=_BACKEND_HELP)
    op.add_argument("--sim", default=None, help='SimConfig overrides as JSON, e.g. \'{"engine": "dynamic"}\' (default: the quasi-static engine)')
    op.add_argument("--json", action="store_true", help=_JSON_HELP)
    op.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    op.set_defaults(func=cmd_optimize)

    tr = _sub(sub, "train", "train a pressure policy from a config in agents/")
    tr.add_argument("config", help="a shipped config by name (ubend_ppo_operator, colon_residual_operator, ...: the policy it "
                    "trained) or a config file, e.g. agents/tries/ubend_ppo.toml")
    tr.add_argument("--timesteps", type=int, default=None, metavar="N",
                    help="train N env steps instead of the config's n_timesteps, into its own run folder <name>_<N>steps "
                         "(a short try of a config)")
    tr.add_argument("--out", default="runs", help="runs folder")
    tr.add_argument("--resume", action="store_true",
                    help="insist on continuing from the newest checkpoint (fail without one); without it a run folder "
                         "with a checkpoint is continued too, a finished run is not trained again")
    tr.add_argument("--seed", type=int, default=None,
                    help="replace the config's seed; the run goes to <out>/<name>_seed<N> (default: the config's seed)")
    tr.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    tr.add_argument("--json", action="store_true", help="print the summary as JSON (for machines)")
    tr.set_defaults(func=cmd_train)

    tu = _sub(sub, "tune", "tune the operator protocol on an env's training scenes: the tuned baseline's parameters")
    tu.description = (tu.description or "") + (
        ". Every point of a 36-point grid (start pressure, step, stall window, relaxation) runs on the same training "
        "episodes (scene seeds below the held-out base); the best passes most, then has the lowest mean peak pressure. "
        "Each point is appended to OUT.jsonl as it is produced, so a killed search resumes. Cost: 36 x --episodes episodes.")
    tu.add_argument("--env", required=True, help="a registered env id, e.g. evertgym/Colon-v0")
    tu.add_argument("--episodes", type=int, default=8, help="training episodes per grid point")
    tu.add_argument("--out", default=None, metavar="FILE.json",
                    help="result file (default: the env's file among the shipped agents, which `tuned` loads)")
    tu.add_argument("--json", action="store_true", help=_JSON_HELP)
    tu.set_defaults(func=cmd_tune)

    ev = _sub(sub, "eval", "evaluate policies side by side on the same held-out episodes")
    ev.add_argument("policies", nargs="+", help="a baseline (constant, operator, tuned, cycle, deflate), with parameters as "
                    "name:key=value,... (cycle:low_kpa=0,high_kpa=3,period_s=1), a shipped policy or a saved model (.zip)")
    ev.add_argument("--env", required=True, help="a registered env id, e.g. evertgym/Colon-v0")
    ev.add_argument("--episodes", type=int, default=20, help="held-out episodes per policy (the same seeds for each)")
    ev.add_argument("--env-kwargs", default=None, metavar="JSON",
                    help='env arguments for every policy, a JSON object, e.g. \'{"regulator_tau_s": [0.1, 0.6]}\' '
                         "(a randomised regulator lag); a trained model's own observation flags still apply")
    ev.add_argument("--validation", action="store_true",
                    help="play validation episodes (seeds 2e9 + i) instead of the held-out ones (1e9 + i): neither is ever "
                         "a training scene; choose settings (an action mode, a checkpoint) on these, report on held-out")
    ev.add_argument("--json", action="store_true", help=_JSON_HELP)
    ev.add_argument("--db", default=None, metavar="PATH",
                    help="keep every finished episode in this SQLite store, so a killed evaluation resumes "
                         "(an episode's identity holds the engine and a model file's SHA-256)")
    ev.add_argument("--workers", type=int, default=1, help="processes to spread the episodes over")
    ev.add_argument("--force-workers", action="store_true", help="allow more --workers than CPUs")
    ev.add_argument("--trust-model", action="store_true", help="load a model file that is not a shipped policy: model files are code "
                         "(pickles) and run when loaded")
    ev.add_argument("--check-outcomes", action="store_true",
                    help="also replay every episode with the solver tolerance / 10 and the growth increment / 2 (quasi-static "
                         "engine; 3x the time) and report the episodes whose outcome moves with them (undecided)")
    ev.add_argument("--wait", type=float, default=60.0, help="seconds to wait for a store another process holds locked")
    ev.add_argument("--allow-engine-mismatch", action="store_true", help=_ENGINE_HELP)
    ev.set_defaults(func=cmd_eval)

    from evertgym.agents.baseline_table import add_arguments as baselines_arguments
    from evertgym.agents.headroom import add_arguments as headroom_arguments

    bl = _sub(sub, "baselines", "the hand-written rules (and any policies) side by side on the same held-out episodes of "
                                "each env: the tables of docs/results/")
    baselines_arguments(bl)
    bl.set_defaults(func=cmd_baselines)

    hr = _sub(sub, "headroom", "which stored policies pass the held-out episodes a reference policy fails, and what a "
                               "per-episode oracle over them would pass")
    headroom_arguments(hr)
    hr.set_defaults(func=cmd_headroom)

    cr = _sub(sub, "compare-runs", "are two trained policies the same? Their weights (read as tensors only) and their "
                                   "VecNormalize files (by bytes); exit 0 when both are identical, 1 when not")
    cr.add_argument("first", help="a run folder (final.zip and final_vecnormalize.pkl), a shipped policy's folder or a checkpoint zip")
    cr.add_argument("second", help="the same for the other policy")
    cr.set_defaults(func=cmd_compare_runs)

    pa = _sub(sub, "paired", "two policies on the same held-out episodes from evaluation stores (eval --db): the paired "
                             "difference of a per-episode figure (95%% interval, Wilcoxon) and of their successes (McNemar)")
    pa.add_argument("--env", required=True, help="the env id the episodes were played on")
    pa.add_argument("--a", required=True, metavar="STORE:POLICY", help="the first policy's store and name")
    pa.add_argument("--b", required=True, metavar="STORE:POLICY", help="the second policy's store and name")
    pa.add_argument("--key", default="max_contact_force_n", help="the per-episode figure")
    pa.add_argument("--episodes", type=int, default=200, help="held-out episodes to pair (seeds 1e9 + i)")
    pa.add_argument("--validation", action="store_true",
                    help="pair the validation episodes (eval --validation, seeds 2e9 + i) instead of the held-out ones")
    pa.add_argument("--env-kwargs", default=None, metavar="JSON",
                    help='the env kwargs the episodes were played with (default {"regulator_tau_s": [0.1, 0.6]}, or {} for '
                         'an id whose preset draws the lag itself); an outcome check\'s replay adds e.g. '
                         '"sim_config": {"solver_tolerance": 0.0001}')
    pa.set_defaults(func=cmd_paired)

    po = _sub(sub, "policies", "the shipped trained policies: env, observations, training config, held-out success")
    po.add_argument("--json", action="store_true", help=_JSON_HELP)
    po.set_defaults(func=cmd_policies)

    ro = _sub(sub, "rollout", "render one episode to a GIF")
    ro.add_argument("policy", help="a baseline (constant, operator, cycle, deflate, tuned; parameters as cycle:low_kpa=0,high_kpa=3), "
                    "a shipped policy (colon_ppo, colon_ppo_operator, ubend_ppo_operator, ...) or a .zip")
    ro.add_argument("--env", required=True, help="a registered env id, e.g. evertgym/Colon-v0")
    ro.add_argument("--out", required=True, help="FILE.gif")
    ro.add_argument("--seed", type=int, default=0,
                    help="held-out episode k (episode and scene seed 1e9 + k: eval's k-th episode, never a training one)")
    ro.add_argument("--env-kwargs", default=None, metavar="JSON",
                    help='env arguments, a JSON object, e.g. \'{"regulator_tau_s": [0.1, 0.6]}\' (as for eval)')
    ro.add_argument("--json", action="store_true", help="print the outcome and every step's command as JSON")
    ro.add_argument("--trust-model", action="store_true", help="load a model file that is not a shipped policy: model files are code "
                         "(pickles) and run when loaded")
    ro.add_argument("--allow-engine-mismatch", action="store_true", help=_ENGINE_HELP)
    ro.set_defaults(func=cmd_rollout)

    bench = _sub(sub, "bench", "benchmarks")
    bench_sub = bench.add_subparsers(dest="target", required=True)
    ba = _sub(bench_sub, "accuracy", "run time against error over the simulator's fidelity settings")
    ba.add_argument("--quick", action="store_true", help="a smaller sweep")
    ba.add_argument("--json", action="store_true", help=_JSON_HELP)
    ba.set_defaults(func=cmd_bench_accuracy)
    bp = _sub(bench_sub, "peers", "wall time against PyElastica and MuJoCo at 1%% tip-force error "
                                  "(pip install -e '.[bench]')")
    bp.add_argument("--json", action="store_true", help=_JSON_HELP)
    bp.set_defaults(func=cmd_bench_peers)
    bn = _sub(bench_sub, "render", "cost of a rendered frame against an env step (Colon-v0, compliant walls)")
    bn.add_argument("--frames", type=int, default=30, help="calls timed per row (their median is printed)")
    bn.add_argument("--json", action="store_true", help=_JSON_HELP)
    bn.set_defaults(func=cmd_bench_render)
    br = _sub(bench_sub, "rod", "wall time of the Cosserat rod's shooting solve per tensile-test design and tip displacement")
    br.add_argument("--repeats", type=int, default=5, help="solves per case (the median and the least are printed)")
    br.add_argument("--json", action="store_true", help=_JSON_HELP)
    br.set_defaults(func=cmd_bench_rod)
    bo = _sub(bench_sub, "pool", "scoring backends' throughput: serial, process pool (1, 2 workers), Dask; "
                                 "speed-up against 1 worker")
    bo.add_argument("--trials", type=int, default=16, help="trials per backend")
    bo.add_argument("--trial-s", type=float, default=0.3, help="busy-loop trial duration (s)")
    bo.add_argument("--real", action="store_true", help="real U-bend trials instead of a busy loop")
    bo.add_argument("--no-dask", action="store_true", help="skip the Dask rows (they need the test or cluster extra)")
    bo.add_argument("--json", action="store_true", help=_JSON_HELP)
    bo.set_defaults(func=cmd_bench_pool)
    be = _sub(bench_sub, "env", "env steps per second per registered id (random actions, one core)")
    be.add_argument("--steps", type=int, default=None, help="env steps per id and run, [1, 1e7] (default 500; 200 with --against)")
    be.add_argument("--against", metavar="REV", help="compare with git revision REV side by side on one core "
                                                    "(alternating runs, best of --repeats each; prints both and the ratio)")
    be.add_argument("--repeats", type=int, default=5, help="runs per build and id with --against, [1, 100]")
    be.add_argument("--sim", default=None, help='with --against: SimConfig overrides (JSON) for the working tree\'s envs, '
                                               'e.g. \'{"engine": "quasistatic"}\'')
    be.add_argument("--env-kwargs", default=None, help='with --against: other env kwargs (JSON) for the working tree\'s envs, '
                                                      'e.g. \'{"variation": "off"}\' (the physics before the bend model)')
    be.add_argument("--env", action="append", help="an env id (repeatable); default: every registered id")
    be.add_argument("--no-pin", dest="one_core", action="store_false", help="do not pin the process to one core")
    be.add_argument("--json", action="store_true", help=_JSON_HELP)
    be.set_defaults(func=cmd_bench_env)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    no_abbreviations(parser)
    args, extras = parser.parse_known_args(argv)
    if extras:  # a misspelt flag: the subcommand's usage and the nearest flag, not the top-level usage
        import difflib

        sub = getattr(args, "_parser", parser)
        flags = [o for a in sub._actions for o in a.option_strings]
        near = [m for e in extras if e.startswith("-") for m in difflib.get_close_matches(e.split("=")[0], flags, n=1)]
        sub.error(f"unrecognized arguments: {' '.join(extras)}" + (f" (did you mean {', '.join(near)}?)" if near else ""))
    return run_command(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
