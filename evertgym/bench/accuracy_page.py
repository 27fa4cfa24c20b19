"""Accuracy of the simulator's fidelity settings against the rod model, and their cost.

    python -m evertgym.bench.accuracy_page [--quick] [--json FILE] [--log FILE [--resume]] [--docs DIR | --no-docs]
    python -m evertgym.bench.accuracy_page --render FILE [--docs DIR | --no-docs]

Runs :func:`evertgym.bench.accuracy.run_sweep` and :func:`evertgym.bench.accuracy.skip_costs`
(about 4.5 minutes on a 2-core machine; ``--quick`` about 30 s), prints both tables and writes
``DIR/benchmarks.md`` (the tables, the Pareto set, the chosen default, how to regenerate)
and ``DIR/benchmarks_pareto.png`` (error against wall time, Pareto front marked); DIR is
``docs`` unless given.  ``--json`` writes the whole result (the sweep's JSON structure plus
``skip`` and ``meta``).  ``--log`` appends each row to a JSON-lines file as soon as it is
measured, with the command and versions; ``--resume`` reuses the rows already logged there
for the same ``--quick`` and versions.  ``--render FILE`` measures nothing and writes the
tables and docs of a result saved with ``--json``.  Timings are machine dependent; run
nothing else meanwhile.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pymunk  # noqa: E402
import scipy  # noqa: E402

from evertgym.bench.accuracy import FORCE_ERROR_BUDGET, PARETO_RTOL, TIMING_REPEATS, run_sweep, skip_costs  # noqa: E402

COMMAND = "python -m evertgym.bench.accuracy_page"
FIELD_HEADERS = (("segment_length_m", "ds_mm", 1e3, "{:.1f}"), ("dt_s", "dt_ms", 1e3, "{:.0f}"),
                 ("iterations", "iter", 1, "{:.0f}"), ("inertia_factor", "inertia", 1, "{:g}"),
                 ("mass_ratio", "mass", 1, "{:g}"), ("active_length_m", "active_m", 1, "{:g}"))


def versions() -> dict:
    """Versions of what the numbers depend on, and the machine; the commit gets ``+dirty``
    when ``evertgym/`` differs from it."""
    here = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=here, check=True).stdout.strip()
        changed = subprocess.run(["git", "status", "--porcelain", "--", "../evertgym"], capture_output=True,
                                 text=True, cwd=here, check=True).stdout.strip()
        commit += "+dirty" if changed else ""
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "pymunk": pymunk.version, "git_commit": commit, "machine": f"{platform.machine()}, {os.cpu_count()} CPUs"}


def table(rows: list[dict]) -> list[str]:
    """Rows sorted by wall time, as fixed-width text (mm, ms, %)."""
    head = f"{'setting':<46}" + "".join(f"{h:>9}" for _, h, _, _ in FIELD_HEADERS)
    head += f"{'force_err':>10}{'pose_mm':>8}{'ubend':>7}{'vs_qs':>7}{'overlap':>8}{'colon_N':>8}{'wall/sim':>9}{'pareto':>7}"
    lines = [head]
    for r in sorted(rows, key=lambda r: r["wall_s_per_sim_s"]):
        cells = "".join(f"{fmt.format(r['setting'][f] * k):>9}" for f, _, k, fmt in FIELD_HEADERS)
        force = f"{100 * r['tip_force_error']:.2f}%" + ("" if r["tensile_converged"] else "!")
        label = 'default  <- SimConfig(engine="dynamic")' if r["label"] == "default" else r["label"]
        lines.append(f"{label:<46}{cells}{force:>10}{r['tip_pose_error_mm']:>8.2f}{r['ubend_disagreement']:>7.2f}"
                     f"{r.get('ubend_disagreement_quasistatic', float('nan')):>7.2f}"
                     f"{r.get('wall_overlap_mm', float('nan')):>8.2f}{r.get('colon_peak_force_n', float('nan')):>8.2f}"
                     f"{r['wall_s_per_sim_s']:>9.4f}{'*' if r['pareto'] else '':>7}")
    return lines


def skip_table(skip: list[dict]) -> list[str]:
    lines = [f"{'topic':<11}{'variant':<52}{'wall/sim':>9}{'ratio':>7}"]
    lines += [f"{s['topic']:<11}{s['variant']:<52}{s['wall_s_per_sim_s']:>9.4f}{s['ratio']:>7.2f}" for s in skip]
    return lines


def plot(rows: list[dict], default_label: str | None, path: Path) -> None:
    """Two panels against wall time: tip force error and U-bend disagreement; each panel's
    Pareto front (the lower-left staircase) drawn and labelled, the chosen default ringed,
    the current default and the slowest setting labelled too (the table names the rest)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for ax, key, label, scale in ((axes[0], "tip_force_error", "tip force error vs rod (%)", 100.0),
                                  (axes[1], "ubend_disagreement", "U-bend outcomes differing from the finest (%)", 100.0)):
        pts = sorted((r["wall_s_per_sim_s"], r[key] * scale, r["label"]) for r in rows)
        front, best = [], np.inf
        for x, y, _name in pts:
            if y < best - PARETO_RTOL * max(abs(y), abs(best) if np.isfinite(best) else 0.0):
                front.append((x, y))
                best = y
        xs, ys = zip(*front)
        ax.step(xs, ys, where="post", color="#c92a2a", lw=1.2, label="Pareto front")
        ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=22, color="#1c7ed6", zorder=3)
        ax.scatter(xs, ys, s=60, facecolors="none", edgecolors="#c92a2a", zorder=4)
        labelled = [(x, y, name) for x, y, name in pts if (x, y) in front or name in (default_label, "default", pts[-1][2])]
        for i, (x, y, name) in enumerate(labelled):
            ax.annotate(name, (x, y), fontsize=6, xytext=(4, 3 if i % 2 == 0 else -9), textcoords="offset points")
        for x, y, name in pts:
            if name == default_label:
                ax.scatter([x], [y], s=160, facecolors="none", edgecolors="#2b8a3e", lw=1.5, zorder=5, label="chosen default")
        if key == "tip_force_error":
            ax.axhline(FORCE_ERROR_BUDGET * 100.0, color="#868e96", ls="--", lw=0.8, label=f"budget {FORCE_ERROR_BUDGET:.0%}")
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xticks([t for t in (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0) if pts[0][0] / 1.5 < t < pts[-1][0] * 1.5])
        ax.set_xlabel("wall seconds per simulated second (U-bend growth run)")
        ax.set_ylabel(label)
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def describe_default(default: dict, rows_by_label: dict[str, dict] | None = None, reference: str = "") -> str:
    """One paragraph on the chosen default and whether it is the current ``SimConfig`` default."""
    if "label" not in default:
        return f"No setting met the {FORCE_ERROR_BUDGET:.0%} budget."
    fields = ", ".join(f"{k} = {v:g}" for k, v in default["setting"].items())
    text = (f"**{default['label']}** ({fields}): tip force error {100 * default['tip_force_error']:.2f}%, "
            f"U-bend disagreement {default['ubend_disagreement']:.2f}, {default['wall_s_per_sim_s']:.4f} wall s per "
            "simulated s. ")
    if default["equals_simconfig_default"]:
        return text + "It is the current `SimConfig` default."
    current = ", ".join(f"{k} = {v:g}" for k, v in default["simconfig_default"].items())
    text += f"It is **not** the current `SimConfig` default ({current})."
    rows_by_label = rows_by_label or {}
    chosen, ref = rows_by_label.get(default["label"]), rows_by_label.get(reference)
    now = next((r for r in rows_by_label.values() if r["setting"] == default["simconfig_default"]), None)
    if chosen and now and ref and "colon_peak_force_n" in chosen:
        text += (f"\n\nThe default stays where it is, by judgement rather than by the rule: the rule looks at static "
                 f"answers, and contact with a compliant wall is not converged in the step. The colon robot's peak "
                 f"contact force is {chosen['colon_peak_force_n']:.1f} N with the chosen setting, "
                 f"{now['colon_peak_force_n']:.1f} N with the current default and {ref['colon_peak_force_n']:.1f} N "
                 f"with the reference (`colon_N`), and the U-bend outcome disagreement is "
                 f"{chosen['ubend_disagreement']:.2f} against {now['ubend_disagreement']:.2f}. The shipped policies, "
                 "the bend model's fit and every reproduced table are the quasi-static engine's "
                 "(docs/quasistatic.md), not this engine's.")
    return text


