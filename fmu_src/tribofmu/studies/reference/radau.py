"""Radau IIA (order 5) for implicit systems ``diag(E(y)) y' = G(t, y)`` whose diagonal,
state-dependent "mass" ``E`` may vanish, as a :class:`scipy.integrate.OdeSolver`:

    solve_ivp(G, t_span, y0, method=RadauMass, mass=E, mass_slope=dE, jac=dG_dy,
              rtol=..., atol=..., events=..., dense_output=True)

so events, dense output and the result are solve_ivp's own.

Why not scipy's Radau or BDF: they solve ``y' = f(t, y)``. The fluid law's u-form has
``f_u = (F_stick - m u) / eps(u)`` with ``eps(u) = M d|u|^(1/q)/du ~ |u|^((1-q)/q)``: near
``u = 0`` (dv crossing 0 in a quasi-stick phase) the relaxation rate ``m / eps`` reaches 1e13 1/s
at gamma = -0.9, and a Newton iteration on ``u - psi - h f(u)`` with a frozen Jacobian jumps
across the pole and fails ("required step size is less than spacing between numbers"). Written
as ``eps(u) u' = F_stick - m u`` the stage residual is smooth and monotone in ``u`` and tends
to the algebraic equation ``u = F_stick / m`` as ``eps -> 0``; Radau IIA is stiffly accurate,
so it is exact in that limit (an index-1 DAE) and in between.

The method follows Hairer & Wanner's RADAU5 and scipy's ``Radau`` (same tableau, embedded
estimate filtered through ``(gamma0/h E - J)^-1``, Gustafsson's predictive step-size
controller, ``MIN_FACTOR``/``MAX_FACTOR``). Differences: ``fun`` is ``G``, not ``y'``; the stage
system is solved by Newton with ``E`` and ``dE/dy`` re-evaluated at every iterate (``J = dG/dy``
is evaluated once per step; ``G`` is nearly linear in the states here, ``E`` is not), and the
system is small (n <= 4), so the 3n x 3n Newton matrix is factorised whole instead of through
scipy's complex eigen-split. Dense output is the collocation polynomial.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.integrate import DenseOutput, OdeSolver
from scipy.linalg import lu_factor, lu_solve

__all__ = ["RadauMass"]

_S6 = math.sqrt(6.0)
C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])  # collocation nodes
_A = np.array([[(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
               [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
               [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0]])
A_INV = np.linalg.inv(_A)
E_COEF = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0  # embedded estimate
MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)  # 1 / gamma0
_VANDER_INV = np.linalg.inv(np.vander(C, 4, increasing=True)[:, 1:])  # Z(tau) = sum Q_k tau^k
NEWTON_MAXITER = 8
SAFETY = 0.9
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0  # step-size change limits per step
FIRST_STEP_FRACTION = 1e-6  # first step as a fraction of the span (the mass may vanish at y0)
_EPS = float(np.finfo(float).eps)


class CollocationDense(DenseOutput):
    """The collocation polynomial of one step: ``y(t) = y_old + sum_k Q_k tau^k``,
    ``tau = (t - t_old) / h``, k = 1..3."""

    def __init__(self, t_old: float, t: float, y_old: np.ndarray, Q: np.ndarray):
        super().__init__(t_old, t)
        self.h = t - t_old
        self.y_old = y_old
        self.Q = Q  # (3, n): the tau, tau^2, tau^3 coefficients

    def _call_impl(self, t):
        tau = (np.asarray(t, dtype=float) - self.t_old) / self.h
        Q = self.Q
        if tau.ndim == 0:
            return self.y_old + tau * (Q[0] + tau * (Q[1] + tau * Q[2]))
        tau = tau[None, :]
        return self.y_old[:, None] + tau * (Q[0][:, None] + tau * (Q[1][:, None] + tau * Q[2][:, None]))


class RadauMass(OdeSolver):
    """Radau IIA for ``diag(E(y)) y' = G(t, y)``; ``fun`` is G.

    mass(y), mass_slope(y) -> arrays (n): the diagonal E of the mass and dE_i/dy_i (E_i depends
    on y_i only). jac(t, y) -> (n, n) dG/dy. rtol, atol: error control per component on
    ``atol + rtol |y|`` (RMS norm). first_step [s]: default a millionth of the span.
    """

    def __init__(self, fun, t0, y0, t_bound, mass: Callable, mass_slope: Callable, jac: Callable,
                 rtol: float = 1e-3, atol=1e-6, first_step: float | None = None, vectorized=False,
                 **extraneous):
        if extraneous:
            raise TypeError(f"RadauMass got unexpected options {sorted(extraneous)}")
        super().__init__(fun, t0, y0, t_bound, vectorized)
        self.mass, self.mass_slope, self._jac = mass, mass_slope, jac
        self.rtol = float(rtol)
        self.atol = np.broadcast_to(np.asarray(atol, dtype=float), (self.n,)).copy()
        span = abs(t_bound - t0)
        self.h_abs = first_step if first_step is not None else (
            min(FIRST_STEP_FRACTION * max(span, 1e-300), span) if span > 0 else 0.0)
        self.newton_tol = max(10 * _EPS / self.rtol, min(0.03, self.rtol ** 0.5))
        self.h_old: float | None = None  # last accepted step [s] and its error norm
        self.err_old: float | None = None
        self.previous: CollocationDense | None = None  # its polynomial, for the starting guess
        self.t_old = None

    def jac(self, t, y) -> np.ndarray:
        self.njev += 1
        return np.asarray(self._jac(t, y), dtype=float)

    def _starting_guess(self, h: float) -> np.ndarray:
        """Z_i = y(t + c_i h) - y from the previous step's polynomial extrapolated, else 0."""
        prev = self.previous
        if prev is None or not self.h_old:
            return np.zeros((3, self.n))
        tau = 1.0 + C * h / self.h_old
        Q = prev.Q
        Z = np.array([tau_i * (Q[0] + tau_i * (Q[1] + tau_i * Q[2])) for tau_i in tau])
        return Z - (Q[0] + Q[1] + Q[2])

    def _newton(self, t: float, y: np.ndarray, h: float, J: np.ndarray, scale: np.ndarray):
        """Solve the stage equations E(Y_i) (A^-1 Z / h)_i = G(t + c_i h, Y_i); returns
        (converged, iterations, Z)."""
        n = self.n
        Z = self._starting_guess(h)
        dz_old = rate = None
        for n_iter in range(1, NEWTON_MAXITER + 1):
            Y = y + Z
            W = A_INV @ Z / h
            EY = np.array([self.mass(Y[i]) for i in range(3)])
            dEY = np.array([self.mass_slope(Y[i]) for i in range(3)])
            R = np.concatenate([EY[i] * W[i] - self.fun(t + C[i] * h, Y[i]) for i in range(3)])
            if not np.all(np.isfinite(R)):
                return False, n_iter, Z
            N = np.zeros((3 * n, 3 * n))
            for i in range(3):
                for k in range(3):
                    N[i * n:(i + 1) * n, k * n:(k + 1) * n] = np.diag(EY[i] * A_INV[i, k] / h)
                N[i * n:(i + 1) * n, i * n:(i + 1) * n] += np.diag(dEY[i] * W[i]) - J
            try:
                dZ = -np.linalg.solve(N, R).reshape(3, n)
            except np.linalg.LinAlgError:
                return False, n_iter, Z
            self.nlu += 1
            Z = Z + dZ
            dz = float(np.sqrt(np.mean((dZ / scale) ** 2)))
            if dz_old is not None:
                rate = dz / dz_old if dz_old > 0 else 0.0
                if rate >= 1.0:
                    return False, n_iter, Z
            if dz == 0.0 or (rate is not None and rate / (1.0 - rate) * dz < self.newton_tol) \
                    or (rate is None and dz < 0.1 * self.newton_tol):
                return True, n_iter, Z
            dz_old = dz
        return False, NEWTON_MAXITER, Z

    def _step_impl(self):
        t, y, rtol, atol = self.t, self.y, self.rtol, self.atol
        h = self.h_abs
        rejected = False
        while True:
            h = min(h, abs(self.t_bound - t))
            if h < 10 * _EPS * max(abs(t), 1.0):
                return False, f"step size {h:.3g} s fell below the spacing of numbers at t = {t:.9g} s"
            h_signed = h * self.direction
            Gn = self.fun(t, y)
            J = self.jac(t, y)
            En = np.asarray(self.mass(y), dtype=float)
            converged, n_iter, Z = self._newton(t, y, h_signed, J, atol + rtol * np.abs(y))
            if not converged:
                h *= 0.5
                rejected = True
                self.previous = None
                continue
            y_new = y + Z[-1]
            # Embedded error estimate (Hairer's ESTRAD with a mass matrix).
            ZE = (Z.T @ E_COEF) / h_signed
            lu = lu_factor(MU_REAL / h_signed * np.diag(En) - J)
            self.nlu += 1
            err = lu_solve(lu, Gn + En * ZE)
            scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
            err_norm = float(np.sqrt(np.mean((err / scale) ** 2)))
            if rejected and err_norm > 1.0:
                err = lu_solve(lu, self.fun(t, y + err) + En * ZE)
                err_norm = float(np.sqrt(np.mean((err / scale) ** 2)))
            safety = SAFETY * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
            if not np.isfinite(err_norm):
                h *= 0.5
                rejected = True
                self.previous = None
                continue
            if err_norm > 1.0:
                h *= max(MIN_FACTOR, safety * err_norm ** -0.25)
                rejected = True
                continue
            break
        # Accepted: Gustafsson's predictive controller, as in RADAU5.
        if self.h_old is not None and self.err_old is not None and err_norm > 0:
            multiplier = h / self.h_old * (self.err_old / err_norm) ** 0.25
        else:
            multiplier = 1.0
        factor = min(MAX_FACTOR, safety * min(1.0, multiplier) * (err_norm ** -0.25 if err_norm > 0 else 1e9))
        if rejected:
            factor = min(1.0, factor)
        self.h_old, self.err_old = h, max(err_norm, 1e-10)
        self.t_old, self.y_old = t, y
        # The last step lands on t_bound exactly (t + (t_bound - t) may miss it by an ulp).
        self.t = self.t_bound if h == abs(self.t_bound - t) else t + h_signed
        self.y = y_new
        self.previous = CollocationDense(t, self.t, y.copy(), _VANDER_INV @ Z)
        self.h_abs = h * max(MIN_FACTOR, factor)
        return True, None

    def _dense_output_impl(self):
        return self.previous
