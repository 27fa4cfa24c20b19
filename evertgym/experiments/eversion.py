"""The paper's minimum-eversion-pressure test (Exp 4), simulated.

Protocol (paper, Sec. IV-D): the 40 mm, 600 mm robot everts vertically against gravity;
the pressure is raised in steps and the minimum pressure at which it fully everts
within 20 s of pressurisation is recorded.  Here each trial starts from the initial
everted length with the regulator at 0 and the command at the trial pressure; a trial
fails when the robot has not fully everted 20 s later, or earlier once it has stalled
with the pressure settled.  Success is monotone in the pressure, so the lowest
succeeding pressure on the step grid is found by bisection over the grid, which gives
the same answer as stepping up through it.  The banded robot carries one band at mid
length (300 mm).  The sim runs without guide walls: the growth is straight.
"""

from __future__ import annotations

import math

from evertgym.design import Band, TubeDesign
from evertgym.model.params import load_measurements
from evertgym.sim.config import SimConfig
from evertgym.sim.growth import MAX_PRESSURE_PA
from evertgym.sim.simulator import EversionSim

TIME_LIMIT_S = 20.0
BAND_POSITION_M = 0.300


def paper_eversion_robot(reduction: float) -> TubeDesign:
    """The 40 mm, 600 mm prototype with one band of ``reduction`` at mid length
    (reductions of 0.6 and more are admitted: the test shows they do not evert)."""
    bands = (Band(BAND_POSITION_M, reduction, must_evert=False),) if reduction > 0 else ()
    return TubeDesign(0.040, 0.05e-3, 0.600, bands)


def everts(design: TubeDesign, pressure_pa: float, config: SimConfig | None = None, time_limit_s: float = TIME_LIMIT_S) -> bool:
    """Does the robot fully evert within ``time_limit_s`` at this pressure command?"""
    sim = EversionSim(design, config=config, direction=(0.0, 1.0), vertical_tail=True)
    sim.set_pressure_command(pressure_pa)
    chunk = max(1, int(round(0.1 / sim.cfg.dt_s)))
    while sim.t < time_limit_s - 1e-9:
        sim.step(chunk)
        if sim.length >= design.length_m - 1e-9:
            return True
        settled = abs(sim.pressure - sim.regulator.command) < 1e-3 * max(sim.regulator.command, 1.0)
        if sim.stalled and settled:
            return False
    return False


def min_eversion_pressure(
    design: TubeDesign, step_pa: float = 10.0, max_pa: float = MAX_PRESSURE_PA, config: SimConfig | None = None
) -> float | None:
    """Lowest pressure on the grid ``step_pa, 2 step_pa, ...`` <= ``max_pa`` that everts, or None."""
    n_max = int(math.floor(max_pa / step_pa + 1e-9))
    if not everts(design, n_max * step_pa, config):
        return None
    lo, hi = 0, n_max  # everts(lo * step) is False (0 Pa never everts); everts(hi * step) is True
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if everts(design, mid * step_pa, config):
            hi = mid
        else:
            lo = mid
    return hi * step_pa


def reproduce_eversion(reductions: list[float] | None = None, step_pa: float = 10.0, config: SimConfig | None = None,
                       progress: bool = False) -> dict:
    """The ``--json`` structure of ``evertgym reproduce eversion``; ``progress`` shows a bar
    over the reductions (on stderr)."""
    from tqdm import tqdm

    table = {r["diameter_reduction"]: r for r in load_measurements()["eversion_pressure_test"]["rows"]}
    if reductions is None:
        reductions = sorted(table) + [0.6]
    rows = []
    for red in tqdm(reductions, desc="reproduce eversion", unit="reduction", disable=not progress):
        p = min_eversion_pressure(paper_eversion_robot(red), step_pa, config=config)
        meas = table.get(red)
        rows.append(
            {
                "reduction": red,
                "measured_kpa": meas["median_min_pressure_kPa"] if meas else None,
                "sd_kpa": meas["sd"] if meas else None,
                "simulated_kpa": None if p is None else p / 1e3,
            }
        )
    return {"rows": rows, "step_kpa": step_pa / 1e3, "time_limit_s": TIME_LIMIT_S}
