"""Invariance of the answers under the simulator's numerical knobs.

Masses and inertias in :class:`~evertgym.sim.config.SimConfig` are scaled, not physical, so
only quasi-static answers are meaningful, and they must not move with ``mass_ratio``,
``inertia_factor`` or the step ``dt_s``.  :data:`SETTINGS` holds the reference (the
dynamic engine's defaults) and one knob changed at a time from it: ``mass_ratio`` 0.003 and 0.1 (default
0.01), ``inertia_factor`` 10 (default 3) and the step halved (``dt_s`` 0.001, default 0.002).
For each setting :func:`run_invariance` runs

- the U-bend table of ``evertgym reproduce ubend`` (every design and radius, ``trials`` per
  cell), in its own SQLite store ``<out>/<setting>/ubend.sqlite`` (a killed run resumes);
- the colon case study of ``evertgym reproduce colon`` (both robots), store
  ``<out>/<setting>/colon.sqlite``;
- the operator baseline on ``evertgym/Colon-v0`` over ``episodes`` held-out episodes
  (:func:`~evertgym.agents.evaluate.evaluate`), its row kept in ``<out>/<setting>/operator.json``.

and compares it with the reference.  The criteria (:data:`CRITERIA`): every U-bend cell's
successes move by at most 2 of 12 (scaled by ``trials / 12`` for other trial counts), the
colon outcomes (passed or stalled, per robot) do not change, and the operator's success rate
moves by at most 0.1.

The stores and ``operator.json`` are keyed by the trials, not by the code: results computed by
another build are reused with a :class:`~evertgym.scoring.runner.StaleResultsWarning`, so
after a change to the physics start from an empty ``out`` folder.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

from evertgym.experiments.paper import UBEND_RADII_MM, reproduce_colon, reproduce_ubend
from evertgym.sim.config import SimConfig

#: (name, SimConfig overrides): the reference first, then one knob changed at a time.
SETTINGS: tuple[tuple[str, dict], ...] = (
    ("reference", {"engine": "dynamic"}),
    ("mass_ratio=0.003", {"engine": "dynamic", "mass_ratio": 0.003}),
    ("mass_ratio=0.1", {"engine": "dynamic", "mass_ratio": 0.1}),
    ("inertia_factor=10", {"engine": "dynamic", "inertia_factor": 10.0}),
    ("dt_s=0.001", {"engine": "dynamic", "dt_s": 0.001}),
)

#: The invariance criteria: U-bend per-cell successes (of 12 trials), colon outcomes, operator success rate.
CRITERIA = {"ubend_max_cell_change_of_12": 2, "colon_outcomes_equal": True, "operator_max_change": 0.1}

#: The quasi-static engine: its reference and its numerical settings changed one at a
#: time (the growth increment halved, the solver tolerance ten times tighter, the pressure increment
#: that triggers a re-solve five times finer).  It has no mass,
#: inertia or damping settings to vary.
_HALF_INCREMENT_M = 0.5 * SimConfig().growth_increment_m
QUASISTATIC_SETTINGS: tuple[tuple[str, dict], ...] = (
    ("quasistatic", {"engine": "quasistatic"}),
    (f"growth_increment_m={_HALF_INCREMENT_M:g}", {"engine": "quasistatic", "growth_increment_m": _HALF_INCREMENT_M}),
    ("solver_tolerance=1e-4", {"engine": "quasistatic", "solver_tolerance": 1e-4}),
    ("pressure_increment_fraction=0.01", {"engine": "quasistatic", "pressure_increment_fraction": 0.01}),
)
#: Its criteria: a U-bend cell moves by at most 1 of 12, the colon outcomes are equal and their stall
#: positions within 2 mm, the operator's Colon-v0 success moves by at most 0.05.
QUASISTATIC_CRITERIA = {"ubend_max_cell_change_of_12": 1, "colon_outcomes_equal": True, "colon_stall_max_change_mm": 2.0,
                        "operator_max_change": 0.05}

OPERATOR_ENV = "evertgym/Colon-v0"


def _operator_row(folder: Path, sim: dict, episodes: int, workers: int) -> dict:
    """The operator's evaluation row on Colon-v0, reused from ``operator.json`` when it holds the same run."""
    from evertgym.agents.evaluate import evaluate
    from evertgym.scoring.provenance import code_fingerprint
    from evertgym.scoring.runner import StaleResultsWarning

    path = folder / "operator.json"
    now = code_fingerprint()
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("episodes") == episodes and saved.get("sim") == sim and saved.get("env") == OPERATOR_ENV:
            if saved.get("code_fingerprint") != now:  # as the trial stores do: reuse, and say so
                warnings.warn(StaleResultsWarning(
                    f"the operator evaluation reused from {path} was computed by another build of evertgym (code "
                    f"fingerprint now {now}); delete the file, or use a new --out, to recompute it"), stacklevel=2)
            return saved["row"]
    row = evaluate(["operator"], OPERATOR_ENV, episodes, env_kwargs={"sim_config": dict(sim)} if sim else None, workers=workers)[0]
    row = {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}  # strict JSON
    path.write_text(json.dumps({"env": OPERATOR_ENV, "episodes": episodes, "sim": sim, "code_fingerprint": now, "row": row},
                               indent=1))
    return row


