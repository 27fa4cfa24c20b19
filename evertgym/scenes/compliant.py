"""Compliant channel walls: rigid wall pieces on springs, and their exact linear statics (SI).

Mechanical model (one 2-D wall stands for half the circumference of a silicone tube):

* **Foundation.**  Each metre of tube length resists a normal (radial) displacement of its
  wall with ``k_n = k_ring + k_susp`` (N/m per m, i.e. N/m^2) and a tangential (axial) one
  with ``k_t = k_susp``.

  - ``k_ring = E h^3 / (12 (1 - nu^2) c R^3)`` is the ovalisation stiffness of the tube's
    cross-section: a thin ring of mid-wall radius ``R`` under two opposite point loads changes
    its diameter by ``c F R^3 / (E I)`` with ``c = pi/4 - 2/pi = 0.149`` (Roark's Formulas
    for Stress and Strain, thin circular rings), ``I = h^3 / (12 (1 - nu^2))`` per unit
    length of a wide ring.  It is lumped as a spring to ground on each wall, which is exact
    when the opposite wall is held.  For the phantom (Ecoflex 00-50, ``E`` = 83 kPa, the
    100 % modulus of 12 psi in Smooth-On's technical bulletin; ``h`` = 3 mm; ``R`` = 14.5 mm;
    ``nu`` = 0.49) ``k_ring`` = 0.54 N/m per mm of tube.
  - ``k_susp`` is the mesocolon-like suspension: the paper's phantom was held on a board by
    elastic bands and magnets (stiffness not reported; the default, 1 N/m per mm, is an
    assumption: bands of about 50 N/m every 50 mm).

* **Continuity.**  Neighbouring pieces are joined at their shared end point by a zero-length
  spring; with ``T = k_n * lambda^2`` and joint spacing ``l`` its stiffness is ``T / l``, so
  a local indentation decays along the wall over about ``lambda`` (``wall_influence_mm``, of
  the order of the shell bending length ``sqrt(R h) / (3 (1 - nu^2))^(1/4)`` = 5 mm and of
  the piece length).  The first piece is joined the same way to the (rigid) entry funnel:
  the paper fixed the rectal end with a magnet.

* **Dynamics.**  Pieces carry their physical mass (density 1070 kg/m^3, a half-tube strip);
  if the stiffest mode would then exceed ``omega dt = 0.3`` at ``dt = 1 ms`` the masses are
  scaled up uniformly (quasi-static use only).  Every spring gets damping ``beta * k`` with
  ``beta = 1 / omega_min`` (stiffness-proportional damping: damping ratio 0.5 for the softest
  mode, more for stiffer ones; of the factors 0.3-2 / omega_min tried this settled fastest).
  ``time_constant_s = beta``; a load or unload settles to 1 % in about 5 of them (measured
  0.10 s, i.e. 100 steps of 1 ms, for the default phantom).

The spring network is linear (zero-length springs exactly; the directional suspension springs
up to terms of order ``(u / 50 mm)^2``), so its static response is ``K u = f`` with ``K``
assembled by :meth:`WallNetwork.stiffness_matrix`; :meth:`WallNetwork.point_stiffness` is the
stiffness a single piece shows under a point load, and is what the simulation reproduces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pymunk

from evertgym._blas import one_blas_thread
from evertgym.scenes.geometry import polyline_normals, simplify

#: Roark's coefficient for the diameter change of a thin ring under two opposite point loads.
RING_COEFFICIENT = math.pi / 4 - 2 / math.pi
#: Density of Ecoflex 00-50 (specific gravity 1.07, Smooth-On), kg/m^3.
ECOFLEX_DENSITY = 1070.0
#: Reference time step (s) for which the wall is made stable, and the target ``omega_max * dt``.
REFERENCE_DT = 1e-3
MAX_OMEGA_DT = 0.3
#: Length (m) of the directional suspension springs; only their direction matters.
ANCHOR_LENGTH = 0.05
#: Shape filter category bit shared by every wall shape (walls never collide with walls).
WALL_CATEGORY = 1 << 30
WALL_COLLISION_TYPE = 2
WALL_FRICTION = 1.0
WALL_ELASTICITY = 0.0


def wall_shape_filter() -> pymunk.ShapeFilter:
    """Filter of wall shapes: category :data:`WALL_CATEGORY`, colliding with everything but walls."""
    return pymunk.ShapeFilter(categories=WALL_CATEGORY, mask=pymunk.ShapeFilter.ALL_MASKS() ^ WALL_CATEGORY)


def style_wall_shape(shape: pymunk.Shape) -> pymunk.Shape:
    """Give a wall shape its friction, elasticity, collision type and filter."""
    shape.friction = WALL_FRICTION
    shape.elasticity = WALL_ELASTICITY
    shape.collision_type = WALL_COLLISION_TYPE
    shape.filter = wall_shape_filter()
    return shape


#: Fraction of a tether's overshoot left after 1 s (about 24% corrected per 2 ms step).
TETHER_ERROR_BIAS = 1e-60


@dataclass(frozen=True)
class WallMechanics:
    """Per-unit-length wall mechanics (SI) of a compliant tube of mean lumen ``lumen_m``."""

    modulus_pa: float
    thickness_m: float
    lumen_m: float
    suspension_n_per_m2: float
    influence_m: float
    piece_length_m: float
    #: Largest excursion of a wall piece from its rest place (m): the phantom lies on a
    #: board held by bands and magnets (in vivo: the surrounding organs), so a pushed wall
    #: stops; and a 2-D wall of separate pieces would otherwise open gaps a robot can pass.
    max_travel_m: float = 0.008
    poisson: float = 0.49
    density: float = ECOFLEX_DENSITY

    @property
    def mid_radius_m(self) -> float:
        return 0.5 * (self.lumen_m + self.thickness_m)

    @property
    def ring_n_per_m2(self) -> float:
        """Ovalisation stiffness of the tube wall per unit tube length (N/m per m)."""
        bending = self.modulus_pa * self.thickness_m**3 / (12.0 * (1.0 - self.poisson**2))
        return bending / (RING_COEFFICIENT * self.mid_radius_m**3)

    @property
    def normal_n_per_m2(self) -> float:
        """Normal foundation stiffness per unit tube length: ring + suspension (N/m per m)."""
        return self.ring_n_per_m2 + self.suspension_n_per_m2

    @property
    def tangential_n_per_m2(self) -> float:
        return self.suspension_n_per_m2

    @property
    def tension_n(self) -> float:
        """Equivalent wall tension ``k_n lambda^2`` (N) setting the neighbour coupling."""
        return self.normal_n_per_m2 * self.influence_m**2

    @property
    def mass_per_m(self) -> float:
        """Mass of one wall (half the tube's circumference) per metre of tube (kg/m)."""
        return self.density * self.thickness_m * math.pi * self.mid_radius_m

    def summary(self) -> dict[str, float]:
        """The derived stiffnesses in the units of the scene parameters."""
        return {
            "wall_ring_stiffness_n_per_m_per_mm": self.ring_n_per_m2 * 1e-3,
            "wall_stiffness_n_per_m_per_mm": self.normal_n_per_m2 * 1e-3,
            "wall_tangential_stiffness_n_per_m_per_mm": self.tangential_n_per_m2 * 1e-3,
            "piece_stiffness_n_per_m": self.normal_n_per_m2 * self.piece_length_m,
        }


@dataclass
class WallNetwork:
    """Wall pieces and springs of one compliant scene, before and after building into a space.

    Arrays (P pieces, S springs): ``position`` (P, 2) rest positions of the piece bodies (the
    midpoint of the piece's two end points on the wall); ``normal`` (P, 2) outward unit normals;
    ``length`` (P,) centreline arc length each piece covers; ``outline`` per piece the
    (local) vertices of its wall shape's centre line.  Springs: bodies ``sa, sb`` (piece index,
    -1 for the static body), world attachment points ``pa, pb``, stiffness ``k``, unit
    ``direction`` (NaN for zero-length springs) and ``rest`` length.
    """

    mechanics: WallMechanics
    position: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    length: np.ndarray
    outline: list[np.ndarray]
    shape_radius: float
    sa: np.ndarray
    sb: np.ndarray
    pa: np.ndarray
    pb: np.ndarray
    k: np.ndarray
    direction: np.ndarray
    rest: np.ndarray

    @cached_property
    def physical_mass(self) -> np.ndarray:
        """Each piece's own mass (kg): the strip's density times its volume."""
        return self.mechanics.mass_per_m * self.length

    @cached_property
    def physical_moment(self) -> np.ndarray:
        """Each piece's own moment of inertia (kg m^2) about its centre, as a rod."""
        return self.physical_mass * self.length**2 / 12.0

    @cached_property
    def _dynamics(self) -> tuple[float, float]:
        """``(mass_scale, time_constant_s)`` of the dynamic engine's wall (module docstring).

        Computed on first use: the quasi-static engine never steps the wall, needs neither, and so
        never imports the sparse eigensolver.
        """
        lam_min, lam_max = self._extreme_eigenvalues()
        mass_scale = max(1.0, lam_max * (REFERENCE_DT / MAX_OMEGA_DT) ** 2)
        return mass_scale, 1.0 / math.sqrt(lam_min / mass_scale)

    @property
    def mass_scale(self) -> float:
        """Uniform factor on the pieces' masses and moments for the dynamic engine (>= 1)."""
        return self._dynamics[0]

    @property
    def time_constant_s(self) -> float:
        """``beta`` (s): the springs' damping over their stiffness, ``1 / omega_min``."""
        return self._dynamics[1]

    @property
    def mass(self) -> np.ndarray:
        """Each piece's mass (kg) in the dynamic engine: the physical mass times :attr:`mass_scale`."""
        return self.physical_mass * self.mass_scale

    @property
    def moment(self) -> np.ndarray:
        """Each piece's moment of inertia (kg m^2) in the dynamic engine, scaled like :attr:`mass`."""
        return self.physical_moment * self.mass_scale

    def _extreme_eigenvalues(self) -> tuple[float, float]:
        """Smallest and largest ``omega^2`` of ``K x = omega^2 M x`` (M diagonal).

        The symmetric form ``M^-1/2 K M^-1/2`` is banded (each piece couples only to its
        neighbours), so a sparse Lanczos solve (shift-invert about 0 for the smallest)
        costs milliseconds where a dense ``eigh`` of the same matrix took half a second.
        """
        import scipy.sparse
        import scipy.sparse.linalg

        k = np.asarray(self.stiffness_matrix())
        w = 1.0 / np.sqrt(np.column_stack([self.physical_mass, self.physical_mass, self.physical_moment]).ravel())
        a = scipy.sparse.csc_matrix(k * w[:, None] * w[None, :])
        if a.shape[0] <= 32:
            lam = np.linalg.eigvalsh(a.toarray())
            return float(lam[0]), float(lam[-1])
        v0 = np.ones(a.shape[0])  # ARPACK's default start is random: keep scenes bit-for-bit
        lam_max = scipy.sparse.linalg.eigsh(a, k=1, which="LA", v0=v0, return_eigenvectors=False, tol=1e-8)[0]
        lam_min = scipy.sparse.linalg.eigsh(a, k=1, sigma=0.0, which="LM", v0=v0, return_eigenvectors=False, tol=1e-8)[0]
        return float(lam_min), float(lam_max)

    @property
    def n_pieces(self) -> int:
        return len(self.position)

    @property
    def damping(self) -> np.ndarray:
        """Damping (N s/m) of each spring: ``time_constant_s * k``."""
        return self.time_constant_s * self.k

    def stiffness_matrix(self) -> np.ndarray:
        """Linear stiffness ``K`` (3P x 3P) in the DOFs ``(x, y, theta)`` of every piece."""
        n = self.n_pieces
        K = np.zeros((3 * n, 3 * n))
        for a, b, pa, pb, k, d in zip(self.sa, self.sb, self.pa, self.pb, self.k, self.direction):
            # relative displacement of the attachment points: sum over ends of sign * B_end @ u
            rows = []
            for body, p, sign in ((a, pa, -1.0), (b, pb, 1.0)):
                if body < 0:
                    continue
                r = p - self.position[body]
                rows.append((body, sign * np.array([[1.0, 0.0, -r[1]], [0.0, 1.0, r[0]]])))
            proj = np.eye(2) if np.isnan(d[0]) else np.outer(d, d)
            for bi, Bi in rows:
                for bj, Bj in rows:
                    K[3 * bi:3 * bi + 3, 3 * bj:3 * bj + 3] += k * Bi.T @ proj @ Bj
        return K

    @cached_property
    def compliance_matrix(self) -> np.ndarray:
        """``K^-1`` (3P x 3P), inverted with one BLAS thread (:mod:`evertgym._blas`: the bits do not
        depend on the cores)."""
        with one_blas_thread():
            return np.linalg.inv(self.stiffness_matrix())

    def point_stiffness(self, piece: int, direction: np.ndarray | None = None) -> float:
        """Stiffness (N/m) of ``piece`` under a force at its body position along ``direction``.

        ``direction`` defaults to the piece's outward normal.  Includes the coupling to the
        neighbours, so it exceeds the foundation's share ``k_n * length``.
        """
        d = self.normal[piece] if direction is None else np.asarray(direction, float)
        d = d / np.linalg.norm(d)
        c = self.compliance_matrix[3 * piece:3 * piece + 2, 3 * piece:3 * piece + 2]
        return 1.0 / float(d @ c @ d)

    def build(self, space: pymunk.Space, stiffness_factor: float = 1.0, dynamics: bool = True
              ) -> tuple[list[pymunk.Body], list[pymunk.Shape], list[pymunk.Constraint]]:
        """Add the pieces (dynamic bodies), their shapes, tethers and springs to ``space``; returns the bodies,
        the shapes and the springs.

        Spring stiffnesses are multiplied by ``stiffness_factor`` (see :meth:`Scene.build`).
        ``dynamics=False`` is for an engine that never steps ``space`` (the quasi-static one, which
        reads the wall's statics from :attr:`compliance_matrix` and shows its solved displacements on
        the bodies): the bodies get the physical masses and no tether or spring is built, so the
        eigenvalue problem behind :attr:`mass_scale` is never solved.
        """
        bodies: list[pymunk.Body] = []
        shapes: list[pymunk.Shape] = []
        springs: list[pymunk.Constraint] = []
        mass, moment = (self.mass, self.moment) if dynamics else (self.physical_mass, self.physical_moment)
        for i in range(self.n_pieces):
            body = pymunk.Body(float(mass[i]), float(moment[i]))
            body.position = tuple(self.position[i])
            pts = self.outline[i]
            segs = [style_wall_shape(pymunk.Segment(body, tuple(pts[j]), tuple(pts[j + 1]), self.shape_radius))
                    for j in range(len(pts) - 1)]
            space.add(body, *segs)
            bodies.append(body)
            shapes += segs
            if not dynamics:
                continue
            tether = pymunk.SlideJoint(space.static_body, body, tuple(self.position[i]), (0.0, 0.0), 0.0,
                                       self.mechanics.max_travel_m)
            # correct an overshoot within a few steps (the default, 10% per 1/60 s, lets a
            # loaded piece pass its travel by millimetres and creep back over seconds)
            tether.error_bias = TETHER_ERROR_BIAS
            space.add(tether)
        if not dynamics:
            return bodies, shapes, springs
        for a, b, pa, pb, k, rest, c in zip(self.sa, self.sb, self.pa, self.pb, self.k, self.rest, self.damping):
            ba = space.static_body if a < 0 else bodies[a]
            bb = space.static_body if b < 0 else bodies[b]
            la = tuple(pa - (0.0 if a < 0 else self.position[a]))
            lb = tuple(pb - (0.0 if b < 0 else self.position[b]))
            spring = pymunk.DampedSpring(ba, bb, la, lb, float(rest), float(k * stiffness_factor), float(c))
            space.add(spring)
            springs.append(spring)
        return bodies, shapes, springs


def design_wall_network(mech: WallMechanics, s: np.ndarray, centre_normal: np.ndarray, walls: list[np.ndarray],
                        first: int) -> WallNetwork:
    """Split the walls from sample ``first`` to the end into pieces and spring them.

    ``s`` (N,) centreline arc length, ``centre_normal`` (N, 2) left unit normals of the
    centreline, ``walls`` the [left, right] inner-surface polylines sampled like ``s``.
    Pieces span about ``mech.piece_length_m`` of centreline; each has two normal springs (at
    its ends) and one tangential spring (at its middle) to the static body, and is joined to
    its predecessor (the first one to the static wall before ``first``) by a zero-length link.
    """
    span = s[-1] - s[first]
    n = max(1, int(round(span / mech.piece_length_m)))
    bounds = np.unique(np.searchsorted(s, s[first] + span * np.arange(n + 1) / n))
    bounds[-1] = len(s) - 1
    radius = 0.5 * mech.thickness_m
    kn, kt, tension = mech.normal_n_per_m2, mech.tangential_n_per_m2, mech.tension_n
    pos: list[np.ndarray] = []
    nor: list[np.ndarray] = []
    tan: list[np.ndarray] = []
    ln: list[float] = []
    outline: list[np.ndarray] = []
    sa: list[int] = []
    sb: list[int] = []
    pa: list[np.ndarray] = []
    pb: list[np.ndarray] = []
    kk: list[float] = []
    dd: list[np.ndarray] = []
    rr: list[float] = []

    def spring(a: int, b: int, p_a, p_b, k: float, d=None, rest: float = 0.0) -> None:
        sa.append(a)
        sb.append(b)
        pa.append(np.asarray(p_a, float))
        pb.append(np.asarray(p_b, float))
        kk.append(k)
        dd.append(np.full(2, np.nan) if d is None else np.asarray(d, float))
        rr.append(rest)

    for side, wall in enumerate(walls):
        sign = 1.0 if side == 0 else -1.0  # outward: left of travel for the left wall, right for the right
        shell = wall + sign * polyline_normals(wall) * radius  # centre line of the wall shapes
        prev_end = None
        for a, b in zip(bounds[:-1], bounds[1:]):
            m = (a + b) // 2
            i = len(pos)
            n_out = sign * centre_normal[m]
            t = np.array([n_out[1], -n_out[0]]) * sign
            length = s[b] - s[a]
            centre = 0.5 * (wall[a] + wall[b])  # between the normal springs: a uniform push cannot twist it
            pos.append(centre)
            nor.append(n_out)
            tan.append(t)
            ln.append(length)
            keep = a + simplify(shell[a:b + 1], 2e-5)
            outline.append(shell[keep] - centre)
            for end in (a, b):
                spring(-1, i, wall[end] + n_out * ANCHOR_LENGTH, wall[end], 0.5 * kn * length, -n_out, ANCHOR_LENGTH)
            spring(-1, i, wall[m] - t * ANCHOR_LENGTH, wall[m], kt * length, t, ANCHOR_LENGTH)
            joint = length if prev_end is None else 0.5 * (length + ln[-2])
            spring(-1 if prev_end is None else i - 1, i, wall[a], wall[a], tension / joint)
            prev_end = b
    return WallNetwork(
        mechanics=mech, position=np.array(pos), normal=np.array(nor), tangent=np.array(tan), length=np.array(ln),
        outline=outline, shape_radius=radius, sa=np.array(sa), sb=np.array(sb), pa=np.array(pa), pb=np.array(pb),
        k=np.array(kk), direction=np.array(dd), rest=np.array(rr),
    )
