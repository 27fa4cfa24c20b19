"""Where and why the paper's U-bend trials jam, design by design (issue 6's banded miss).

Runs the trials of ``evertgym reproduce ubend`` (same specs, seeds and randomisation) for
the chosen radii and band reductions, and for every trial that fails measures the stalled
tip region with :func:`evertgym.scoring.jam.jam_anatomy`.  Prints one row per design and
radius (medians over the failed trials) and, with ``--write``, the page docs/ubend_jams.md.

    PYTHONPATH=. python scripts/ubend_jam_anatomy.py                  # about 1 min on 2 cores
    PYTHONPATH=. python scripts/ubend_jam_anatomy.py --bands-mm 400,450,500 --write ''

``--bands-mm`` moves the bands (before the per-trial +/- 25 mm shift), to test whether a
band inside the free span would release the jam; ``--wall-friction`` overrides the casing's
fitted friction factor, to test whether any friction separates the designs.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from evertgym.scoring import paper  # noqa: E402
from evertgym.scoring.jam import jam_anatomy  # noqa: E402
from evertgym.scoring.trial import play_trial  # noqa: E402


def _one(job: tuple) -> dict:
    spec, bands_mm, wall_friction = job
    if wall_friction is not None:
        spec.scene["params"]["wall_friction"] = wall_friction
    if bands_mm:
        spec.design["bands"] = [dict(b, position_mm=p) for b, p in zip(spec.design["bands"], bands_mm)]
    env, info, _ = play_trial(spec)
    out = {"group": spec.group, "seed": spec.seed, "success": bool(info["success"])}
    if not info["success"]:
        out["jam"] = jam_anatomy(env.sim, env.scene)
    return out


def _median(values: list[float]) -> float | None:
    return round(statistics.median(values), 2) if values else None


def summarise(results: list[dict], radii: list[float], reductions: list[float]) -> list[dict]:
    rows = []
    for red in reductions:
        for r in radii:
            grp = [x for x in results if x["group"] == f"{red:.1f}/{r:g}"]
            jams = [x["jam"] for x in grp if "jam" in x]
            band_ratio = [max(b["peak_moment_ratio"] for b in j["bands"]) for j in jams if j["bands"]]
            rows.append(
                {
                    "reduction": red,
                    "radius_mm": r,
                    "trials": len(grp),
                    "successes": sum(x["success"] for x in grp),
                    "jam_channel_turn_deg": _median([j["channel_turn_deg"] for j in jams]),
                    "jam_heading_error_deg": _median([j["heading_error_deg"] for j in jams]),
                    "jam_free_span_mm": _median([j["free_span_mm"] for j in jams]),
                    "jam_span_peak_moment_ratio": _median([j["span_peak_moment_ratio"] for j in jams]),
                    "jam_band_peak_moment_ratio": _median(band_ratio),
                    "jams_with_band_in_span": sum(any(b["in_free_span"] for b in j["bands"]) for j in jams),
                    "jam_nearest_band_behind_tip_mm": _median(
                        [min(b["behind_tip_mm"] for b in j["bands"] if b["everted"]) for j in jams if any(b["everted"] for b in j["bands"])]
                    ),
                    "jam_pressure_margin_kpa": _median([j["pressure_margin_kpa"] for j in jams]),
                }
            )
    return rows


COLUMNS = (
    ("design", lambda r: "no bands" if r["reduction"] == 0 else f"3 x {round(r['reduction'] * 100)}%"),
    ("radius mm", lambda r: f"{r['radius_mm']:g}"),
    ("passed", lambda r: f"{r['successes']}/{r['trials']}"),
    ("turn at jam (deg)", lambda r: r["jam_channel_turn_deg"]),
    ("tip heading error (deg)", lambda r: r["jam_heading_error_deg"]),
    ("free span (mm)", lambda r: r["jam_free_span_mm"]),
    ("span max M/Mc", lambda r: r["jam_span_peak_moment_ratio"]),
    ("band max M/Mc", lambda r: r["jam_band_peak_moment_ratio"]),
    ("nearest band behind tip (mm)", lambda r: r["jam_nearest_band_behind_tip_mm"]),
    ("jams with a band in the span", lambda r: r["jams_with_band_in_span"]),
    ("pressure margin (kPa)", lambda r: r["jam_pressure_margin_kpa"]),
)


def table(rows: list[dict]) -> str:
    head = "| " + " | ".join(c for c, _ in COLUMNS) + " |\n|" + "---|" * len(COLUMNS) + "\n"
    body = "".join("| " + " | ".join("-" if f(r) is None else str(f(r)) for _, f in COLUMNS) + " |\n" for r in rows)
    return head + body


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--radii", default="35,32.5,30,25", help="U-bend inner radii (mm)")
    ap.add_argument("--reductions", default="0,0.1,0.2,0.3")
    ap.add_argument("--trials", type=int, default=12)
    ap.add_argument("--bands-mm", default="", help="band positions from the base (mm); default the paper's 200,250,300")
    ap.add_argument("--wall-friction", type=float, default=None,
                    help="the casing's friction factor (default: the ubend family's, fitted on the no-band rows)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--write", default=str(ROOT / "docs" / "ubend_jams.md"), help="page to write ('' for none)")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    radii = [float(x) for x in a.radii.split(",")]
    reductions = [float(x) for x in a.reductions.split(",")]
    bands_mm = [float(x) for x in a.bands_mm.split(",")] if a.bands_mm else []
    if bands_mm and len(bands_mm) != len(paper.UBEND_BANDS_MM):
        ap.error(f"--bands-mm needs {len(paper.UBEND_BANDS_MM)} positions (mm), got {len(bands_mm)}")
    specs = paper.ubend_specs(a.trials, radii=radii, reductions=reductions)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(a.workers) as pool:
        results = list(pool.map(_one, [(s, bands_mm, a.wall_friction) for s in specs]))
    wall = time.perf_counter() - t0
    rows = summarise(results, radii, reductions)
    bands_text = ",".join(f"{p:g}" for p in (bands_mm or paper.UBEND_BANDS_MM))
    text = table(rows)
    friction = "" if a.wall_friction is None else f", wall friction factor {a.wall_friction:g}"
    print(f"bands at {bands_text} mm (+/- 25 mm per trial){friction}, {len(specs)} trials in {wall:.0f} s; medians over the failed trials\n")
    print(text)
    out = {"bands_mm": bands_mm or list(paper.UBEND_BANDS_MM), "wall_friction": a.wall_friction, "rows": rows, "wall_s": round(wall, 1)}
    if a.json:
        print(json.dumps(out))
    if a.write:
        cmd = "PYTHONPATH=. python scripts/ubend_jam_anatomy.py" + ("" if not bands_mm else f" --bands-mm {bands_text}")
        Path(a.write).write_text(
            "# Where the U-bend trials jam\n\n"
            f"Generated by `{cmd}` ({len(specs)} trials, {wall:.0f} s on {a.workers} workers). Bands at "
            f"{bands_text} mm from the base, shifted by one uniform draw in +/- 25 mm per trial, as in "
            "`evertgym reproduce ubend`. Each jam column is the median over the failed trials, measured on the "
            "stalled robot by `evertgym.scoring.jam.jam_anatomy`:\n\n"
            "* *turn at jam*: how far the channel has turned at the tip (180 is the end of the U);\n"
            "* *tip heading error*: the tip's heading minus the channel's (negative: the tip points into the outer wall);\n"
            "* *free span*: body between the last wall contact behind the tip and the tip;\n"
            "* *M/Mc*: a joint's moment over its collapse moment p pi r^3 (1 is a kink);\n"
            "* *pressure margin*: pressure minus what the tip needs to grow (at or below 0 while stalled).\n\n"
            + text
        )
    return out


if __name__ == "__main__":
    main()