def markdown(result: dict, lines: list[str], skip_lines: list[str]) -> str:
    meta = result["meta"]
    pareto = [r for r in result["rows"] if r["pareto"]]
    trials = result["ubend_trials"]
    radii = sorted({t["radius_mm"] for t in trials})
    pressures = sorted({t["pressure_kpa"] for t in trials})
    return "\n".join([
        "# Simulator accuracy and cost",
        "",
        f"Regenerate (about 4.5 minutes on a 2-core machine; `--quick`, about 30 s, for a smaller sweep): `{COMMAND}`",
        "",
        f"Measured {meta['date']} in {meta['elapsed_s']:.0f} s on build {meta['versions']['git_commit']}, "
        f"{'quick' if result['quick'] else 'full'} sweep; "
        f"{meta['versions']['machine']}, Python {meta['versions']['python']}, numpy {meta['versions']['numpy']}, "
        f"pymunk {meta['versions']['pymunk']}. "
        "Wall times depend on the machine: compare rows of one run only.",
        "",
        "> **Engine.** Every row below is the dynamic engine's (`SimConfig(engine=\"dynamic\")`, the default before 0.3.0): "
        "\"default\" means its settings. Only the `vs_qs` column compares with the quasi-static engine.",
        "",
        "## What is measured",
        "",
        "* `force_err`: largest relative error of the pymunk tensile test (`sim_tensile_test`) against the Cosserat "
        "rod (`virtual_tensile_test`) over the bare tube, one 50% band at 50 mm, four 50% bands at 50-200 mm and one "
        "10% band at 100 mm from the tip, at 20 and 60 mm tip displacement (6.9 kPa). `!` marks a setting whose "
        "tensile test did not converge.",
        "* `pose_mm`: largest tip x error (mm) against the rod at 60 mm displacement.",
        f"* `ubend`: fraction of {len(trials)} U-bend trials (inner radius {', '.join(f'{r:g}' for r in radii)} mm, "
        "0.9 m robot with no bands or three 10% bands at 200/250/300 mm, constant "
        f"{' or '.join(f'{p:g}' for p in pressures)} kPa, success = tip reaches the goal within 15 s) whose "
        f"outcome differs from the finest setting's (`{result['reference']}`). The tensile force error does not "
        "depend on the step, solver passes, mass scaling or active window (static answers; by design), so this "
        "column is what tells those settings apart.",
        "* `overlap`: largest depth (mm) by which the tube passed into a wall beyond the stress tests' contact "
        "tolerances (1 mm, 2 mm at the tip) while the bare robot grows 8 s into the 20 mm U-bend at 8 kPa, "
        "checked every 5 steps (`wall_overlap_mm`); 0 means the contact held.",
        "* `colon_N`: largest tip contact force (N) of the paper's banded colon robot pushed into the default "
        "phantom's bend at 8 kPa for 8 s (`colon_peak_force_n`): how hard a compliant wall is hit, which no static "
        "answer shows. Reported, not used to choose.",
        "* `wall/sim`: wall seconds per simulated second of the bare robot growing 10 s through the 40 mm U-bend "
        f"at 3 kPa (best of {TIMING_REPEATS}).",
        "* `pareto`: `*` when no other setting is at least as good in wall time, force error and U-bend "
        "disagreement together and better in one (values within 0.1% count as equal).",
        "",
        "Reading the numbers: the force and pose errors depend on the segment length only (the chain's statics "
        "converge to the rod's as O(ds^2); the step, solver passes, mass scaling and active window do not change a "
        "static answer). U-bend outcomes are decided near a pass/fail boundary, so a few trials flip between "
        f"settings: one trial is {1 / len(result['ubend_trials']):.3f} of the disagreement.",
        "",
        "## All settings (sorted by cost)",
        "",
        "```",
        *lines,
        "```",
        "",
        "`ubend`: the share of U-bend outcomes unlike the finest setting's; `vs_qs`: unlike the quasi-static "
        "engine's on the same trials (`SimConfig(engine=\"quasistatic\")`, docs/quasistatic.md), a reference outside the sweep.",
        "",
        "## Pareto set",
        "",
        "| setting | force error | pose error (mm) | U-bend disagreement | wall s / sim s |",
        "|---|---:|---:|---:|---:|",
        *[f"| {r['label']} | {100 * r['tip_force_error']:.2f}% | {r['tip_pose_error_mm']:.2f} | "
          f"{r['ubend_disagreement']:.2f} | {r['wall_s_per_sim_s']:.4f} |"
          for r in sorted(pareto, key=lambda r: r["wall_s_per_sim_s"])],
        "",
        f"## Chosen default (fastest with force error <= {FORCE_ERROR_BUDGET:.0%} and no wall overlap)",
        "",
        describe_default(result["default"], {r["label"]: r for r in result["rows"]}, result["reference"]),
        "",
        "![error against wall time](benchmarks_pareto.png)",
        "",
        "## Skip what a scene does not need",
        "",
        "Wall seconds per simulated second, and the ratio to the simulator's default behaviour (first row of "
        "each topic): the active set on a long robot grown through a 90-degree bend, compliant against static "
        "colon walls (20 mm robot, 0.6 m, 4 kPa), and an RGB frame (`render_rgb`) every 0.1 s against none.",
        "",
        "```",
        *skip_lines,
        "```",
        "",
        "## Elsewhere",
        "",
        "* Against PyElastica and MuJoCo at matched (1%) accuracy: [peers.md](peers.md) "
        "(`python -m evertgym.bench.peers_page`).",
        "* Numerical stress tests (hypothesis): [stress.md](stress.md).",
        "* Env steps per second against an earlier build, side by side, and where an env step's time goes: "
        "[speed.md](speed.md) (`evertgym bench env --against REV`).",
        "",
    ])


