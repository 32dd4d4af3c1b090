"""Radau IIA (order 5) for implicit systems ``E(y) y' = G(t, y)`` with a diagonal, state-dependent
"mass" ``E`` that may vanish.

Why not scipy's Radau or BDF: they solve ``y' = f(t, y)``. The fluid law's u-form has
``f_u = (F_stick - m u) / eps(u)`` with ``eps(u) = M d|u|^(1/q)/du ~ |u|^((1-q)/q)``: near
``u = 0`` (dv crossing 0 in a quasi-stick phase) the relaxation rate ``m / eps`` reaches 1e13 1/s
at gamma = -0.9, and a Newton iteration on ``u - psi - h f(u)`` with a frozen Jacobian jumps
across the pole and fails ("required step size is less than spacing between numbers"). Written
as ``eps(u) u' = F_stick - m u`` the stage residual is smooth and monotone in ``u`` and tends
to the algebraic equation ``u = F_stick / m`` as ``eps -> 0``; Radau IIA is stiffly accurate,
so it is exact in that limit (an index-1 DAE) and in between.

The method follows Hairer & Wanner's RADAU5 (and scipy's port): 3-stage collocation, the
embedded error estimate filtered through ``(gamma0/h E - J)^-1``, the Gustafsson step-size
controller. Differences: the stage system is solved by Newton with ``E`` and ``dE/dy``
re-evaluated at every iterate (``J = dG/dy`` is frozen per step; ``G`` is nearly linear in
the states here, ``E`` is not), and the system is small (n <= 4), so the 3n x 3n Newton matrix
is factorised whole. Dense output is the collocation polynomial. Events are located by brentq
on it after each accepted step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from scipy.linalg import lu_factor, lu_solve
from scipy.optimize import brentq

__all__ = ["ImplicitResult", "solve_radau_mass"]

_S6 = math.sqrt(6.0)
_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
_A = np.array([[(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
               [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
               [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0]])
_A_INV = np.linalg.inv(_A)
_E_COEF = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0  # embedded estimate
_MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)  # 1 / gamma0
_VANDER_INV = np.linalg.inv(np.vander(_C, 4, increasing=True)[:, 1:])  # Z(tau) = sum Q_k tau^k
_NEWTON_MAXITER = 8
_MIN_FACTOR, _MAX_FACTOR = 0.2, 10.0
_EPS = float(np.finfo(float).eps)


class _Dense:
    """Piecewise collocation polynomials of the accepted steps: y(t) for t in [t_first, t_last]."""

    def __init__(self):
        self.t0: list[float] = []
        self.h: list[float] = []
        self.y0: list[np.ndarray] = []
        self.Q: list[np.ndarray] = []

    def add(self, t0: float, h: float, y0: np.ndarray, Q: np.ndarray) -> None:
        self.t0.append(t0)
        self.h.append(h)
        self.y0.append(y0)
        self.Q.append(Q)

    def one(self, j: int, t: float) -> np.ndarray:
        tau = (t - self.t0[j]) / self.h[j]
        return self.y0[j] + tau * (self.Q[j][0] + tau * (self.Q[j][1] + tau * self.Q[j][2]))

    def __call__(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        idx = np.clip(np.searchsorted(np.asarray(self.t0), t, side="right") - 1, 0, len(self.t0) - 1)
        return np.array([self.one(int(j), float(tt)) for j, tt in zip(idx, t)]).T


@dataclass
class ImplicitResult:
    """What :func:`scipy.integrate.solve_ivp` returns, as far as the reference solver uses it.

    status: 0 reached the end, 1 a terminal event, -1 failure (message says why).
    """

    t: np.ndarray
    y: np.ndarray
    sol: Callable
    t_events: list
    status: int
    message: str
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    extra: dict = field(default_factory=dict)


def solve_radau_mass(G: Callable, E: Callable, dE: Callable, jac: Callable, t_span: tuple[float, float],
                     y0: Sequence[float], rtol: float, atol: np.ndarray,
                     events: Sequence[Callable] = ()) -> ImplicitResult:
    """Integrate ``diag(E(y)) y' = G(t, y)`` over ``t_span``.

    G(t, y) -> array (n); E(y), dE(y) -> arrays (n): the diagonal of the mass and the derivative
    of each entry with respect to its own component (E_i depends on y_i only); jac(t, y) -> n x n
    dG/dy. rtol, atol: error control per component on ``atol + rtol |y|`` (RMS norm).
    events: functions g(t, y) with optional ``terminal`` and ``direction`` attributes as in
    solve_ivp; zeros are found on the dense output.
    """
    t0, t1 = map(float, t_span)
    y = np.array(y0, dtype=float)
    n = y.size
    atol = np.asarray(atol, dtype=float)
    counts = {"nfev": 0, "njev": 0, "nlu": 0}

    def fun(t, yy):
        counts["nfev"] += 1
        return np.asarray(G(t, yy), dtype=float)

    dense = _Dense()
    ts, ys = [t0], [y.copy()]
    t_events: list[list[float]] = [[] for _ in events]
    g_prev = [float(ev(t0, y)) for ev in events]
    t = t0
    span = t1 - t0
    h = min(1e-6 * max(span, 1e-300), span) if span > 0 else 0.0
    h_old = err_old = None
    Q_prev = None  # last step's polynomial, for the starting guess
    rejected = False
    status, message = 0, "reached the end of the interval"
    while t < t1:
        h = min(h, t1 - t)
        if h < 10 * _EPS * max(abs(t), 1.0):
            status, message = -1, f"step size {h:.3g} s fell below the spacing of numbers at t = {t:.9g} s"
            break
        Gn = fun(t, y)
        J = np.asarray(jac(t, y), dtype=float)
        counts["njev"] += 1
        En = np.asarray(E(y), dtype=float)
        scale = atol + rtol * np.abs(y)
        # Starting guess: the previous step's polynomial extrapolated (Z_i = y(t + c_i h) - y).
        if Q_prev is not None and h_old:
            tau = 1.0 + _C * h / h_old
            Z = np.array([tau_i * (Q_prev[0] + tau_i * (Q_prev[1] + tau_i * Q_prev[2])) for tau_i in tau])
            Z -= Z_end_prev
        else:
            Z = np.zeros((3, n))
        converged, n_iter, rate = False, 0, None
        dz_old = None
        newton_tol = max(10 * _EPS / rtol, min(0.03, rtol ** 0.5))
        for n_iter in range(1, _NEWTON_MAXITER + 1):
            Y = y + Z
            W = _A_INV @ Z / h
            EY = np.array([E(Y[i]) for i in range(3)])
            dEY = np.array([dE(Y[i]) for i in range(3)])
            R = np.concatenate([EY[i] * W[i] - fun(t + _C[i] * h, Y[i]) for i in range(3)])
            if not np.all(np.isfinite(R)):
                break
            N = np.zeros((3 * n, 3 * n))
            for i in range(3):
                for k in range(3):
                    N[i * n:(i + 1) * n, k * n:(k + 1) * n] = np.diag(EY[i] * _A_INV[i, k] / h)
                N[i * n:(i + 1) * n, i * n:(i + 1) * n] += np.diag(dEY[i] * W[i]) - J
            try:
                dZ = -np.linalg.solve(N, R).reshape(3, n)
            except np.linalg.LinAlgError:
                break
            counts["nlu"] += 1
            Z = Z + dZ
            dz = float(np.sqrt(np.mean((dZ / scale) ** 2)))
            if dz_old is not None:
                rate = dz / dz_old if dz_old > 0 else 0.0
                if rate >= 1.0:
                    break
            if dz == 0.0 or (rate is not None and rate / (1.0 - rate) * dz < newton_tol) \
                    or (rate is None and dz < 0.1 * newton_tol):
                converged = True
                break
            dz_old = dz
        if not converged:
            h *= 0.5
            rejected = True
            Q_prev = None
            continue
        y_new = y + Z[-1]
        # Embedded error estimate (Hairer's ESTRAD with a mass matrix).
        ZE = (Z.T @ _E_COEF) / h
        lu = lu_factor(_MU_REAL / h * np.diag(En) - J)
        counts["nlu"] += 1
        err = lu_solve(lu, Gn + En * ZE)
        scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
        err_norm = float(np.sqrt(np.mean((err / scale) ** 2)))
        if rejected and err_norm > 1.0:
            err = lu_solve(lu, fun(t, y + err) + En * ZE)
            err_norm = float(np.sqrt(np.mean((err / scale) ** 2)))
        safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
        if not np.isfinite(err_norm):
            h *= 0.5
            rejected = True
            Q_prev = None
            continue
        if err_norm > 1.0:
            h *= max(_MIN_FACTOR, safety * err_norm ** -0.25)
            rejected = True
            continue
        # Accepted.
        Q = (_VANDER_INV @ Z)  # rows: tau, tau^2, tau^3 coefficients
        dense.add(t, h, y.copy(), Q)
        t_new = t + h
        # Events on the new step.
        stop_at = None
        for j, ev in enumerate(events):
            g_new = float(ev(t_new, y_new))
            direction = getattr(ev, "direction", 0)
            if g_prev[j] * g_new < 0 or (g_new == 0.0 and g_prev[j] != 0.0):
                rising = g_new > g_prev[j]
                if direction == 0 or (direction > 0) == rising:
                    j_step = len(dense.t0) - 1
                    te = brentq(lambda tt: ev(tt, dense.one(j_step, tt)), t, t_new,
                                xtol=4 * _EPS * max(abs(t_new), 1.0), rtol=4 * _EPS) \
                        if g_new != 0.0 else t_new
                    t_events[j].append(te)
                    if getattr(ev, "terminal", False) and (stop_at is None or te < stop_at):
                        stop_at = te
            g_prev[j] = g_new
        if stop_at is not None:
            y_stop = dense.one(len(dense.t0) - 1, stop_at)
            t_events = [[te for te in tes if te <= stop_at] for tes in t_events]
            ts.append(stop_at)
            ys.append(y_stop)
            status, message = 1, "a termination event occurred"
            t = stop_at
            break
        # Step-size control (Gustafsson's predictive controller, as in RADAU5).
        if h_old is not None and err_old is not None and err_norm > 0:
            multiplier = h / h_old * (err_old / err_norm) ** 0.25
        else:
            multiplier = 1.0
        factor = min(_MAX_FACTOR, safety * min(1.0, multiplier) * (err_norm ** -0.25 if err_norm > 0 else 1e9))
        if rejected:
            factor = min(1.0, factor)
        h_old, err_old = h, max(err_norm, 1e-10)
        Q_prev, Z_end_prev = Q, Z[-1]
        t, y = t_new, y_new
        ts.append(t)
        ys.append(y.copy())
        h *= max(_MIN_FACTOR, factor)
        rejected = False
    if len(dense.t0) == 0:
        dense.add(t0, 1.0, np.array(y0, dtype=float), np.zeros((3, n)))
    return ImplicitResult(t=np.array(ts), y=np.array(ys).T, sol=dense,
                          t_events=[np.array(te) for te in t_events], status=status, message=message,
                          **counts)
