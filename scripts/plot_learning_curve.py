#!/usr/bin/env python
"""Learning curve from a training run's TensorBoard logs.

    python scripts/plot_learning_curve.py runs/ubend_ppo docs/ubend_ppo_learning_curve.png

Plots the mean episode return and the mean episode length (rollout/ep_rew_mean,
rollout/ep_len_mean, logged by SB3's Monitor) against environment steps.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator


def main(run_dir: str, out: str) -> None:
    events = sorted(Path(run_dir, "tb").rglob("events.out.tfevents*"))
    if not events:
        raise SystemExit(f"no TensorBoard events under {run_dir}/tb")
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for tag, ax, label in (("rollout/ep_rew_mean", axes[0], "mean episode return"), ("rollout/ep_len_mean", axes[1], "mean episode length (steps)")):
        for ev in events:
            acc = EventAccumulator(str(ev))
            acc.Reload()
            if tag in acc.Tags().get("scalars", []):
                pts = acc.Scalars(tag)
                ax.plot([p.step for p in pts], [p.value for p in pts], "-")
        ax.set_xlabel("environment steps")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle(f"learning curve: {Path(run_dir).name}")
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:3])
