"""The quasi-static engine's compiled kernel: one static equilibrium of a window of the chain.

The unknowns are the relative rotations ``phi`` (rad) of the window's joints and the displacements
``u = (dx, dy, dtheta)`` (m, m, rad) of the compliant wall pieces near it.  The window's first node
and the direction of the segment before it are held.  Equilibrium is the stationary point of the
incremental potential (Incremental Potential Contact, Li et al., SIGGRAPH 2020)::

    E = sum_j W_j(phi_j)                       joint law (linear, tension field, kink plateau)
      + sum_pairs kappa b(d)                   log barrier on every robot-wall capsule gap d < d_hat
      + sum_lagged mu lambda f0(|u_T|)         Coulomb friction, normal force and tangent lagged
      + 1/2 u^T K u + travel(u)                compliant wall pieces (linear springs, tether stop)

Modules, in the order a solve uses them:

* :mod:`~evertgym.sim.kernel.bundles`: the typed bundles the functions take and return;
* :mod:`~evertgym.sim.kernel.window`: a solve's window gathered from the scene, and merged back;
* :mod:`~evertgym.sim.kernel.geometry`: chain nodes, piece poses, point-edge distances;
* :mod:`~evertgym.sim.kernel.contacts`: candidate pairs, contact rows, feature selection, overlap;
* :mod:`~evertgym.sim.kernel.terms`: the four energy terms, each with value, gradient and Hessian;
* :mod:`~evertgym.sim.kernel.potential`: the terms summed and carried onto the joints;
* :mod:`~evertgym.sim.kernel.linear`: the Newton step's dense and semiseparable solves;
* :mod:`~evertgym.sim.kernel.ccd`: the collision-free bound of a step;
* :mod:`~evertgym.sim.kernel.friction`: the lagged friction entries;
* :mod:`~evertgym.sim.kernel.newton`: the Newton driver and the friction lag;
* :mod:`~evertgym.sim.kernel.api`: the entry points the engine calls from Python per solve
  (``window_setup``, ``solve_increment``, ``merge_friction``), re-exported here.

Everything is SI.  The functions are compiled with numba (``cache=True``): the first call in a fresh
environment compiles them, later processes load the cache.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

from evertgym.sim.kernel.api import merge_friction, solve_increment, window_setup
from evertgym.sim.kernel.bundles import (
    Body,
    Chain,
    ContactLaw,
    Entries,
    Friction,
    Joints,
    LawTable,
    Pieces,
    Problem,
    ScenePieces,
    SceneWalls,
    SolveResult,
    SolveSettings,
    Walls,
    Window,
    WindowQuery,
)
from evertgym.sim.kernel.contacts import boxes_near, contacts, overlaps, segment_gap, select_features, touching
from evertgym.sim.kernel.geometry import chain_nodes, max_node_shift
from evertgym.sim.kernel.newton import CONVERGED, INFEASIBLE_START, LINE_SEARCH_FAILED, MAX_ITERATIONS, solve
from evertgym.sim.kernel.terms import joint_moments, kinked_joints
from evertgym.sim.kernel.window import gather_walls, piece_window, window_friction


def _drop_stale_cache() -> None:
    """Delete the kernel's numba cache when any of its modules changed since it was written.

    numba keys a function's cache on its own file alone, while the compiled code of a caller holds its
    callees: an edit of ``terms.py`` would leave ``newton.py``'s cached solve with the old terms.  The
    cache (``__pycache__/*.nbi``, ``*.nbc`` beside the sources) is kept only while a digest of every
    module's source matches the one stored with it; where the folder cannot be written (an installed
    package), numba keeps its cache elsewhere and nothing is done here."""
    here = Path(__file__).parent
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(here.glob("*.py")))).hexdigest()
    cache = here / "__pycache__"
    stamp = cache / "kernel-sources.sha256"
    try:
        if stamp.is_file() and stamp.read_text() == digest:
            return
        for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
            f.unlink()
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass


# (before any kernel function is first called: numba loads a cache then)
_drop_stale_cache()

#: The largest drive the barrier is scaled to (Pa): the robots' highest operating pressure.
BARRIER_DRIVE_PA = 8000.0
#: The barrier's stiffness as a fraction of that drive's force ``p pi r^2`` per barrier gap.
BARRIER_STIFFNESS_FRACTION = 0.1


def barrier_stiffness(radius_m: float, dhat_m: float) -> float:
    """The barrier's stiffness ``kappa`` (N/m): :data:`BARRIER_STIFFNESS_FRACTION` of the largest
    drive's force (:data:`BARRIER_DRIVE_PA` times ``pi r^2``) per barrier gap ``dhat``."""
    return BARRIER_STIFFNESS_FRACTION * BARRIER_DRIVE_PA * math.pi * radius_m**2 / dhat_m


__all__ = [
    "BARRIER_DRIVE_PA", "BARRIER_STIFFNESS_FRACTION", "Body", "CONVERGED", "Chain", "ContactLaw", "Entries", "Friction",
    "INFEASIBLE_START", "Joints", "LINE_SEARCH_FAILED", "LawTable", "MAX_ITERATIONS", "Pieces", "Problem", "ScenePieces", "SceneWalls",
    "SolveResult", "SolveSettings", "Walls", "Window", "WindowQuery", "barrier_stiffness", "boxes_near", "chain_nodes", "contacts", "gather_walls",
    "joint_moments", "kinked_joints", "max_node_shift", "merge_friction", "overlaps", "piece_window", "segment_gap", "select_features",
    "solve", "solve_increment", "touching", "window_friction", "window_setup",
]
