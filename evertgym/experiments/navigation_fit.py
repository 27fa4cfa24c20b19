"""Fit of the section law's navigation parameters that nothing else constrains, on the no-band
U-bend rows only (``SimConfig(section_law=True)``).

``measurements.json`` lets the no-band U-bend rows calibrate "parameters nothing else constrains,
such as wall friction, bend losses and tail tension".  Three are free here:

* ``casing_friction_factor`` ``c``: multiplies the robot's Coulomb coefficients (tip 0.2, laid-down
  body 1.0) against the PLA casing;
* ``bend_loss_per_rad`` ``mu_b``: the tail's capstan coefficient (:mod:`evertgym.sim.growth`);
* ``tail_drag_fraction`` ``f_tail``: the share of the bare eversion threshold that is the tail's
  drag at the base.

Each candidate runs the paper's protocol (12 trials per radius, 3 kPa, the paper's trial
randomisation) on the bare robot; the criterion is the binomial negative log-likelihood of the
paper's no-band success rates (37.5 mm: 1.0, 35 mm: 0.583, 32.5 mm: 0.333, below: 0), with the
rates clipped to [0.02, 0.98] so that one trial cannot make it infinite.  Every candidate has its
own SQLite store, so a killed fit resumes.  :func:`sensitivity` reruns the best with each
parameter moved by +-0.05: a fit on a knife-edge is not a fit.
"""

from __future__ import annotations

import datetime as _dt
import itertools
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from evertgym.experiments.paper import _run, ubend_specs
from evertgym.model.params import DATA_DIR, load_measurements

#: The paper's no-band rates by radius (mm); below 32.5 mm none passed.
PAPER_BARE = {40.0: 1.0, 37.5: 1.0, 35.0: 0.583, 32.5: 0.333, 30.0: 0.0, 27.5: 0.0, 25.0: 0.0}
FIT_RADII_MM = (37.5, 35.0, 32.5, 30.0, 27.5)
PARAMETERS = ("casing_friction_factor", "bend_loss_per_rad", "tail_drag_fraction")
#: Where the fit is recorded (the grid, the best point, its sensitivity).
FIT_PATH = DATA_DIR / "navigation_fit.json"


def paper_bare_rates() -> dict[float, float]:
    """The paper's no-band success rates by radius (mm), from ``measurements.json``."""
    nb = load_measurements()["u_bend_validation"]["success_rate"]["no_bands"]
    out = {r: 0.0 for r in PAPER_BARE}
    for k, v in nb.items():
        if k != "below_32.5":
            out[float(k)] = float(v)
    return out


def nll(passes: dict[float, int], trials: int, rates: dict[float, float] | None = None) -> float:
    """Binomial negative log-likelihood of ``passes`` per radius under the paper's rates."""
    rates = rates or paper_bare_rates()
    total = 0.0
    for r, k in passes.items():
        q = min(max(rates[r], 0.02), 0.98)
        total -= k * math.log(q) + (trials - k) * math.log(1.0 - q)
    return total


def _key(point: dict[str, float]) -> str:
    return "_".join(f"{k[:4]}{point[k]:.3f}" for k in PARAMETERS)


def evaluate(point: dict[str, float], store_dir: Path, trials: int = 12, radii: Sequence[float] = FIT_RADII_MM,
             workers: int | None = None, progress: bool = False) -> dict[int | float, int]:
    """Bare-robot passes per radius for one parameter point (resumable)."""
    sim = {"engine": "dynamic", "section_law": True,
           "bend_loss_per_rad": point["bend_loss_per_rad"], "tail_drag_fraction": point["tail_drag_fraction"]}
    specs = ubend_specs(trials, radii=radii, reductions=(0.0,), sim=sim,
                        scene_params={"wall_friction": point["casing_friction_factor"]})
    records = _run(specs, store_dir / f"{_key(point)}.sqlite", "process", workers, progress)
    passes: dict[int | float, int] = {float(r): 0 for r in radii}
    for rec in records:
        passes[float(rec.spec.scene["params"]["radius_mm"])] += bool(rec.result["success"])
    return passes


def fit(grid: dict[str, Sequence[float]], store_dir: str | Path, trials: int = 12, radii: Sequence[float] = FIT_RADII_MM,
        workers: int | None = None, progress: bool = True) -> dict[str, Any]:
    """Every point of the ``grid`` (parameter -> values), ranked by :func:`nll`; ``best`` first."""
    store_dir = Path(store_dir)
    rows: list[dict[str, Any]] = []
    names = list(PARAMETERS)
    for values in itertools.product(*(grid[n] for n in names)):
        point = dict(zip(names, (float(v) for v in values)))
        passes = evaluate(point, store_dir, trials, radii, workers, progress)
        rows.append({**point, "passes": {f"{r:g}": k for r, k in passes.items()}, "nll": nll(passes, trials)})
    rows.sort(key=lambda r: r["nll"])
    return {"rows": rows, "best": rows[0], "trials": trials, "radii_mm": list(radii)}


def sensitivity(best: dict[str, float], store_dir: str | Path, trials: int = 12, radii: Sequence[float] = FIT_RADII_MM,
                step: float = 0.05, workers: int | None = None, progress: bool = True) -> list[dict[str, Any]]:
    """Passes per radius with each parameter of ``best`` moved by ``-step`` and ``+step``."""
    out = []
    for name in PARAMETERS:
        for sign in (-1.0, 1.0):
            point = {n: float(best[n]) for n in PARAMETERS}
            point[name] = point[name] + sign * step
            if point[name] < 0 or (name == "tail_drag_fraction" and point[name] > 1.0):
                continue
            passes = evaluate(point, Path(store_dir), trials, radii, workers, progress)
            out.append({"parameter": name, "delta": sign * step, "passes": {f"{r:g}": k for r, k in passes.items()}})
    return out


def write_params(result: dict[str, Any], sens: list[dict[str, Any]], path: str | Path = FIT_PATH) -> Path:
    """Write the versioned record of the fit (grid, best point, sensitivity) with where each number came from."""
    best = result["best"]
    doc = {
        "version": _dt.date.today().isoformat() + "-bare-ubend-fit",
        "fitted_on": ("measurements.json u_bend_validation no_bands rows only (the rule lets them calibrate wall "
                      f"friction, bend losses and tail tension); {result['trials']} trials per radius at "
                      f"{', '.join(f'{r:g}' for r in result['radii_mm'])} mm, 3 kPa, the paper's trial randomisation; "
                      "criterion: binomial NLL of the paper's rates clipped to [0.02, 0.98]; grid search"),
        "command": "python scripts/calibrate_navigation.py",
        "fitted": {n: best[n] for n in PARAMETERS},
        "fit_passes": best["passes"],
        "fit_nll": best["nll"],
        "grid": [{**{n: r[n] for n in PARAMETERS}, "passes": r["passes"], "nll": r["nll"]} for r in result["rows"]],
        "sensitivity": sens,
    }
    path = Path(path)
    path.write_text(json.dumps(doc, indent=2) + "\n")
    return path
