"""The numbers of docs/robustness.md: the bounded event log and the 1000-band build.

    python -m evertgym.bench.robustness [--minutes 10] [--json]

* event log: an EversionSim in a Tortuous-v0 scene with its pressure command cycling
  between 0 and 8 kPa at 20 Hz for ``--minutes`` simulated minutes; the process's RSS and
  the number of kept events after the first simulated minute and at the end.
* bands: wall time to build an EversionSim of a 20 m body with 1000 bands and run 0.5 s.
"""

from __future__ import annotations

import argparse
import json
import time

from evertgym.design import Band, TubeDesign
from evertgym.limits import MAX_EVENTS
from evertgym.scenes import SceneSpec, make_scene
from evertgym.sim import EversionSim


def event_log_memory(minutes: float) -> dict:
    """RSS (MiB) and kept events after 1 simulated minute and after ``minutes`` (needs psutil: the test extra)."""
    from evertgym._extras import require

    require("the event log's memory figures", "psutil")
    import psutil

    proc = psutil.Process()
    sim = EversionSim(TubeDesign(length_m=0.9), scene=make_scene(SceneSpec("tortuous", {}, 0)))
    out: dict = {"minutes": minutes, "max_events": MAX_EVENTS}
    k = 0
    while sim.t < 60.0 * minutes:
        sim.set_pressure_command(8000.0 if k % 2 == 0 else 0.0)
        sim.run(0.05)
        k += 1
        if "rss_mib_at_1_min" not in out and sim.t >= 60.0:
            out.update(rss_mib_at_1_min=proc.memory_info().rss / 2**20, events_at_1_min=len(sim.events))
    out.update(rss_mib_at_end=proc.memory_info().rss / 2**20, events_at_end=len(sim.events),
               events_counted=sum(sim.event_counts.values()))
    return out


def thousand_bands() -> dict:
    """Wall time (s) to build a 1000-band body and simulate 0.5 s."""
    t0 = time.perf_counter()
    sim = EversionSim(TubeDesign(length_m=20.0, bands=tuple(Band(0.05 + 0.019 * i, 0.1) for i in range(1000))))
    sim.set_pressure_command(3000.0)
    sim.run(0.5)
    return {"bands": 1000, "build_and_run_0p5_s_wall_s": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    out = {"event_log": event_log_memory(args.minutes), "bands": thousand_bands()}
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
