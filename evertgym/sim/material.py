"""The tabulated material of a design along its body, shared by every simulation of it.

Building these tables (the joints' bending and shear compliances by quadrature over each
node's hat function, the smallest radius of each cell, a fine radius profile) costs about
40 ms per simulation, a tenth of a U-bend trial; a sweep runs the same few designs hundreds
of times, so :func:`material_tables` keeps the last few designs' tables per process.
The arrays are read-only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from evertgym.design import TubeDesign
from evertgym.model.params import ModelParams
from evertgym.model.section import TubeSection
from evertgym.sim.discretize import hat_compliance, min_radius

#: Reference pressure at which the joint compliances are tabulated (Pa).
P_REF = 6900.0
#: Designs whose tables a process keeps.
CACHE_SIZE = 8


@dataclass(frozen=True)
class MaterialTables:
    """Per-node tables of one design at node spacing ``ds`` (m).

    ``nodes`` (m) body coordinates of the joints; ``section`` the reference section at
    :data:`P_REF`; ``c_ref`` / ``cs_ref`` bending (1/(N m)) and shear (1/N) compliances of
    each joint at :data:`P_REF`; ``r_cell`` (m) the smallest radius within half a segment of
    each node; ``radius_s``, ``radius_r`` (m) a radius profile at ``ds / 8``.
    """

    nodes: np.ndarray
    section: TubeSection
    c_ref: np.ndarray
    cs_ref: np.ndarray
    r_cell: np.ndarray
    radius_s: np.ndarray
    radius_r: np.ndarray


_cache: dict[tuple, MaterialTables] = {}


def material_tables(design: TubeDesign, ds: float, params: ModelParams) -> MaterialTables:
    """The tables of ``design`` at node spacing ``ds`` (m) with ``params``, cached per process."""
    key = (design, ds, repr(params))
    hit = _cache.get(key)
    if hit is not None:
        return hit
    n_nodes = int(math.floor(design.length_m / ds + 1e-9))
    nodes = np.arange(n_nodes) * ds
    section = TubeSection(design, P_REF, params)
    c_ref = hat_compliance(section, nodes, design.length_m)
    cs_ref = hat_compliance(section, nodes, design.length_m, shear=True)
    r_cell = min_radius(section, np.maximum(nodes - ds / 2, 0.0), nodes + ds / 2, 17)
    seg_s = np.linspace(0, design.length_m, int(design.length_m / (ds / 8)) + 2)
    seg_r = section.radius(seg_s)
    for a in (nodes, c_ref, cs_ref, r_cell, seg_s, seg_r):
        a.flags.writeable = False
    tables = MaterialTables(nodes, section, c_ref, cs_ref, r_cell, seg_s, seg_r)
    if len(_cache) >= CACHE_SIZE:
        _cache.pop(next(iter(_cache)))
    _cache[key] = tables
    return tables
