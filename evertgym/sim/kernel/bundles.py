"""The typed bundles the kernel's functions take and return (``typing.NamedTuple``: numba compiles
them as tuples, Python code builds and reads them by name).

Units are SI throughout.  Arrays inside a bundle may be updated in place (the unknowns ``phi`` and
``u`` are, by the Newton solve); the bundles themselves are never rebuilt to change a field.
"""

# (no ``from __future__ import annotations``: the bundles' fields keep their types as objects, which the
# API reference resolves in the package that re-exports them)
from typing import NamedTuple

import numpy as np


class LawTable(NamedTuple):
    """The joint law past wrinkling in normalised form (``h = M / M_c`` at ``x = phi / phi_w``):
    ``u`` a uniform grid of ``ln x``, ``h`` the law on it, ``hi`` its integral from 1, ``slope`` the
    slope beyond the grid's end, ``residual`` the residual stiffness as a fraction of ``k``."""

    u: np.ndarray
    h: np.ndarray
    hi: np.ndarray
    slope: float
    residual: float


class Joints(NamedTuple):
    """Per joint: the linear stiffness ``k`` (N m/rad) and the wrinkling moment ``mw`` (N m; 0: no
    wrinkling, the residual stiffness only)."""

    k: np.ndarray
    mw: np.ndarray


class Chain(NamedTuple):
    """The window's fixed geometry: the direction ``theta0`` (rad) of the segment before it, its first
    node ``n0`` (2,), and per segment its length ``seg_len`` and collision radius ``seg_rad`` (m)."""

    theta0: float
    n0: np.ndarray
    seg_len: np.ndarray
    seg_rad: np.ndarray


class Walls(NamedTuple):
    """Wall features: segments ``a``-``b`` (m; world coordinates for a static wall, the piece's frame
    for a compliant one), the piece of each (``piece``, -1 static), whether it is a vertex (``a == b``)
    and the radius of its shape (m)."""

    a: np.ndarray
    b: np.ndarray
    piece: np.ndarray
    vertex: np.ndarray
    radius: np.ndarray


class Pieces(NamedTuple):
    """The compliant wall pieces that are unknowns: rest origins ``pc0`` (npc, 2), each piece's own
    stiffness ``kaa`` (npc, 3, 3) on ``(dx, dy, dtheta)``, and the tether stop: the free travel
    ``travel`` (m) and the stop's stiffness ``k_travel`` (N/m), per piece."""

    pc0: np.ndarray
    kaa: np.ndarray
    travel: np.ndarray
    k_travel: np.ndarray


class ContactLaw(NamedTuple):
    """The barrier's reach ``dhat`` (m) and stiffness ``kappa`` (N/m), and friction's slip ``eps_v``
    (m of tangential travel per increment at which a contact slides)."""

    dhat: float
    kappa: float
    eps_v: float


class Problem(NamedTuple):
    """Everything fixed during one Newton solve of a window (the unknowns ``phi`` and ``u`` apart)."""

    chain: Chain
    joints: Joints
    law: LawTable
    walls: Walls
    pieces: Pieces
    contact: ContactLaw


class Entries(NamedTuple):
    """Lagged friction entries: material coordinate ``s`` of the robot point (m; -1 for the tip's
    cap), wall feature ``w``, the wall point ``wl`` in the feature's frame, the tangent ``t`` and
    ``ml``, the friction coefficient times the lagged normal force (N)."""

    s: np.ndarray
    w: np.ndarray
    wl: np.ndarray
    t: np.ndarray
    ml: np.ndarray


class Friction(NamedTuple):
    """Lagged friction entries resolved in a window: segment ``k`` and parameter ``s`` of the robot
    point, wall feature ``w`` and point ``wl`` (its frame), tangent ``t``, ``mulam`` (N), and the robot
    and wall points ``xr0``, ``xw0`` at the configuration before the solve (slip is measured from them)."""

    k: np.ndarray
    s: np.ndarray
    w: np.ndarray
    wl: np.ndarray
    t: np.ndarray
    mulam: np.ndarray
    xr0: np.ndarray
    xw0: np.ndarray


class LagSource(NamedTuple):
    """What the friction lag makes its entries from: the window's nodes ``start_nodes`` and pieces'
    displacements ``u0`` before the solve (slip is measured from them), the nodes' material
    coordinates ``s_nodes`` (m), and the friction coefficients per segment ``robot_mu`` and per wall
    feature ``wall_mu``."""

    start_nodes: np.ndarray
    u0: np.ndarray
    s_nodes: np.ndarray
    robot_mu: np.ndarray
    wall_mu: np.ndarray


class SolveSettings(NamedTuple):
    """A solve's stop and limits: the largest unbalanced joint moment ``tol_m`` (N m) and wall-piece
    force ``tol_f`` (N), the Newton budget ``max_iter``, the largest node displacement of one step
    ``max_move`` (m), the friction re-solves ``lag_iterations``, and ``semi``: the O(m) semiseparable
    linear solver (else the dense one)."""

    tol_m: float
    tol_f: float
    max_iter: int
    max_move: float
    lag_iterations: int
    semi: bool


