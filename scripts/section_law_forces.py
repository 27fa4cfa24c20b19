"""Largest wall force on the tip against the tube's capacity p pi r^2, at 8 kPa, in every scene
family, under the rigid-column model and the section law (evertgym.experiments.capacity)."""

from __future__ import annotations

import argparse

from evertgym.experiments.capacity import CASES, max_tip_force


def main() -> None:
    argparse.ArgumentParser(description=__doc__).parse_args()  # about 1 min; --help says what it prints
    print("| case | model | max tip force (N) | p pi r^2 (N) | ratio | insertion (mm) |")
    print("|---|---|---:|---:|---:|---:|")
    for case in CASES:
        for law in (False, True):
            r = max_tip_force(case, law)
            print(f"| {case} | {r['model']} | {r['max_tip_force_n']:.2f} | {r['capacity_n']:.2f} | {r['ratio']:.2f} | {r['insertion_mm']:.0f} |")


if __name__ == "__main__":
    main()
