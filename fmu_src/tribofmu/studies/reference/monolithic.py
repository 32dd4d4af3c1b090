"""Monolithic solvers at a user's accuracy: what a user would run instead of co-simulating, the
anchors the coupling algorithms are measured against at matched accuracy.

* :func:`solve_monolithic`: one scipy ``solve_ivp`` call (LSODA, Radau, BDF, ...) on the same
  equations the FMUs solve together, with no event handling: ``x' = v``,
  ``M v' = F(dv, n, f) - 2 K x`` (eq. 3), ``f' = `` eq. (21) (boundary friction) and
  ``C T' = q F dv - G (T - T_ambient)`` (with a Thermal FMU), n = n(t) with a Load FMU.
  Dry friction's ``sgn(dv)`` is not a function a smooth solver can integrate; it is
  regularised as ``mu L tanh(dv / eps)`` with ``eps = 100 rtol A omega``: the width tightens
  with the tolerance; the regularisation's own error is about 3.5 eps / (A omega) in nRMS(v)
  (measured on Fig. 2 with Radau at rtol 1e-9 for eps from 1e-5 to 1e-2 A omega), and a
  narrower width than ~100 rtol makes the solver's own error in dv (atol ~ rtol A omega) move
  the force across the whole of [-mu L, mu L] (LSODA then wanders off by O(1)).
  The fluid and boundary laws are integrated as they are.
* :func:`solve_event_driven`: the reference's piecewise exact dry solver (:mod:`.dry`) with its
  events located to ``event_tol`` times the drive period instead of machine precision.

Both return a :class:`~tribofmu.studies.reference.ReferenceResult`; its stats give the
solver, rtol, right-hand-side evaluations (``n_rhs``) and steps (``n_steps``).
"""
from __future__ import annotations

import math
import time as _time

import numpy as np
from scipy.integrate import solve_ivp

from ...errors import SolveOutOfTime as _OutOfTime
from ...physics.block import BlockState, acceleration
from ...scene.scenario import Scenario
from . import ReferenceResult
from .dry import solve_dry, solve_stick_slip
from .problem import Problem, state_scale

__all__ = ["solve_monolithic", "solve_event_driven", "REGULARISATION", "default_grid"]

REGULARISATION = "sgn(dv) -> tanh(dv/eps) (dry: mu L tanh(dv/eps)), eps = 100 rtol A omega"
WIDTH_PER_RTOL = 100.0  # eps / (rtol A omega)


def default_grid(scenario: Scenario, samples_per_period: int = 1000) -> np.ndarray:
    """Every T/samples_per_period over [0, stop_time] [s] (the reference's and simulate's grid)."""
    n_steps = int(math.floor(scenario.time.periods * samples_per_period + 1e-6))
    return np.arange(n_steps + 1) * (scenario.drive.period / samples_per_period)


def _checked_grid(scenario: Scenario, t_eval, name: str, tol: float) -> np.ndarray:
    """t_eval as an array (default :func:`default_grid`), after checking tol > 0."""
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {tol!r}")
    return default_grid(scenario) if t_eval is None else np.asarray(t_eval, dtype=float)


def _result(problem: Problem, t_eval, x, v, F, f, wall, stats, ok, message, T=None):
    X, V = problem.output_drive(t_eval)
    n = np.array([problem.n_at(float(ti)) for ti in t_eval]) if problem.program is not None \
        else np.full_like(t_eval, problem.n)
    T = T if T is not None else np.full_like(t_eval, problem.T)
    return ReferenceResult(time=t_eval, X=X, V=V, x=x, v=v, F=F, f=f, wall_time=wall, stats=stats, ok=ok,
                           message=message, T=T, n=n)