def run_setting(folder: str | Path, sim: dict, trials: int = 12, episodes: int = 50, radii=UBEND_RADII_MM,
                workers: int = 2, progress: bool = False) -> dict:
    """Run (or resume) the three experiments of one setting; ``{"sim", "ubend", "colon", "operator", "solves"}``
    (``episodes`` 0 skips the operator evaluation: its row is then empty)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ubend = reproduce_ubend(folder / "ubend.sqlite", trials=trials, backend="process", workers=workers, progress=progress,
                            sim=sim, radii=radii)
    colon = reproduce_colon(folder / "colon.sqlite", backend="process" if workers > 1 else "serial", sim=sim)
    colon_rows = [{k: r[k] for k in ("reduction", "passed", "stall_position_mm", "peak_pressure_kpa")} for r in colon["rows"]]
    operator = _operator_row(folder, sim, episodes, workers) if episodes > 0 else {"success_rate": float("nan"), "episodes": 0}
    return {"sim": dict(sim), "ubend": ubend["rows"], "ubend_wall_s": ubend["wall_s"], "colon": colon_rows, "operator": operator,
            "solves": ubend.get("solves", {})}


def compare(name: str, run: dict, ref: dict, trials: int, criteria: dict = CRITERIA) -> dict:
    """One summary row: ``run`` against the reference run ``ref`` and the ``criteria``."""
    ref_cells = {(r["reduction"], r["radius_mm"]): r["successes"] for r in ref["ubend"]}
    changes = [abs(r["successes"] - ref_cells[(r["reduction"], r["radius_mm"])]) for r in run["ubend"]]
    worst = max(changes, default=0)
    worst_cell = None
    if changes and worst > 0:
        r = run["ubend"][changes.index(worst)]
        worst_cell = f"{r['reduction']:.1f}/{r['radius_mm']:g}"
    ref_colon = {r["reduction"]: r["passed"] for r in ref["colon"]}
    colon_same = all(ref_colon.get(r["reduction"]) == r["passed"] for r in run["colon"]) and len(run["colon"]) == len(ref_colon)
    ref_stall = {r["reduction"]: r["stall_position_mm"] for r in ref["colon"]}
    stall_moves = [abs(r["stall_position_mm"] - ref_stall[r["reduction"]]) for r in run["colon"]
                   if r["stall_position_mm"] is not None and ref_stall.get(r["reduction"]) is not None]
    stall_change = max(stall_moves, default=0.0)
    if "colon_stall_max_change_mm" in criteria:
        colon_same = colon_same and stall_change <= criteria["colon_stall_max_change_mm"]
    op = float(run["operator"]["success_rate"])
    op_change = op - float(ref["operator"]["success_rate"])
    if math.isnan(op_change):  # not measured (episodes 0): no verdict on it
        op_change = 0.0
    ubend_limit = criteria["ubend_max_cell_change_of_12"] * trials / 12
    ok_ubend = worst <= ubend_limit + 1e-9
    ok_op = abs(op_change) <= criteria["operator_max_change"] + 1e-9
    return {
        "setting": name,
        "sim": run["sim"],
        "ubend_max_cell_change": int(worst),
        "ubend_worst_cell": worst_cell,
        "ubend_trials": trials,
        "ubend_ok": ok_ubend,
        "colon": run["colon"],
        "colon_same": colon_same,
        "colon_stall_change_mm": stall_change,
        "operator_success": op,
        "operator_change": op_change,
        "operator_episodes": int(run["operator"]["episodes"]),
        "operator_ok": ok_op,
        "holds": bool(ok_ubend and colon_same and ok_op),
    }


def run_invariance(out: str | Path = "runs/invariance", trials: int = 12, episodes: int = 50, radii=UBEND_RADII_MM,
                   settings=SETTINGS, workers: int = 2, progress: bool = False, criteria: dict = CRITERIA) -> dict:
    """Run (or resume) every setting and compare it with the first (the reference).

    Returns ``{"rows": [...], "runs": {name: run_setting(...)}, "criteria": CRITERIA}``: one row per
    setting (:func:`compare`), with the largest per-cell change of U-bend successes, whether
    the colon outcomes equal the reference's, the operator's success rate and its change,
    and whether the setting meets every criterion (``holds``)."""
    out = Path(out)
    runs = {}
    for name, sim in settings:
        runs[name] = run_setting(out / name, sim, trials=trials, episodes=episodes, radii=radii, workers=workers, progress=progress)
    ref = runs[settings[0][0]]
    rows = [compare(name, runs[name], ref, trials, criteria) for name, _ in settings]
    solves = {name: runs[name].get("solves", {}) for name in runs}
    return {"rows": rows, "runs": runs, "criteria": criteria, "trials": trials, "episodes": episodes, "solves": solves}


def _colon_cell(r: dict) -> str:
    if r["passed"]:
        return f"passed ({r['peak_pressure_kpa']:.1f} kPa)"
    stall = r["stall_position_mm"]
    return f"stalled at {stall:.0f} mm ({r['peak_pressure_kpa']:.1f} kPa)" if stall is not None else "stalled"


def format_table(result: dict) -> str:
    """The markdown table of :func:`run_invariance`'s rows."""
    trials = result["trials"]
    lines = [
        f"| setting | U-bend max cell change (of {trials}) | colon no bands | colon 3 x 10% | colon same | "
        f"operator Colon-v0 success ({result['episodes']} ep.) | change | holds |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in result["rows"]:
        colon = {r["reduction"]: _colon_cell(r) for r in row["colon"]}
        worst = f"{row['ubend_max_cell_change']}" + (f" ({row['ubend_worst_cell']})" if row["ubend_worst_cell"] else "")
        lines.append(
            f"| {row['setting']} | {worst} | {colon.get(0.0, '-')} | {colon.get(0.1, '-')} | "
            f"{'yes' if row['colon_same'] else 'NO'} | {row['operator_success']:.2f} | {row['operator_change']:+.2f} | "
            f"{'yes' if row['holds'] else 'NO'} |"
        )
    c = result["criteria"]
    lines.append("")
    stall = f" and their stall positions within {c['colon_stall_max_change_mm']:g} mm" if "colon_stall_max_change_mm" in c else ""
    lines.append(f"Criteria: U-bend per-cell successes move by at most {c['ubend_max_cell_change_of_12']} of 12, colon outcomes "
                 f"equal the reference's{stall}, operator success moves by at most {c['operator_max_change']}.")
    return "\n".join(lines)


def ubend_table(result: dict) -> str:
    """U-bend passes per design and radius (rows) and setting (columns), as markdown."""
    names = list(result["runs"])
    cells: dict[tuple[float, float], dict[str, str]] = {}
    for name in names:
        for r in result["runs"][name]["ubend"]:
            cells.setdefault((r["reduction"], r["radius_mm"]), {})[name] = f"{r['successes']}/{r['trials']}"
    lines = ["| design | radius mm | " + " | ".join(names) + " |", "|---|---|" + "---|" * len(names)]
    for (red, radius), by in sorted(cells.items(), key=lambda kv: (kv[0][0], -kv[0][1])):
        design = "no bands" if red == 0 else f"3 x {round(red * 100)}%"
        lines.append(f"| {design} | {radius:g} | " + " | ".join(by.get(n, "-") for n in names) + " |")
    return "\n".join(lines)
