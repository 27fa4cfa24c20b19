"""Figures written to files (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str | Path, dpi: int = 120) -> Path:
    """Lay out ``fig``, write it to ``path`` (folders created) and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def plot_stiffness_curves(curves: list[dict], path: str | Path) -> Path:
    """Force against tip displacement (0-20 mm) per paper row, model against measurement.

    Each entry of ``curves``: ``experiment``, ``label``, ``displacement_mm`` (array),
    ``cosserat_force_n`` (array), ``measured_n_per_m``, ``sd_n_per_m`` and optionally
    ``sim_force_n`` (array).  One panel per experiment, like the paper's Fig. 3.
    """
    plt = _pyplot()
    exps = sorted({c["experiment"] for c in curves})
    fig, axes = plt.subplots(1, len(exps), figsize=(5.2 * len(exps), 4.4), squeeze=False)
    titles = {1: "Exp 1: number of 50% bands (calibrate)", 2: "Exp 2: band position (predict)", 3: "Exp 3: reduction at 100 mm (calibrate)"}
    for ax, e in zip(axes[0], exps):
        sel = [c for c in curves if c["experiment"] == e]
        colors = plt.cm.viridis(np.linspace(0, 0.9, len(sel)))
        for c, col in zip(sel, colors):
            x = np.asarray(c["displacement_mm"])
            k, sd = c["measured_n_per_m"], c["sd_n_per_m"]
            ax.plot(x, k * x / 1e3, color=col, lw=1.6, label=f"{c['label']} measured")
            ax.fill_between(x, (k - sd) * x / 1e3, (k + sd) * x / 1e3, color=col, alpha=0.18, lw=0)
            ax.scatter(x[1::2], np.asarray(c["cosserat_force_n"])[1::2], color=col, s=14, marker="o", zorder=3)
            if c.get("sim_force_n") is not None:
                ax.scatter(x[2::2], np.asarray(c["sim_force_n"])[2::2], color=col, s=18, marker="x", zorder=3)
        ax.set_title(titles.get(e, f"Exp {e}"), fontsize=10)
        ax.set_xlabel("tip displacement (mm)")
        ax.set_ylabel("lateral tip force (N)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, loc="upper left")
    fig.suptitle("Lines: measured k x displacement (+/- 1 SD). Dots: Cosserat model" + (
        ". Crosses: pymunk simulator" if any(c.get("sim_force_n") is not None for c in curves) else ""), fontsize=9)
    return save_figure(fig, path, dpi=130)


def plot_pressure_position(rows: list[dict], path: str | Path) -> Path:
    """Pressure against insertion length per design, like the paper's Fig. 5d."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for r in rows:
        pp = np.asarray(r["pressure_position"], dtype=float)
        name = "no bands" if r["reduction"] == 0 else f"3 x {round(r['reduction'] * 100)}% bands"
        if len(pp):
            ax.plot(pp[:, 0], pp[:, 1], "-o", ms=2.5, label=f"{name} ({'passed' if r['passed'] else 'stalled'})")
    ax.axhline(8.0, color="r", lw=0.8, ls="--", label="8 kPa limit")
    ax.set_xlabel("insertion length (mm)")
    ax.set_ylabel("pressure (kPa)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return save_figure(fig, path)