class SolveResult(NamedTuple):
    """A window's equilibrium (:func:`evertgym.sim.kernel.newton.solve_increment`): the status code,
    Newton iterations, the largest unbalanced moment (N m) and piece force (N) at the end, the new
    lagged friction ``entries``, the wall forces per segment ``seg_force`` (m, 2; N) and their moments
    about the origin ``seg_moment`` (m; N m), ``tip`` = ``(F_tip, fx, fy, gap)`` (the reaction against
    growth and the total force on the tip segment, N; the tip segment's smallest gap, m) and the
    contact ``rows`` at the end (:func:`evertgym.sim.kernel.contacts.pair_rows`); ``lag_converged``: whether
    the friction lag's normal forces stopped changing within its refreshes, and ``refreshes``: how many
    times the lag's entries were made again."""

    status: int
    iterations: int
    residual_m: float
    residual_f: float
    entries: Entries
    seg_force: np.ndarray
    seg_moment: np.ndarray
    tip: np.ndarray
    rows: np.ndarray
    lag_converged: bool
    refreshes: int


class Body(NamedTuple):
    """The whole chain of a scene: nodes (n + 1, 2), joint rotations ``phi``, segment lengths and
    radii, the nodes' material coordinates ``s_nodes`` (n,) and the tip's ``length`` (m), and its
    joints' stiffnesses and wrinkling moments."""

    nodes: np.ndarray
    phi: np.ndarray
    seg_len: np.ndarray
    seg_rad: np.ndarray
    s_nodes: np.ndarray
    length: float
    joints: Joints


class SceneWalls(NamedTuple):
    """Every wall feature of a scene (:class:`Walls`), with its box (``box_lo``, ``box_hi``; a
    piece's covers its travel) and its friction coefficient ``mu``."""

    walls: Walls
    box_lo: np.ndarray
    box_hi: np.ndarray
    mu: np.ndarray


class ScenePieces(NamedTuple):
    """Every compliant wall piece of a scene: rest origins, displacements ``u`` and the cosine and
    sine of their rotations, own stiffnesses ``k_piece``, and the tether stop (``travel`` m,
    ``k_travel`` N/m, the same for every piece)."""

    pc0: np.ndarray
    u: np.ndarray
    cos_u: np.ndarray
    sin_u: np.ndarray
    k_piece: np.ndarray
    travel: float
    k_travel: float


class WindowQuery(NamedTuple):
    """Which window a solve takes: joints ``a..``, the direction ``theta0`` of the segment before
    it, the segment length ``ds`` (m), the reach of its walls ``reach`` and of its unknown pieces
    ``piece_reach`` (m), and the robot's friction coefficients on its side ``wall_mu`` and its tip
    ``tip_mu``."""

    a: int
    theta0: float
    ds: float
    reach: float
    piece_reach: float
    wall_mu: float
    tip_mu: float


class Window(NamedTuple):
    """A solve's window (:func:`evertgym.sim.kernel.window.window_setup`): whether it overlaps a wall
    (nothing else is gathered then), its ``chain``, joint rotations ``phi``, node material
    coordinates ``s_nodes``, ``joints``; the wall features ``sel`` (indices into the scene's) it sees
    as ``walls`` with their friction ``wall_mu``; the unknown pieces (``pieces``, indices into the
    scene's) with their data and displacements ``u``; the robot's friction per segment ``robot_mu``;
    which of the scene's friction entries lie in it (``in_window``) and those that do, as ``entries``
    (their features as positions in ``sel``)."""

    overlap: bool
    chain: Chain
    phi: np.ndarray
    s_nodes: np.ndarray
    joints: Joints
    sel: np.ndarray
    walls: Walls
    wall_mu: np.ndarray
    pieces: np.ndarray
    piece_data: Pieces
    u: np.ndarray
    robot_mu: np.ndarray
    in_window: np.ndarray
    entries: Entries


class Accumulators(NamedTuple):
    """Where the contact and friction terms add their forces and Hessian parts
    (:mod:`evertgym.sim.kernel.terms`), for a window of ``m`` segments and ``npc`` pieces.

    Per segment ``k``: ``acc_f`` the sum of the wall forces on the robot (N), ``acc_m`` of ``p x f``
    (N m), ``acc_fx`` of ``f . p`` (N m); ``tip`` = ``(F_tip, fx, fy, gap)`` of the tip segment;
    ``grad`` the gradient over ``[phi, u.ravel()]`` (the pieces' generalised forces go into
    ``grad[m:]``).  The Hessian's parts: ``smat`` (m, 3, 3) the rank-one sums of each segment's
    contacts (expanded on the joints by :mod:`evertgym.sim.kernel.potential`), ``va`` and ``vf`` the
    curvature of a distance to a line that turns with the joints, ``hjp`` the joints-pieces block
    (dense, m x 3 npc), ``hpp`` each piece's own block, and, if ``rec`` has rows, the joints-pieces
    couplings as records instead (``nrec[0]`` of them used)."""

    grad: np.ndarray
    acc_f: np.ndarray
    acc_m: np.ndarray
    acc_fx: np.ndarray
    tip: np.ndarray
    smat: np.ndarray
    va: np.ndarray
    vf: np.ndarray
    hjp: np.ndarray
    hpp: np.ndarray
    rec: np.ndarray
    nrec: np.ndarray


class Hessian(NamedTuple):
    """The Hessian of the incremental potential over ``[phi, u.ravel()]`` in blocks: the joints'
    ``hess`` (m, m; (1, 1) with the semiseparable solver), or its generators ``gen`` (m, 7) =
    ``[d, a, p]`` (``H_ij = d_j [i = j] + a_i . p_j`` for ``i <= j``; (1, 7) with the dense solver);
    the joints-pieces block ``hjp`` (m, 3 npc; with the semiseparable solver its records, rows of
    ``[piece, k, c, g]``); each piece's own block ``hpp`` (npc, 3, 3)."""

    hess: np.ndarray
    gen: np.ndarray
    hjp: np.ndarray
    hpp: np.ndarray
