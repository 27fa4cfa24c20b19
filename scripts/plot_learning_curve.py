#!/usr/bin/env python
"""Learning curves from training runs' TensorBoard logs, several runs (seeds) in one figure.

    python scripts/plot_learning_curve.py runs/ubend_ppo docs/ubend_ppo_learning_curve.png
    python scripts/plot_learning_curve.py runs/colon_ppo_operator_seed0 runs/colon_ppo_operator_seed1 \\
        docs/colon_ppo_operator_learning_curves.png

Plots the mean episode return and the mean episode length (rollout/ep_rew_mean,
rollout/ep_len_mean, logged by SB3's Monitor) against environment steps, one colour per run
(a resumed run's pieces share their run's colour).
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

TAGS = (("rollout/ep_rew_mean", "mean episode return"), ("rollout/ep_len_mean", "mean episode length (steps)"))


def main(run_dirs: list[str], out: str) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for k, run_dir in enumerate(run_dirs):
        events = sorted(Path(run_dir, "tb").rglob("events.out.tfevents*"))
        if not events:
            raise SystemExit(f"no TensorBoard events under {run_dir}/tb")
        label = Path(run_dir).name if len(run_dirs) > 1 else None  # once per run, on its first piece
        for ev in events:  # a resumed run has one file per piece: each is read once
            acc = EventAccumulator(str(ev))
            acc.Reload()
            scalars = acc.Tags().get("scalars", [])
            for (tag, _), ax in zip(TAGS, axes):
                if tag in scalars:
                    pts = acc.Scalars(tag)
                    ax.plot([p.step for p in pts], [p.value for p in pts], "-", color=f"C{k}", label=label if ax is axes[0] else None)
            if any(tag in scalars for tag, _ in TAGS):
                label = None
    for (_, ylabel), ax in zip(TAGS, axes):
        ax.set_xlabel("environment steps")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    if len(run_dirs) > 1:
        axes[0].legend(fontsize=8)
    fig.suptitle("learning curve" + ("s" if len(run_dirs) > 1 else "") + ": " + ", ".join(Path(r).name for r in run_dirs))
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit("usage: plot_learning_curve.py RUN_DIR [RUN_DIR ...] OUT.png")
    main(sys.argv[1:-1], sys.argv[-1])