def solve_monolithic(scenario: Scenario, method: str = "LSODA", rtol: float = 1e-4,
                     t_eval: np.ndarray | None = None, width: float | None = None,
                     max_wall: float | None = None):
    """Solve ``scenario`` as one ODE system with scipy's ``method`` at ``rtol`` [1].

    atol is rtol times each state's scale (A, A omega, 1, T), as for the reference. width [m/s]:
    the dry law's regularisation width eps (default 100 rtol A omega). t_eval [s]: default every
    T/1000. wall_time covers the solve and the sampling onto t_eval. max_wall [s]: give up after
    this long (a solver crawling at dv = 0 of a law with an infinite slope there, e.g. LSODA
    on the boundary law at gamma = -0.95). A failure is returned with ok False. Raises
    ValueError on misuse (no Friction FMU, rtol not > 0).
    """
    if "Friction" not in scenario.fmus or "Drive" not in scenario.fmus:
        raise ValueError("a monolithic anchor needs a Drive and a Friction FMU in the scene")
    t_eval = _checked_grid(scenario, t_eval, "rtol", rtol)
    start = _time.perf_counter()
    p = Problem(scenario)
    law = p.law
    regularised, boundary, heated = law.sticks, law.has_state, p.thermal is not None
    eps = width if width is not None else WIDTH_PER_RTOL * rtol * abs(p.A) * p.omega
    if regularised and not eps > 0:
        raise ValueError(f"the regularisation width must be > 0, got {eps!r}")

    def force(t: float, dv: float, f: float) -> float:
        return law.regularised_force(dv, p.n_at(t), f, eps)

    calls = [0]

    def rhs(t, y):
        calls[0] += 1
        if max_wall is not None and calls[0] % 1000 == 0 and _time.perf_counter() - start > max_wall:
            raise _OutOfTime
        x, v = y[0], y[1]
        dv = p.drive(t)[1] - v
        f = y[2] if boundary else 0.0
        F = force(t, dv, f)
        out = [v, acceleration(BlockState(x, v), F, p.M, p.K)]
        if boundary:
            out.append(law.kinetics_rate(f, dv, p.n_at(t), y[-1] if heated else p.T)
                       if law.effects.melting else 0.0)
        if heated:
            out.append(p.heat_rate(y[-1], F * dv))
        return out

    b = scenario.block
    y0 = [b.x0, b.v0] + ([scenario.friction.f0] if boundary else []) + ([p.T] if heated else [])
    scale = state_scale(p)
    atol = rtol * np.array([scale[0], scale[1]] + ([scale[2]] if boundary else []) + ([scale[3]] if heated else []))
    t_end = max(scenario.stop_time, float(t_eval[-1]))
    try:
        sol = solve_ivp(rhs, (0.0, t_end), y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    except _OutOfTime:
        wall = _time.perf_counter() - start
        nan = np.full_like(t_eval, np.nan)
        stats = {"solver": f"{method} (monolithic)", "rtol": rtol, "n_rhs": calls[0], "event_times": []}
        return _result(p, t_eval, nan, nan, nan, nan, wall, stats, False,
                       f"{method} gave up after {wall:.0f} s ({calls[0]} right-hand sides)")
    y = np.full((len(y0), len(t_eval)), np.nan)  # NaN where the solver did not reach
    reached = np.asarray(sol.y, dtype=float)
    if reached.ndim == 2:
        y[:, :reached.shape[1]] = reached
    x, v = y[0], y[1]
    f = y[2] if boundary else np.zeros_like(t_eval)
    F = np.array([force(float(t), p.drive(float(t))[1] - vi, fi) if np.isfinite(vi) else np.nan
                  for t, vi, fi in zip(t_eval, v, f)])
    wall = _time.perf_counter() - start
    stats = {"solver": f"{method} (monolithic" + (f", {REGULARISATION}" if regularised else "") + ")", "rtol": rtol,
             "n_rhs": int(sol.nfev), "n_jac": int(sol.njev), "n_lu": int(sol.nlu),
             "n_steps": None, "width": eps if regularised else None, "event_times": []}
    return _result(p, t_eval, x, v, F, f, wall, stats, bool(sol.success), "" if sol.success else sol.message,
                   T=y[-1] if heated else None)


def solve_event_driven(scenario: Scenario, event_tol: float = 1e-6, t_eval: np.ndarray | None = None):
    """A law that sticks by the reference's piecewise solver with stick/slip events located to
    ``event_tol`` [1] times the drive period. Raises ValueError for a law that does not stick."""
    if "Friction" not in scenario.fmus or not scenario.friction.law().sticks:
        raise ValueError("the event-driven solve is for a law that sticks (dry, mixed friction)")
    t_eval = _checked_grid(scenario, t_eval, "event_tol", event_tol)
    start = _time.perf_counter()
    p = Problem(scenario)
    t_end = max(scenario.stop_time, float(t_eval[-1]))
    xtol = event_tol * p.period
    solver = solve_dry if p.law.constant_slip_force and p.program is None and p.thermal is None \
        else solve_stick_slip
    out = solver(p, t_eval, t_end, xtol=xtol)
    wall = _time.perf_counter() - start
    stats = dict(out.stats, event_tol=event_tol)
    return _result(p, t_eval, out.x, out.v, out.F, out.f, wall, stats, out.ok, out.message, T=out.T)
