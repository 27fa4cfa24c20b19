"""U-bend success against radius for a range of casing friction factors, bare against banded.

The ``ubend`` family's casing friction factor is the one parameter fitted on the paper's
no-band rows (0.875).  This map reruns the paper's U-bend trials (same specs, seeds and
randomisation as ``evertgym reproduce ubend``) with the factor swept, to show whether any
friction lets the banded robots separate from the bare one.  Prints a table of successes
and writes the plot docs/ubend_friction_map.png.

    PYTHONPATH=. python scripts/ubend_friction_map.py            # about 4 min on 2 cores
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from evertgym.experiments.trial import run_trial  # noqa: E402
from evertgym.scoring import paper  # noqa: E402
from evertgym.scoring.runner import run_trials  # noqa: E402
from evertgym.scoring.store import ResultStore  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frictions", default="0.6,0.7,0.8,0.875,0.95", help="casing friction factors")
    ap.add_argument("--reductions", default="0,0.1,0.3")
    ap.add_argument("--trials", type=int, default=6, help="trials per design, radius and friction")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--plot", default=str(ROOT / "docs" / "ubend_friction_map.png"), help="plot to write ('' for none)")
    a = ap.parse_args(argv)
    frictions = [float(x) for x in a.frictions.split(",")]
    reductions = [float(x) for x in a.reductions.split(",")]
    specs = []
    for f in frictions:
        for spec in paper.ubend_specs(a.trials, reductions=reductions):
            spec.scene["params"]["wall_friction"] = f
            specs.append(spec)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, ResultStore(Path(tmp) / "trials.sqlite") as store:
        records = run_trials(specs, run_trial, store, workers=a.workers, progress=False)
    wall = time.perf_counter() - t0
    counts: dict[tuple[float, float, float], list[int]] = {}
    for rec in records:
        red = rec.spec.design["bands"][0]["reduction"] if rec.spec.design["bands"] else 0.0
        key = (rec.spec.scene["params"]["wall_friction"], red, rec.spec.scene["params"]["radius_mm"])
        c = counts.setdefault(key, [0, 0])
        c[0] += 1
        c[1] += int(rec.result["success"])
    radii = sorted(paper.UBEND_RADII_MM, reverse=True)
    print(f"{len(specs)} trials in {wall:.0f} s; successes / {a.trials} per inner radius (mm)")
    print(f"{'friction':>8} {'design':>9} " + " ".join(f"{r:>5g}" for r in radii))
    for f in frictions:
        for red in reductions:
            name = "no bands" if red == 0 else f"3 x {round(red * 100)}%"
            print(f"{f:>8g} {name:>9} " + " ".join(f"{counts[(f, red, r)][1]:>5d}" for r in radii))
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from evertgym.experiments.plots import save_figure

        fig, ax = plt.subplots(figsize=(6.8, 4.4))
        cmap = plt.get_cmap("viridis")
        styles = {0.0: "-", 0.1: "--", 0.2: "-.", 0.3: ":"}
        for i, f in enumerate(frictions):
            colour = cmap(i / max(1, len(frictions) - 1))
            for red in reductions:
                ax.plot(radii, [counts[(f, red, r)][1] / counts[(f, red, r)][0] for r in radii], styles.get(red, "-"),
                        marker="o", ms=3, color=colour,
                        label=f"friction {f:g}" if red == reductions[0] else None)
        for red in reductions:
            ax.plot([], [], styles.get(red, "-"), color="grey", label="no bands" if red == 0 else f"3 x {round(red * 100)}%")
        ax.set_xlabel("U-bend inner radius (mm)")
        ax.set_ylabel("success rate")
        ax.set_title("Simulated U-bend at 3 kPa: friction moves every design together")
        ax.invert_xaxis()
        ax.legend(fontsize=7, ncol=2)
        save_figure(fig, a.plot)
        print(f"plot: {a.plot}")
    return {"counts": {f"{k[0]}/{k[1]}/{k[2]}": v for k, v in counts.items()}, "wall_s": wall}


if __name__ == "__main__":
    main()