def read_log(path: Path, quick: bool, vers: dict) -> dict[str, dict]:
    """Rows logged earlier for the same ``quick`` flag and versions, by label."""
    done: dict[str, dict] = {}
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            rec = json.loads(line)
            if rec["quick"] == quick and rec["versions"] == vers:
                done[rec["row"]["label"]] = rec["row"]
    return done


def measure(args: argparse.Namespace) -> dict:
    """Run the sweep and the skip costs, logging rows as they come (``--log``, ``--resume``)."""
    vers = versions()
    command = " ".join([COMMAND, *sys.argv[1:]])
    done = read_log(args.log, args.quick, vers) if args.resume else {}

    def on_row(row: dict) -> None:
        print(f"  measured {row['label']}: force error {100 * row['tip_force_error']:.2f}%, "
              f"{row['wall_s_per_sim_s']:.4f} wall s / sim s", flush=True)
        if args.log is not None:
            args.log.parent.mkdir(parents=True, exist_ok=True)
            with args.log.open("a", encoding="utf-8") as f:
                f.write(json.dumps({"command": command, "versions": vers, "quick": args.quick, "row": row}) + "\n")

    t0 = time.perf_counter()
    result = run_sweep(quick=args.quick, done=done, on_row=on_row)
    result["skip"] = skip_costs(quick=args.quick)
    result["meta"] = {"command": command, "versions": vers, "elapsed_s": time.perf_counter() - t0,
                      "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="7 settings, 6 U-bend trials each (3 kPa)")
    ap.add_argument("--json", type=Path, help="write the whole result here")
    ap.add_argument("--log", type=Path, help="append each row to this JSON-lines file as it is measured")
    ap.add_argument("--resume", action="store_true", help="reuse the rows already in --log")
    ap.add_argument("--render", type=Path, metavar="FILE",
                    help="measure nothing: print and write the docs of a result saved with --json")
    out = ap.add_mutually_exclusive_group()
    out.add_argument("--docs", type=Path, default=Path("docs"), help="directory of benchmarks.md and its figure")
    out.add_argument("--no-docs", action="store_true", help="write no docs")
    args = ap.parse_args()
    if args.resume and args.log is None:
        ap.error("--resume needs --log FILE")
    if args.render is not None:
        if args.quick or args.log or args.json:
            ap.error("--render measures nothing: it takes no --quick, --log or --json")
        result = json.loads(args.render.read_text(encoding="utf-8"))
    else:
        result = measure(args)
    lines, skip_lines = table(result["rows"]), skip_table(result["skip"])
    print("\n".join(lines))
    d = result["default"]
    if "label" in d:
        print(f"default (fastest with force error <= {FORCE_ERROR_BUDGET:.0%}, no wall overlap): {d['label']}"
              f" ({'equals' if d['equals_simconfig_default'] else 'differs from'} the current SimConfig default)")
    else:
        print(f"no setting met the {FORCE_ERROR_BUDGET:.0%} force error budget")
    print("\n".join(skip_lines))
    print(f"elapsed: {result['meta']['elapsed_s']:.0f} s")
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    if not args.no_docs:
        args.docs.mkdir(parents=True, exist_ok=True)
        plot(result["rows"], d.get("label"), args.docs / "benchmarks_pareto.png")
        (args.docs / "benchmarks.md").write_text(markdown(result, lines, skip_lines), encoding="utf-8")


if __name__ == "__main__":
    main()
