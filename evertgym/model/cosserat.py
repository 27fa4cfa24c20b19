"""Static planar Cosserat rod of a pressurised thin-walled tube (the paper's equation 1).

The rod is clamped at ``s = s_base`` pointing along +x and loaded by a point force
``F = (Fx, Fy)`` at ``s = s_c`` (the tip by default).  In the plane the paper's system

    R' = R (Kbt^-1 R^T m)^,   P' = R (Kse^-1 R^T n + e3),   n' = -F delta(s - s_c),
    m' = -P' x n

reduces, with ``R = rot(theta)``, to

    theta' = kappa(m, s),
    P'     = (1 + n_t / EA(s)) t + (n_n / GA(s)) nu,      n = F for s < s_c, 0 beyond,
    m(s)   = m(s_base) - ((P(s) - P(s_base)) x F)_z,

where ``t``, ``nu`` are the tangent and normal and ``n_t``, ``n_n`` the force components
on them: extension and shear are included.  ``kappa(m, s)`` is linear, ``m / EI(s)``, up
to the wrinkling moment and follows the tension-field law of
:mod:`evertgym.model.pressure` beyond it, up to the collapse (kink) moment.  The unknown
``m(s_base)`` (and, under displacement control, the lateral force) is found by shooting
so that ``m(s_c) = 0``; the rod beyond ``s_c`` carries no load and stays straight.

Integration is piecewise between the kinks of the band profile (DOP853, rtol 1e-10),
so discontinuities in EI'(s) never straddle a step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root, root_scalar

from evertgym.model.pressure import (
    KINK_MOMENT_FRACTION,
    wrinkled_curvature_ratio_scalar,
)
from evertgym.model.section import TubeSection


class RodSolveError(RuntimeError):
    """The shooting did not converge (typically: the load exceeds a section's collapse moment)."""


class _WoundError(RodSolveError):
    """A shooting trial wound past MAX_TURN: cut short, it is not the solution sought."""


#: Trial shapes turning more than this (rad) are abandoned during shooting: the tensile
#: test and contact loads of interest never turn the tube by more than a half turn.
MAX_TURN = math.pi


@dataclass
class RodSolution:
    """A static equilibrium. Coordinates in m (clamp at the origin, rod along +x)."""

    s: np.ndarray
    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    moment: np.ndarray
    force: tuple[float, float]
    max_moment_fraction: float  # max over s of |m| / M_c (1 means collapse)
    wrinkled: bool  # some section passed its wrinkling moment
    kinked: bool  # some section reached the kink plateau

    @property
    def tip_x(self) -> float:
        return float(self.x[-1])

    @property
    def tip_y(self) -> float:
        return float(self.y[-1])

    @property
    def tip_angle(self) -> float:
        return float(self.theta[-1])


class CosseratRod:
    """A clamped planar Cosserat rod over ``[s_base, s_tip]`` of a :class:`TubeSection`.

    Parameters
    ----------
    section: section properties along the body.
    s_base, s_tip: clamp and free end, body coordinates (m).
    shear, extension: include shear and extension (the paper's Kse); switch off to
        compare with Euler-Bernoulli theory.
    wrinkling: use the tension-field moment law past ``M_w`` (linear when False or p = 0).
    rtol: integrator tolerance.
    """

    def __init__(
        self,
        section: TubeSection,
        s_base: float,
        s_tip: float,
        *,
        shear: bool = True,
        extension: bool = True,
        wrinkling: bool = True,
        rtol: float = 1e-10,
        method: str = "DOP853",
    ):
        if not s_tip > s_base:
            raise ValueError(f"s_tip = {s_tip!r} must exceed s_base = {s_base!r}")
        self.section = section
        self.s_base = float(s_base)
        self.s_tip = float(s_tip)
        self.shear = shear
        self.extension = extension
        self.wrinkling = wrinkling and section.pressure_pa > 0
        self.rtol = rtol
        self.method = method
        self.length = self.s_tip - self.s_base

    # ---- constitutive ------------------------------------------------------------
    def _props(self, s: float) -> tuple[float, float, float, float, float]:
        sec = self.section
        ei = float(sec.bending_stiffness(s))
        ea = float(sec.axial_stiffness(s)) if self.extension else math.inf
        ga = float(sec.shear_stiffness(s)) if self.shear else math.inf
        mw = float(sec.wrinkling_moment(s))
        return ei, ea, ga, mw, 2.0 * mw

    def _pieces(self, s_end: float) -> list[tuple[float, float, object]]:
        """Intervals of [s_base, s_end] with a fast props function each.

        Between breakpoints every band's shape is linear in s, so where at most one
        band zone is active the reduction and alpha are linear: the props are evaluated
        in closed form from the interval's end values (no numpy in the ODE right-hand
        side).  Overlapping zones fall back to the general evaluation.
        """
        sec = self.section
        cuts = [self.s_base] + [b for b in sec.breakpoints() if self.s_base < b < s_end] + [s_end]
        e, g_ratio = sec.e_eff_pa, sec.g_eff_pa / sec.e_eff_pa
        r0, t, p = sec.r0, sec.t, sec.pressure_pa
        pieces: list[tuple[float, float, object]] = []
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b - a <= 1e-12:
                continue
            mid = 0.5 * (a + b)
            active = [z for z in sec.zones if z.start_m < mid < z.end_m]
            if len(active) > 1:
                pieces.append((a, b, self._props))
                continue
            if active:
                z = active[0]
                # sample inside the interval (the shape is linear there; its ends may sit
                # exactly on a discontinuity when the taper is zero) and extrapolate
                w1, w3 = float(z.shape(a + 0.25 * (b - a))), float(z.shape(a + 0.75 * (b - a)))
                wa, wb = 1.5 * w1 - 0.5 * w3, 1.5 * w3 - 0.5 * w1
                rho_a, rho_b = z.reduction * wa, z.reduction * wb
                al_a, al_b = 1 - (1 - z.alpha) * wa, 1 - (1 - z.alpha) * wb
            else:
                rho_a = rho_b = 0.0
                al_a = al_b = 1.0

            def props(s, a=a, b=b, rho_a=rho_a, rho_b=rho_b, al_a=al_a, al_b=al_b):
                u = (s - a) / (b - a)
                r = r0 * (1.0 - (rho_a + (rho_b - rho_a) * u))
                al = al_a + (al_b - al_a) * u
                ea = al * e * 2.0 * math.pi * r * t
                mw = 0.5 * p * math.pi * r**3
                return (
                    al * e * math.pi * r**3 * t,
                    ea if self.extension else math.inf,
                    ea * g_ratio if self.shear else math.inf,
                    mw,
                    2.0 * mw,
                )

            pieces.append((a, b, props))
        return pieces

    def _curvature(self, m: float, ei: float, mw: float, mc: float) -> tuple[float, bool]:
        if not self.wrinkling or abs(m) <= mw:
            return m / ei, False
        ratio = wrinkled_curvature_ratio_scalar(abs(m) / mc)
        return math.copysign(ratio * mw / ei, m), abs(m) / mc >= KINK_MOMENT_FRACTION

    # ---- integration -------------------------------------------------------------
    def _integrate(self, m0: float, fx: float, fy: float, s_end: float, dense: bool = False):
        def rhs_factory(props):
            def rhs(s, z):
                x, y, th = z
                ei, ea, ga, mw, mc = props(s)
                m = m0 - (x * fy - y * fx)
                kappa, _ = self._curvature(m, ei, mw, mc)
                c, sn = math.cos(th), math.sin(th)
                n_t = fx * c + fy * sn
                n_n = -fx * sn + fy * c
                a = 1.0 + n_t / ea
                b = n_n / ga
                return (a * c - b * sn, a * sn + b * c, kappa)

            return rhs

        def wound(s, z):  # a trial shape that winds past MAX_TURN is not the equilibrium sought
            return MAX_TURN - abs(z[2])

        wound.terminal = True  # type: ignore[attr-defined]  # solve_ivp's event flag
        z = np.zeros(3)
        out_s, out_z = [np.array([self.s_base])], [z[:, None]]
        for a, b, props in self._pieces(s_end):
            sol = solve_ivp(
                rhs_factory(props),
                (a, b),
                z,
                method=self.method,
                rtol=self.rtol,
                atol=self.rtol * 1e-2 * self.length,
                events=None if dense else wound,
            )
            if not sol.success:
                raise RodSolveError(f"integration failed on [{a}, {b}]: {sol.message}")
            z = sol.y[:, -1]
            if sol.status == 1:  # stopped by the winding guard: report a far-off residual
                raise _WoundError()
            if dense:
                out_s.append(sol.t[1:])
                out_z.append(sol.y[:, 1:])
        m_end = m0 - (z[0] * fy - z[1] * fx)
        if dense:
            return z, m_end, np.concatenate(out_s), np.concatenate(out_z, axis=1)
        return z, m_end

    def _solution(self, m0: float, fx: float, fy: float, s_c: float) -> RodSolution:
        z, _, s, zz = self._integrate(m0, fx, fy, s_c, dense=True)
        x, y, th = zz
        m = m0 - (x * fy - y * fx)
        if s_c < self.s_tip - 1e-12:  # unloaded, straight remainder
            rest = self.s_tip - s_c
            s = np.append(s, self.s_tip)
            x = np.append(x, x[-1] + rest * math.cos(th[-1]))
            y = np.append(y, y[-1] + rest * math.sin(th[-1]))
            th = np.append(th, th[-1])
            m = np.append(m, 0.0)
        sec = self.section
        mw = np.asarray(sec.wrinkling_moment(s), dtype=float)
        frac = np.abs(m) / np.maximum(2 * mw, 1e-300) if self.wrinkling else np.zeros_like(m)
        return RodSolution(
            s=s,
            x=x,
            y=y,
            theta=th,
            moment=m,
            force=(fx, fy),
            max_moment_fraction=float(frac.max()),
            wrinkled=bool(self.wrinkling and np.any(np.abs(m) > mw)),
            kinked=bool(self.wrinkling and frac.max() >= KINK_MOMENT_FRACTION),
        )

    def linear_tip_compliance(self, n: int = 4001) -> float:
        """Small-deflection tip compliance (m/N) under a lateral tip force, shear included:
        ``int (s_tip - s)^2 / EI + 1 / GA ds`` (trapezoid on ``n`` points)."""
        s = np.linspace(self.s_base, self.s_tip, n)
        integrand = (self.s_tip - s) ** 2 / self.section.bending_stiffness(s)
        if self.shear:
            integrand = integrand + 1.0 / self.section.shear_stiffness(s)
        return float(np.trapezoid(integrand, s))

    # ---- public solves -----------------------------------------------------------
    def solve_force(self, fx: float, fy: float, s_c: float | None = None, m0_guess: float | None = None) -> RodSolution:
        """Equilibrium under a point force (N) at ``s_c`` (the tip by default)."""
        s_c = self.s_tip if s_c is None else float(s_c)
        if not (self.s_base < s_c <= self.s_tip):
            raise ValueError(f"s_c = {s_c!r} is out of range: allowed ({self.s_base}, {self.s_tip}]")
        lever = s_c - self.s_base
        guess = fy * lever if m0_guess is None else m0_guess
        if fx == 0 and fy == 0:
            return self._solution(0.0, 0.0, 0.0, s_c)
        m0 = self._shoot_m0(fx, fy, s_c, guess)
        if m0 is None:  # large load: continue from small load fractions
            m0 = 0.0
            for frac in np.linspace(0.1, 1.0, 10):
                m0 = self._shoot_m0(fx * frac, fy * frac, s_c, m0 if frac > 0.1 else fy * frac * lever)
                if m0 is None:
                    raise RodSolveError(
                        f"shooting for m(s_base) did not converge at {frac:.0%} of the load "
                        "(the moment probably exceeds a section's collapse moment)"
                    )
        return self._solution(m0, fx, fy, s_c)

    def _shoot_m0(self, fx: float, fy: float, s_c: float, guess: float) -> float | None:
        try:
            res = root_scalar(
                lambda m0: self._integrate(m0, fx, fy, s_c)[1],
                x0=guess,
                x1=guess * 1.01 + 1e-9,
                method="secant",
                xtol=1e-14 * max(abs(guess), 1e-6),
                rtol=1e-12,
                maxiter=50,
            )
        except (RodSolveError, OverflowError, ValueError):
            return None
        return res.root if res.converged else None

    def solve_lateral_displacement(self, displacement: float, fy_guess: float | None = None) -> RodSolution:
        """Equilibrium with the tip moved ``displacement`` (m) along y by a pure y force,
        tip free to rotate and to move along x (the paper's tensile test).

        Two-unknown shooting (``m(s_base)``, ``Fy``) by Powell's hybrid method from the
        linear-theory guess; where that fails (wrinkled or kinked sections make the
        problem strongly non-linear) the displacement is reached by continuation.
        """
        if displacement == 0:
            return self._solution(0.0, 0.0, 0.0, self.s_tip)
        c_lin = self.linear_tip_compliance()
        fy0 = fy_guess if fy_guess is not None else displacement / c_lin
        x = self._shoot_displacement(displacement, fy0 * self.length, fy0)
        if x is None:
            x = self._continuation(displacement, c_lin)
        return self._solution(x[0], 0.0, x[1], self.s_tip)

    def _continuation(self, displacement: float, c_lin: float, n_steps: int = 12) -> tuple[float, float]:
        """Reach ``displacement`` in small steps with a secant predictor (the kinked branch)."""
        history: list[tuple[float, float, float]] = [(0.0, 0.0, 0.0)]
        for d in np.linspace(displacement / n_steps, displacement, n_steps):
            if len(history) >= 2:
                (d1, m1, f1), (d2, m2, f2) = history[-2], history[-1]
                w = (d - d2) / (d2 - d1)
                guess = (m2 + w * (m2 - m1), f2 + w * (f2 - f1))
            else:
                guess = (d / c_lin * self.length, d / c_lin)
            x = self._shoot_displacement(d, *guess)
            if x is None:
                raise RodSolveError(
                    f"displacement-controlled shooting did not converge at {d * 1e3:.1f} mm "
                    "(a section probably collapsed)"
                )
            history.append((d, *x))
        return history[-1][1], history[-1][2]

    def _shoot_displacement(self, displacement: float, m0_guess: float, fy_guess: float) -> tuple[float, float] | None:
        m_scale = max(abs(m0_guess), 1e-12)
        f_scale = max(abs(fy_guess), 1e-12)
        d_scale = abs(displacement)

        def residual(v):
            m0, fy = v[0] * m_scale, v[1] * f_scale
            try:
                z, m_end = self._integrate(m0, 0.0, fy, self.s_tip)
            except RodSolveError:
                return [1e3, 1e3]  # far from any root: hybr backs off
            return [m_end / m_scale, (z[1] - displacement) / d_scale]

        res = root(
            residual, x0=[m0_guess / m_scale, fy_guess / f_scale], method="hybr", options={"xtol": 1e-10, "maxfev": 80}
        )
        # judge by the residual: near convergence hybr may report "no progress" because
        # the integrator's own noise (rtol) floors the residual
        if not max(abs(r) for r in res.fun) <= 1e-8:
            return None
        m0, fy = res.x[0] * m_scale, res.x[1] * f_scale
        # reject spurious branches: the force must pull the tip the way it moved, and the
        # rod may not wind through a half turn (a kinked hinge makes such roots cheap)
        z, _ = self._integrate(m0, 0.0, fy, self.s_tip)
        if fy * displacement <= 0 or abs(z[2]) > math.pi / 2:
            return None
        return m0, fy
