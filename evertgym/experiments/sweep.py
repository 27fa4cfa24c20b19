"""Score band designs on a scene distribution: specs, summary table and plot."""

from __future__ import annotations

from pathlib import Path

from evertgym.design import TubeDesign
from evertgym.scoring.spec import TrialSpec
from evertgym.sim.config import SimConfig


def with_engine(episode: dict) -> dict:
    """``episode`` with its ``"sim"`` overrides naming the engine the trial runs on (the default's
    when not given).  The engine is part of a trial's identity: a store filled before the default
    engine changed (0.3.0: ``"dynamic"`` -> ``"quasistatic"``) is not reused for the new one."""
    sim = dict(episode.get("sim") or {})
    sim.setdefault("engine", SimConfig().engine)
    return {**episode, "sim": sim}


def design_from_flags(diameter_mm: float, length_mm: float, bands_mm: list[float], reduction: float) -> dict:
    """A design-file dict from flags (validated through :class:`TubeDesign`)."""
    d = {
        "tube": {"diameter_mm": diameter_mm, "wall_thickness_mm": 0.05, "length_mm": length_mm},
        "bands": [{"position_mm": p, "reduction": reduction} for p in bands_mm],
    }
    TubeDesign.from_dict(d)
    return d


def sweep_specs(
    designs: dict[str, dict],
    scene: dict,
    n_scenes: int,
    trials: int,
    policy: dict,
    episode: dict | None = None,
    first_scene_seed: int = 0,
) -> list[TrialSpec]:
    """Every design on ``n_scenes`` scene seeds x ``trials`` randomised trials each.

    The scene spec and the designs are validated here, before any trial runs."""
    from evertgym.scenes import SceneSpec

    SceneSpec(scene["family"], dict(scene.get("params", {})), first_scene_seed)
    specs = []
    for name, design in designs.items():
        TubeDesign.from_dict(design)
        for k in range(n_scenes):
            for i in range(trials):
                specs.append(
                    TrialSpec(
                        design=design,
                        design_name=name,
                        scene={**scene, "seed": first_scene_seed + k, "episode": with_engine(dict(episode or {}))},
                        policy=policy,
                        seed=k * 100003 + i,
                        index=k * trials + i,
                        group=f"scene{first_scene_seed + k}",
                    )
                )
    return specs


def plot_summary(rows: list[dict], path: str | Path, title: str | None = None) -> Path:
    """Success rate with its Wilson interval per design (``n`` under each name), titled ``title``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from evertgym.experiments.plots import save_figure

    fig, ax = plt.subplots(figsize=(max(4.0, 1.2 * len(rows)), 3.6))
    x = range(len(rows))
    rate = [r["success_rate"] for r in rows]
    err = [[r["success_rate"] - r["success_ci_lo"] for r in rows], [r["success_ci_hi"] - r["success_rate"] for r in rows]]
    ax.bar(x, rate, yerr=err, capsize=4, color="tab:blue", alpha=0.7)
    ax.set_xticks(list(x), [f"{r['design_name']}\nn = {r['n']}" for r in rows], rotation=20, fontsize=8)
    ax.set_xlabel("design")
    ax.set_ylabel("success rate\n(bars: Wilson 95% interval)")
    ax.set_ylim(0, 1.05)
    if title:
        import textwrap

        ax.set_title("\n".join(textwrap.wrap(title, 60)), fontsize=8)
    return save_figure(fig, path)
