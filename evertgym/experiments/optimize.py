"""Band-design search: optuna (TPE) over band count, spacing, reduction and offset.

The objective is the success rate of a design on training scenes of a family (scene
seeds ``0..n_scenes-1``) under a pressure budget (constant pressure at the budget, or the
operator protocol capped at it), less :data:`BAND_PENALTY` per band, so that of two designs
with the same success rate the one with fewer bands wins (:data:`OBJECTIVE` says so in every
output).  The study lives in an SQLite file (optuna's RDB storage) and every trial's episodes
in the scoring store, so a killed search resumes.  A study remembers what it was made for (the
scene, the search settings, the policy and the simulator settings): a file holds one study per
such set, so a run with another scene or other settings starts its own study (and says so)
instead of reusing the answer of another search.  The best design is then scored against the paper's design (3 x 10%
bands 50 mm apart) on held-out scenes (seeds from 10000).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

from tqdm import tqdm

from evertgym._extras import require
from evertgym.experiments.sweep import sweep_specs, with_engine
from evertgym.experiments.trial import run_trial
from evertgym.scoring.runner import run_trials
from evertgym.scoring.stats import summarize
from evertgym.scoring.store import ResultStore, identify_store, identify_study

HELD_OUT_FIRST_SEED = 10_000
#: Names of the two reference designs scored beside the best on the held-out scenes.
PAPER_NAME = "paper 3 x 10% / 50 mm"
BARE_NAME = "no bands"
#: Every trial shifts all bands by U(-BAND_JITTER_MM, BAND_JITTER_MM) mm (the paper's randomised band positions).
BAND_JITTER_MM = 25.0
#: Closest a band of a searched design may sit to either end of the body (mm), before the jitter: the strip stays on it.
MIN_BAND_MM = 10.0 + BAND_JITTER_MM
#: Success-rate points a design loses per band: the tie-break towards fewer bands.
BAND_PENALTY = 0.001
#: The objective in words, printed by ``evertgym optimize``.
OBJECTIVE = (f"objective: success rate on the training scenes minus {BAND_PENALTY:g} per band "
             "(of two designs that succeed equally often, the one with fewer bands is best)")


def band_design(n_bands: int, spacing_mm: float, reduction: float, last_band_mm: float, diameter_mm: float, length_mm: float) -> dict:
    """Bands ``spacing_mm`` apart ending at ``last_band_mm`` from the base; a band closer than
    :data:`MIN_BAND_MM` to either end of the body is left out (the trial's jitter would move it off)."""
    positions = [last_band_mm - k * spacing_mm for k in range(n_bands)]
    bands = [{"position_mm": p, "reduction": reduction} for p in sorted(positions) if MIN_BAND_MM < p < length_mm - MIN_BAND_MM]
    return {"tube": {"diameter_mm": diameter_mm, "wall_thickness_mm": 0.05, "length_mm": length_mm}, "bands": bands}


def optimize_bands(
    scene: dict,
    study_path: str | Path,
    store_path: str | Path,
    n_trials: int = 20,
    n_scenes: int = 4,
    trials_per_scene: int = 2,
    held_out_scenes: int = 8,
    budget_kpa: float = 3.0,
    policy: str = "constant",
    diameter_mm: float = 40.0,
    length_mm: float = 900.0,
    max_s: float = 20.0,
    backend: str = "process",
    seed: int = 0,
    progress: bool = False,
    sim: dict | None = None,
) -> dict:
    """Run (or resume) the search and score its best design, the paper's (:data:`PAPER_NAME`) and
    the bare robot (:data:`BARE_NAME`) on held-out scenes: ``{"best_params", "best_design",
    "held_out", "trials", "objective", "study"}``; ``study`` says which study of ``study_path`` ran
    (``name``; ``new``: True when none was made for these settings before; ``resumed_designs``: the
    designs it already held; ``other_studies``: what the file's other studies were made for).
    ``progress`` shows a bar
    over the designs with the best score so far, then one over the held-out trials (stderr).
    ``diameter_mm`` and ``length_mm`` are the tube of every design (mm), ``max_s`` each trial's time limit (s).
    ``sim`` overrides :class:`~evertgym.sim.config.SimConfig` fields in every trial.  A study is
    kept per scene and settings (:func:`study_settings`), so a study never resumes for another scene,
    budget, policy, tube, engine or simulator setting.  ``n_trials`` and ``held_out_scenes`` are not
    among them: a second call with more trials extends the study."""
    require("evertgym optimize (optimize_bands)", "optuna")
    import optuna

    if policy not in ("constant", "operator"):
        raise ValueError(f"policy = {policy!r}: allowed 'constant' or 'operator'")
    if not (0 < budget_kpa <= 8.0):
        raise ValueError(f"budget_kpa = {budget_kpa!r} is out of range: allowed (0, 8] kPa")
    pol = {"name": "constant", "pressure_kpa": budget_kpa} if policy == "constant" else {"name": "operator", "max_kpa": budget_kpa}
    episode = with_engine({"max_s": float(max_s), "band_offset_mm": [-BAND_JITTER_MM, BAND_JITTER_MM], "entry_offset_mm": [-5.0, 5.0],
                           "sim": dict(sim or {})})
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    if Path(study_path).resolve() == Path(store_path).resolve():
        raise ValueError(f"study_path and store_path are the same file ({study_path}): allowed two files")
    identify_study(study_path, "study_path")  # read-only: a file that is not an optuna study is refused unchanged
    identify_store(store_path, "store_path")
    settings = study_settings(scene, n_scenes, trials_per_scene, pol, diameter_mm, length_mm, seed, episode)
    name = "bands-" + hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
    storage = f"sqlite:///{Path(study_path).resolve()}"
    try:
        summaries = optuna.get_all_study_summaries(storage) if Path(study_path).is_file() else []
        others = [s for s in summaries if s.study_name != name]
        new = len(others) == len(summaries)
        study = optuna.create_study(
            study_name=name, storage=storage, load_if_exists=True, direction="maximize", sampler=optuna.samplers.TPESampler(seed=seed),
        )
    except Exception as e:  # noqa: BLE001 - optuna's and SQLAlchemy's errors (an old schema, a locked file) in one line
        raise ValueError(f"study {study_path}: optuna cannot open it ({type(e).__name__}: {' '.join(str(e).split())[:200]})") from None
    if new:
        study.set_user_attr("settings", settings)
    done = len([t for t in study.trials if t.state.name == "COMPLETE"])
    info = {"path": str(study_path), "name": name, "new": new, "resumed_designs": done, "settings": settings,
            "other_studies": [{"name": o.study_name, "settings": o.user_attrs.get("settings"), "designs": o.n_trials} for o in others]}
    if progress:
        print(study_text(info), file=sys.stderr)

    def score(designs: dict[str, dict], first_seed: int, n: int) -> list[dict]:
        specs = sweep_specs(designs, scene, n, trials_per_scene, pol, episode, first_scene_seed=first_seed)
        with ResultStore(store_path) as store:
            records = run_trials(specs, run_trial, store, backend=backend, progress=progress and first_seed == HELD_OUT_FIRST_SEED)
        return summarize(records, by="design_name")

    def objective(trial) -> float:
        n = trial.suggest_int("n_bands", 0, 6)
        design = band_design(
            n, trial.suggest_float("spacing_mm", 20.0, 100.0), trial.suggest_float("reduction", 0.05, 0.5),
            trial.suggest_float("last_band_mm", 150.0, 500.0), diameter_mm, length_mm,
        )
        row = score({f"candidate {trial.number}": design}, 0, n_scenes)[0]
        # the study's own record says when an outcome may be the solver settings' (never hidden)
        trial.set_user_attr("unconverged_solves", int(row["unconverged_solves"]))
        trial.set_user_attr("trials_unconverged", int(row["trials_unconverged"]))
        return row["success_rate"] - BAND_PENALTY * n

    remaining = n_trials - done
    if remaining > 0:
        with tqdm(total=n_trials, initial=done, desc="optimize", unit="design", disable=not progress) as bar:

            def show_best(study, trial) -> None:  # an optuna callback, after every finished design
                if any(t.state.name == "COMPLETE" for t in study.trials):
                    b = study.best_trial
                    bar.set_postfix({"best": f"{b.value:.3f}", "n_bands": b.params["n_bands"], "design": b.number}, refresh=False)
                bar.update(1)

            study.optimize(objective, n_trials=remaining, callbacks=[show_best])
    best = study.best_params
    best_design = band_design(best["n_bands"], best["spacing_mm"], best["reduction"], best["last_band_mm"], diameter_mm, length_mm)
    paper = band_design(3, 50.0, 0.1, 300.0, diameter_mm, length_mm)
    bare = band_design(0, 50.0, 0.1, 300.0, diameter_mm, length_mm)
    rows = score({"best": best_design, PAPER_NAME: paper, BARE_NAME: bare}, HELD_OUT_FIRST_SEED, held_out_scenes)
    return {"best_params": best, "best_design": best_design, "held_out": rows, "trials": len(study.trials), "objective": OBJECTIVE,
            "study": info}


def study_text(info: dict) -> str:
    """One line on the study a search ran in: new or resumed, and what the file's other studies were made for."""
    if info["new"]:
        text = f"study: a new one in {info['path']} for this scene and these settings"
    else:
        text = f"study: resumed in {info['path']}: {info['resumed_designs']} designs already searched for this scene and these settings"
    others = info["other_studies"]
    if others:
        kinds = "; ".join(settings_difference(o["settings"], info["settings"]) for o in others[:3]) + ("; ..." if len(others) > 3 else "")
        text += f" (the file's {len(others)} other {'study is' if len(others) == 1 else 'studies are'} kept, made for: {kinds})"
    return text


def study_settings(scene: dict, n_scenes: int, trials_per_scene: int, policy: dict, diameter_mm: float, length_mm: float,
                   seed: int, episode: dict) -> dict:
    """What a band-design study was made for: its identity in a study file (JSON-ready)."""
    return json.loads(json.dumps({
        "scene": scene, "n_scenes": n_scenes, "trials_per_scene": trials_per_scene, "policy": policy, "diameter_mm": diameter_mm,
        "length_mm": length_mm, "sampler_seed": seed, "episode": episode, "band_penalty": BAND_PENALTY,
    }, sort_keys=True))


def settings_difference(a: dict | None, b: dict) -> str:
    """The settings of ``b`` that differ from ``a``'s, in words (``a`` None: made before studies kept them)."""
    if a is None:
        return "settings not recorded"
    flat_a, flat_b = _flat(a), _flat(b)
    keys = sorted(set(flat_a) | set(flat_b))
    return ", ".join(f"{k} = {json.dumps(flat_a.get(k))}" for k in keys if flat_a.get(k) != flat_b.get(k)) or "the same settings"


def _flat(d: dict, prefix: str = "") -> dict:
    out: dict = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out
