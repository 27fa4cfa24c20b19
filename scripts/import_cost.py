"""What ``import evertgym`` costs against ``import gymnasium``, side by side in one run.

Each import runs in a fresh interpreter with ``-X importtime``; the contenders alternate and
the best of ``--repeats`` is kept, so a load spike hits both alike.  ``--src DIR`` measures the
evertgym package found in DIR instead of the installed one (e.g. a worktree of an older
revision)::

    python scripts/import_cost.py
    git worktree add /tmp/old 199a1c1 && python scripts/import_cost.py --src /tmp/old
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys


def import_seconds(module: str, src: str | None) -> float:
    """Cumulative import time (s) of ``module`` in a fresh interpreter."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    r = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import {module}"], capture_output=True, text=True,
                       env=env, cwd=src or None, check=True)
    rows = [line for line in r.stderr.splitlines() if line.rstrip().endswith(f"| {module}")]
    return int(rows[-1].split("|")[1]) / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7, help="runs of each import; the best is kept")
    ap.add_argument("--src", default=None, help="folder holding the evertgym package to measure")
    args = ap.parse_args()
    best: dict[str, float] = {}
    for _ in range(args.repeats):
        for module in ("gymnasium", "evertgym", "evertgym.design"):
            t = import_seconds(module, args.src)
            best[module] = min(best.get(module, t), t)
    for module, t in best.items():
        print(f"import {module:<16} {t * 1e3:7.1f} ms   {t / best['gymnasium']:5.2f} x gymnasium")


if __name__ == "__main__":
    main()
