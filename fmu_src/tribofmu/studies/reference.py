"""Monolithic reference solution of a scenario: pure scipy, no FMI.

The yardstick for every error figure of the project (co-simulation error = distance to this
solution) and what a user would write instead of co-simulating. Units are SI throughout:
t [s], X x [m], V v [m/s], F [N], f [1].

Each regime is solved so that the solver never steps across a point where the right-hand side
is not smooth:

* dry: piecewise exact. While slipping the force is the constant ``+-mu L`` and the block is
  a harmonic oscillator with a closed-form solution (:func:`advance_block`); while stuck
  ``x = x_s + X(t) - X(t_s)``. Stick -> slip (``|M V' + 2 K x|`` reaches ``mu L``) and
  slip -> stick/reversal (``dv`` reaches 0) are located by brentq on these exact
  expressions, to machine precision; ``rtol``/``atol`` are not used.
* fluid and boundary: ``solve_ivp`` between events, restarted at every event: ``dv = 0``
  (``|dv|^(gamma+1)`` has an infinite slope there for ``gamma < 0``), the kinks of ``mu_eff``
  (``f = mu/mub``, melting/solidification) and ``lam_eff`` (``f = lam/lamb``), and switches
  between two equivalent state forms (see :class:`_SmoothSystem`): ``(x, v[, f])`` while
  inertia dominates, ``(x, u[, f])`` with ``u = sgn(dv)|dv|^(gamma+1)`` while the viscous
  force nearly balances the rest. The second form is what makes ``gamma = -2/3`` converge:
  there ``dv`` creeps through 0 with an unbounded relaxation rate, which no explicit method
  and no Newton iteration on a cube root gets through, but BDF in ``u`` does.
  Fluid uses DOP853 in the v-form; boundary (``f`` relaxes at up to 1e7 1/s) uses BDF with a
  finite-difference Jacobian. The u-form always uses BDF.
  Fluid and boundary laws have no static friction (F(0) = 0), so ``dv = 0`` persists only
  where ``M V' + 2 K x`` vanishes identically; the u-form follows such a state as it is.

Beyond the paper, a scene may list a Load FMU (the normal stress is a function of time
n(t), :mod:`tribofmu.physics.load`) and a Thermal FMU (the film temperature T [K] is a state,
``C T' = q F (V - v) - G (T - T_ambient)``, :mod:`tribofmu.physics.thermal`), solved together
with the rest in one system (no exchange delay: the yardstick for the master's explicit T).
Integration restarts at the load program's breakpoints. Dry friction under a varying load or
with heating: stick is exact (x follows the drive, T relaxes in closed form as no power is
dissipated), slip is integrated by DOP853 (the slip force mu S (-n(t)) is no longer constant),
with the same brentq/event logic for stick and slip.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ..physics.block import BlockState, acceleration, advance_block
from ..physics.drive import drive
from ..physics.friction import BOUNDARY, DRY, FLUID, FrictionLaw
from ..physics.thermal import temperature_rate
from ..scene.scenario import Scenario

__all__ = ["ReferenceResult", "reference_solution", "nrms", "SAMPLES_PER_PERIOD"]

SAMPLES_PER_PERIOD = 1000  # default output grid: every T/1000
_EPS = float(np.finfo(float).eps)
_MAX_EVENTS = 100_000  # a scenario needing more is chattering, not physics
_MAX_STALLS = 20  # consecutive zero-length segments before giving up


@dataclass(frozen=True)
class ReferenceResult:
    """Reference trajectory on ``time``.

    time [s]; X [m], V [m/s] the upper block (zeros when the scenario has no Drive);
    x [m], v [m/s] the lower block; F [N] the friction force on the lower block; f [1] the
    lubricant's excess volume (0 for dry and fluid friction). wall_time [s] of the solve.
    stats: solver used, right-hand-side evaluations, events (``event_times`` as
    ``(t [s], kind)``), stick intervals (dry) and counts of melting/solidification (boundary).
    ok is False when the solver failed; message says why (the arrays then hold what was
    computed up to the failure, NaN after it).
    """

    time: np.ndarray
    X: np.ndarray
    V: np.ndarray
    x: np.ndarray
    v: np.ndarray
    F: np.ndarray
    f: np.ndarray
    wall_time: float
    stats: dict = field(default_factory=dict)
    ok: bool = True
    message: str = ""
    T: np.ndarray | None = None  # K, film temperature (constant conditions.T without Thermal)
    n: np.ndarray | None = None  # Pa, normal stress


def nrms(t: np.ndarray, v: np.ndarray, t_ref: np.ndarray, v_ref: np.ndarray,
         window: tuple[float, float]) -> float:
    """Normalised RMS distance of ``v(t)`` from ``v_ref(t_ref)`` on ``window`` = (t0, t1) [s].

    ``v`` is interpolated linearly onto the reference times inside the window; the RMS of
    the difference is divided by ``max |v_ref|`` there. Dimensionless. Raises ValueError
    when ``t`` does not cover the window, the window holds no reference point, or the
    reference is identically zero on it (nRMS undefined).
    """
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    t_ref, v_ref = np.asarray(t_ref, dtype=float), np.asarray(v_ref, dtype=float)
    if t.ndim != 1 or t.shape != v.shape or t_ref.ndim != 1 or t_ref.shape != v_ref.shape:
        raise ValueError("t, v and t_ref, v_ref must be 1-D arrays of equal length pairwise")
    t0, t1 = window
    if not t0 < t1:
        raise ValueError(f"window must be (start, end) with start < end, got {window}")
    if np.any(np.diff(t) < 0) or np.any(np.diff(t_ref) < 0):
        raise ValueError("t and t_ref must be non-decreasing")
    span = max(abs(t0), abs(t1), t1 - t0)
    slack = 1e-9 * span  # grids that end a rounding error short of the window still cover it
    if t.size == 0 or t[0] > t0 + slack or t[-1] < t1 - slack:
        raise ValueError(f"t spans [{t[0] if t.size else 'nan'}, {t[-1] if t.size else 'nan'}] s, "
                         f"which does not cover the window [{t0}, {t1}] s")
    inside = (t_ref >= t0 - slack) & (t_ref <= t1 + slack)
    if not np.any(inside):
        raise ValueError(f"no reference time lies in the window [{t0}, {t1}] s")
    scale = float(np.max(np.abs(v_ref[inside])))
    if scale == 0.0:
        raise ValueError("the reference is zero on the window: nRMS is undefined")
    diff = np.interp(t_ref[inside], t, v) - v_ref[inside]
    return float(np.sqrt(np.mean(diff * diff)) / scale)


# -- the problem, with the physics module's functions ----------------------------------------
class _Problem:
    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self.M, self.K = scenario.block.M, scenario.block.K
        self.A, self.omega = scenario.drive.A, scenario.drive.omega
        self.period = scenario.drive.period
        self.driven = "Drive" in scenario.fmus
        self.has_friction = "Friction" in scenario.fmus
        self.law: FrictionLaw = scenario.friction.law()
        self.n, self.T = scenario.conditions.n, scenario.conditions.T
        self.program = scenario.load_program.program_() if "Load" in scenario.fmus else None
        self.thermal = scenario.thermal.params() if "Thermal" in scenario.fmus else None
        # Block's own angular frequency [rad/s] (0 for a free mass).
        self.omega0 = math.sqrt(2.0 * self.K / self.M)

    def n_at(self, t: float) -> float:
        """Normal stress [Pa] at t [s]."""
        return self.n if self.program is None else self.program.n(t)

    def breakpoints(self, t0: float, t1: float) -> list[float]:
        """Times in (t0, t1) [s] where n(t) is not smooth."""
        return sorted(b for b in (self.program.breakpoints() if self.program else ()) if t0 < b < t1)

    def heat_rate(self, T: float, power: float) -> float:
        """dT/dt [K/s] of the film under friction power [W]."""
        return temperature_rate(T, power, self.thermal)

    def drive(self, t: float) -> tuple[float, float, float]:
        """X [m], V [m/s], V' [m/s^2] of the upper block (all 0 without a Drive)."""
        if not self.driven:
            return 0.0, 0.0, 0.0
        return drive(t, self.A, self.omega)

    def stick_force(self, t: float, x: float) -> float:
        """Friction force [N] that makes the lower block follow the upper one (v = V):
        eq. (3) solved for F with x'' = V'."""
        _, V, V_dot = self.drive(t)
        spring_acc = acceleration(BlockState(x, V), 0.0, self.M, self.K)
        return self.M * (V_dot - spring_acc)

    def shortest_period(self) -> float:
        """The shorter of the drive's and the block's periods [s]."""
        return min(self.period, 2.0 * math.pi / self.omega0) if self.omega0 > 0 else self.period

    def output_drive(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        XV = np.array([self.drive(float(ti))[:2] for ti in t]).reshape(len(t), 2)
        return XV[:, 0], XV[:, 1]


# -- public entry -------------------------------------------------------------------------------
def reference_solution(scenario: Scenario, t_eval: np.ndarray | None = None, rtol: float = 1e-10,
                       atol: float | np.ndarray | None = None) -> ReferenceResult:
    """Converged monolithic solution of ``scenario`` on ``t_eval`` [s].

    t_eval: non-decreasing times >= 0 [s]; default every T/1000 over [0, stop_time]
    (T the drive period). rtol [1]: relative tolerance of the ODE solver (fluid, boundary).
    atol: absolute tolerance, a scalar or one value per state (x [m], v [m/s][, f [1]]);
    default ``rtol`` times the state's scale (drive amplitude A, A*omega, 1).
    Dry friction is solved piecewise exactly with events at machine precision, so
    rtol/atol do not apply to it. Initial state x0, v0 (scenario.block), f0 (friction).
    Raises ValueError on misuse; a solver failure is returned with ``ok=False``.
    """
    if not isinstance(scenario, Scenario):
        raise TypeError(f"scenario must be a tribofmu.scenario.Scenario, got {type(scenario).__name__}")
    if not (isinstance(rtol, (int, float)) and math.isfinite(rtol) and rtol > 0):
        raise ValueError(f"rtol must be a finite number > 0, got {rtol!r}")
    period = scenario.drive.period
    if t_eval is None:
        n_steps = int(math.floor(scenario.time.periods * SAMPLES_PER_PERIOD + 1e-6))
        t_eval = np.arange(n_steps + 1) * (period / SAMPLES_PER_PERIOD)
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size == 0:
        raise ValueError(f"t_eval must be a non-empty 1-D array, got shape {t_eval.shape}")
    if not np.all(np.isfinite(t_eval)) or t_eval[0] < 0 or np.any(np.diff(t_eval) < 0):
        raise ValueError("t_eval must be finite, >= 0 and non-decreasing")

    problem = _Problem(scenario)
    regime = problem.law.regime
    n_state = 2 + (problem.has_friction and regime == BOUNDARY) + (problem.thermal is not None)
    if atol is not None:
        atol_arr = np.broadcast_to(np.asarray(atol, dtype=float), (n_state,)) if np.ndim(atol) == 0 \
            else np.asarray(atol, dtype=float)
        if atol_arr.shape != (n_state,) or not np.all(np.isfinite(atol_arr)) or np.any(atol_arr <= 0):
            raise ValueError(f"atol must be > 0, a scalar or {n_state} values (x, v[, f][, T]), got {atol!r}")
    t_end = max(scenario.stop_time, float(t_eval[-1]))

    start = _time.perf_counter()
    if not problem.has_friction:
        out = _solve_free(problem, t_eval)
    elif regime == DRY and problem.program is None and problem.thermal is None:
        out = _solve_dry(problem, t_eval, t_end)
    elif regime == DRY:
        out = _solve_dry_varying(problem, t_eval, t_end)
    elif regime in (FLUID, BOUNDARY):
        if atol is None:
            scale = _state_scale(problem)
            scale = np.concatenate([scale[:n_state - 1], scale[3:]]) if problem.thermal is not None \
                else scale[:n_state]
            atol_arr = rtol * scale
        out = _solve_ode(problem, t_eval, t_end, float(rtol), np.array(atol_arr, dtype=float))
    else:  # scenario validation rejects this; guard against a hand-built scenario
        raise ValueError(f"unknown friction regime {regime}")
    wall = _time.perf_counter() - start

    X, V = problem.output_drive(t_eval)
    T = out.get("T")
    if T is None:
        T = np.full_like(t_eval, problem.T)
    n = np.array([problem.n_at(float(ti)) for ti in t_eval]) if problem.program is not None \
        else np.full_like(t_eval, problem.n)
    return ReferenceResult(time=t_eval, X=X, V=V, x=out["x"], v=out["v"], F=out["F"], f=out["f"],
                           wall_time=wall, stats=out["stats"], ok=out["ok"], message=out["message"],
                           T=T, n=n)


def _state_scale(p: _Problem) -> np.ndarray:
    """Typical magnitudes of x [m], v [m/s], f [1], T [K] for absolute tolerances."""
    b = p.scenario.block
    x_scale = max(abs(p.A) if p.driven else 0.0, abs(b.x0),
                  abs(b.v0) / p.omega0 if p.omega0 > 0 else 0.0)
    v_scale = max(abs(p.A) * p.omega if p.driven else 0.0, abs(b.v0), abs(b.x0) * p.omega0)
    x_scale = x_scale or v_scale * p.period or 1.0
    v_scale = v_scale or x_scale / p.period
    T_scale = max(p.T, p.thermal.T_ambient if p.thermal else 0.0, 1.0)
    return np.array([x_scale, v_scale, 1.0, T_scale])


# -- no friction: the free oscillator ------------------------------------------------------------
def _solve_free(p: _Problem, t_eval: np.ndarray) -> dict:
    b = p.scenario.block
    state0 = BlockState(b.x0, b.v0)
    xv = np.array([[s.x, s.v] for s in (advance_block(state0, 0.0, 0.0, float(t), p.M, p.K)
                                        for t in t_eval)]).reshape(len(t_eval), 2)
    zeros = np.zeros_like(t_eval)
    return {"x": xv[:, 0], "v": xv[:, 1], "F": zeros, "f": zeros.copy(), "ok": True, "message": "",
            "stats": {"solver": "exact (free oscillator)", "n_rhs": 0, "event_times": []}}


# -- root location -------------------------------------------------------------------------------
def _first_fall(g: Callable[[float], float], t0: float, t1: float, step: float,
                xtol: float) -> float | None:
    """First time in [t0, t1] [s] where g reaches 0 from above; None if g stays > 0.

    g must be smooth and g(t0) >= 0. A zero at t0 itself counts only if g falls right away
    (g may start at 0 and rise, e.g. dv at the start of a slip). ``step`` [s] is the sampling
    interval: a dip of g below 0 that starts and ends between two samples is caught by
    minimising g around every sampled local minimum.
    """
    root = lambda a, b: brentq(g, a, b, xtol=xtol, rtol=4 * _EPS, maxiter=500)
    t_a, g_a = t0, g(t0)
    if g_a < 0:
        return t0
    t_prev, g_prev = None, None
    while t_a < t1:
        t_b = min(t_a + step, t1)
        g_b = g(t_b)
        if g_b <= 0:
            if g_a > 0:
                return root(t_a, t_b)
            # g starts at a zero: it must rise before it can fall through zero again.
            peak = minimize_scalar(lambda t: -g(t), bounds=(t_a, t_b), method="bounded",
                                   options={"xatol": 1e-3 * (t_b - t_a)})
            if -peak.fun > 0 and g(peak.x) > 0:
                return root(peak.x, t_b)
            return t_a
        if t_prev is not None and g_prev > g_a < g_b:
            dip = minimize_scalar(g, bounds=(t_prev, t_b), method="bounded",
                                  options={"xatol": _EPS ** 0.5 * (t_b - t_prev)})
            if dip.fun <= 0 and g_prev > 0:
                return root(t_prev, dip.x)
        t_prev, g_prev = t_a, g_a
        t_a, g_a = t_b, g_b
    return None


# -- dry friction: piecewise exact ----------------------------------------------------------------
def _solve_dry(p: _Problem, t_eval: np.ndarray, t_end: float) -> dict:
    law, M, K = p.law, p.M, p.K
    bound = abs(law.force(1.0, p.n))  # mu L [N]: slip force magnitude and static limit
    xtol = 4 * _EPS * max(t_end, p.period)
    b = p.scenario.block
    # segments: (t_start, t_end, kind, x_start, v_start, slip sign s)
    segments: list[tuple[float, float, str, float, float, int]] = []
    events: list[tuple[float, str]] = []
    ok, message = True, ""

    def slip_state(t: float, t_s: float, x_s: float, v_s: float, s: int) -> BlockState:
        return advance_block(BlockState(x_s, v_s), s * bound, 0.0, t - t_s, M, K)

    t, x, v = 0.0, b.x0, b.v0
    dv = p.drive(0.0)[1] - v
    if dv != 0.0:
        mode, s = "slip", (1 if dv > 0 else -1)
    else:
        mode, s = "stick", 0
    stalls = 0
    while t < t_end:
        if len(segments) > _MAX_EVENTS or stalls > _MAX_STALLS:
            ok, message = False, (f"dry friction: gave up at t = {t:.6g} s after {len(segments)} "
                                  f"segments ({stalls} of zero length in a row): chattering")
            break
        if mode == "stick":
            X_s = p.drive(t)[0]
            t_s, x_s = t, x

            def stick_x(tt: float) -> float:
                return x_s + p.drive(tt)[0] - X_s

            # Stuck until |F_stick| reaches mu L. The kink of |.| at F_stick = 0 is a maximum
            # of the margin, far from its zeros, so it does not disturb the root finding.
            t_next = _first_fall(lambda tt: bound - abs(p.stick_force(tt, stick_x(tt))),
                                 t_s, t_end, p.period / 64, xtol)
            segments.append((t_s, t_end if t_next is None else t_next, "stick", x_s, 0.0, 0))
            if t_next is None:
                break
            x, v = stick_x(t_next), p.drive(t_next)[1]
            F_stick = p.stick_force(t_next, x)
            s = 1 if F_stick > 0 else -1
            mode = "slip"
            events.append((t_next, "slip"))
        else:
            t_s, x_s, v_s, s_seg = t, x, v, s

            def rel_velocity(tt: float) -> float:
                return s_seg * (p.drive(tt)[1] - slip_state(tt, t_s, x_s, v_s, s_seg).v)

            t_next = _first_fall(rel_velocity, t_s, t_end, p.shortest_period() / 64, xtol)
            segments.append((t_s, t_end if t_next is None else t_next, "slip", x_s, v_s, s_seg))
            if t_next is None:
                break
            x = slip_state(t_next, t_s, x_s, v_s, s_seg).x
            v = p.drive(t_next)[1]  # dv = 0 here by construction; remove the roundoff
            F_stick = p.stick_force(t_next, x)
            if abs(F_stick) <= bound:
                mode = "stick"
                events.append((t_next, "stick"))
            else:
                # dv reached 0 with the blocks pushed apart harder than mu L: slip reverses.
                s = 1 if F_stick > 0 else -1
                events.append((t_next, "reversal"))
        stalls = stalls + 1 if segments[-1][1] - segments[-1][0] <= xtol else 0
        t = segments[-1][1]

    x_out = np.full_like(t_eval, np.nan)
    v_out, F_out = x_out.copy(), x_out.copy()
    starts = np.array([seg[0] for seg in segments])
    # A time on a segment boundary belongs to the later segment; states are continuous there.
    index = np.searchsorted(starts, t_eval, side="right") - 1
    covered_until = segments[-1][1] if ok else t
    for i, tt in enumerate(t_eval):
        if index[i] < 0 or tt > covered_until:
            continue
        t_s, _, kind, x_s, v_s, s_seg = segments[index[i]]
        if kind == "stick":
            X_s = p.drive(t_s)[0]
            x_out[i] = x_s + p.drive(tt)[0] - X_s
            v_out[i] = p.drive(tt)[1]
            F_out[i] = p.stick_force(tt, x_out[i])
        else:
            st = slip_state(tt, t_s, x_s, v_s, s_seg)
            x_out[i], v_out[i], F_out[i] = st.x, st.v, s_seg * bound
    stick_intervals = [(seg[0], seg[1]) for seg in segments if seg[2] == "stick" and seg[1] > seg[0]]
    stats = {"solver": "exact piecewise (harmonic slip, rigid stick), brentq events",
             "n_rhs": 0, "n_segments": len(segments), "event_times": events,
             "stick_intervals": stick_intervals,
             "n_stick": sum(1 for _, k in events if k == "stick"),
             "n_slip": sum(1 for _, k in events if k == "slip"),
             "n_reversal": sum(1 for _, k in events if k == "reversal")}
    return {"x": x_out, "v": v_out, "F": F_out, "f": np.zeros_like(t_eval), "ok": ok,
            "message": message, "stats": stats}


# -- dry friction under a varying load, or heating: exact stick, DOP853 slip ------------------
def _solve_dry_varying(p: _Problem, t_eval: np.ndarray, t_end: float) -> dict:
    """Dry friction with n = n(t) and/or the film temperature as a state.

    Stick: x = x_s + X(t) - X(t_s), v = V, T relaxes exactly toward T_ambient (no power);
    it ends where |F_stick| reaches mu L(t) (brentq on the exact margin). Slip: y = (x, v[, T])
    by DOP853 (rtol 1e-12) with F = s mu S (-n(t)), ending where dv reaches 0 (event), then
    stick or reversal as in :func:`_solve_dry`. Integration also stops at load breakpoints.
    """
    law, M, K = p.law, p.M, p.K
    heated = p.thermal is not None
    bound = lambda tt: abs(law.force(1.0, p.n_at(tt)))  # mu L(t) [N]
    xtol = 4 * _EPS * max(t_end, p.period)
    scale = _state_scale(p)
    atol = np.array([1e-12 * scale[0], 1e-12 * scale[1]] + ([1e-12 * scale[3]] if heated else []))
    b = p.scenario.block
    segments: list[tuple] = []  # (t0, t1, "stick", x_s, X_s, T_s) or (t0, t1, "slip", dense, s)
    events: list[tuple[float, str]] = []
    ok, message = True, ""

    def stick_T(tt: float, t_s: float, T_s: float) -> float:
        if not heated:
            return p.T
        th = p.thermal
        if th.G == 0.0:
            return T_s
        return th.T_ambient + (T_s - th.T_ambient) * math.exp(-th.G / th.C * (tt - t_s))

    t, x, v, T = 0.0, b.x0, b.v0, p.T
    dv = p.drive(0.0)[1] - v
    mode, s = ("slip", 1 if dv > 0 else -1) if dv != 0.0 else ("stick", 0)
    stalls = 0
    while t < t_end - xtol:
        if len(segments) > _MAX_EVENTS or stalls > _MAX_STALLS:
            ok, message = False, (f"dry friction: gave up at t = {t:.6g} s after {len(segments)} "
                                  f"segments ({stalls} of zero length in a row): chattering")
            break
        if mode == "stick":
            X_s = p.drive(t)[0]
            t_s, x_s, T_s = t, x, T
            stick_x = lambda tt: x_s + p.drive(tt)[0] - X_s
            t_next = _first_fall(lambda tt: bound(tt) - abs(p.stick_force(tt, stick_x(tt))),
                                 t_s, t_end, p.period / 64, xtol)
            segments.append((t_s, t_end if t_next is None else t_next, "stick", x_s, X_s, T_s))
            if t_next is None:
                break
            x, v, T = stick_x(t_next), p.drive(t_next)[1], stick_T(t_next, t_s, T_s)
            s = 1 if p.stick_force(t_next, x) > 0 else -1
            mode = "slip"
            events.append((t_next, "slip"))
        else:
            s_seg = s

            def rhs(tt, y):
                F = s_seg * bound(tt)
                acc = acceleration(BlockState(y[0], y[1]), F, M, K)
                if not heated:
                    return [y[1], acc]
                return [y[1], acc, p.heat_rate(y[2], F * (p.drive(tt)[1] - y[1]))]

            def dv_zero(tt, y):
                return p.drive(tt)[1] - y[1]
            dv_zero.terminal, dv_zero.direction = True, -s_seg
            t_stop = next(iter(p.breakpoints(t, t_end)), t_end)
            y0 = [x, v] + ([T] if heated else [])
            sol = solve_ivp(rhs, (t, t_stop), y0, method="DOP853", rtol=1e-12, atol=atol,
                            events=[dv_zero], dense_output=True)
            if sol.status == -1:
                ok, message = False, f"DOP853 failed at t = {sol.t[-1]:.6g} s: {sol.message}"
                break
            t_new = float(sol.t[-1])
            segments.append((t, t_new, "slip", sol.sol, s_seg))
            x, v = float(sol.y[0, -1]), float(sol.y[1, -1])
            T = float(sol.y[2, -1]) if heated else p.T
            if sol.status == 1:  # dv reached 0
                v = p.drive(t_new)[1]
                F_stick = p.stick_force(t_new, x)
                if abs(F_stick) <= bound(t_new):
                    mode = "stick"
                    events.append((t_new, "stick"))
                else:
                    s = 1 if F_stick > 0 else -1
                    events.append((t_new, "reversal"))
        stalls = stalls + 1 if segments[-1][1] - segments[-1][0] <= xtol else 0
        t = segments[-1][1]

    x_out = np.full_like(t_eval, np.nan)
    v_out, F_out, T_out = x_out.copy(), x_out.copy(), x_out.copy()
    starts = np.array([seg[0] for seg in segments])
    index = np.searchsorted(starts, t_eval, side="right") - 1
    covered_until = segments[-1][1] if segments else 0.0
    for i, tt in enumerate(t_eval):
        if index[i] < 0 or tt > covered_until + xtol:
            continue
        seg = segments[index[i]]
        if seg[2] == "stick":
            t_s, _, _, x_s, X_s, T_s = seg
            x_out[i] = x_s + p.drive(tt)[0] - X_s
            v_out[i] = p.drive(tt)[1]
            F_out[i] = p.stick_force(tt, x_out[i])
            T_out[i] = stick_T(tt, t_s, T_s)
        else:
            y = seg[3](min(tt, seg[1]))
            x_out[i], v_out[i] = y[0], y[1]
            F_out[i] = seg[4] * bound(tt)
            T_out[i] = y[2] if heated else p.T
    stick_intervals = [(seg[0], seg[1]) for seg in segments if seg[2] == "stick" and seg[1] > seg[0]]
    stats = {"solver": "exact stick, DOP853 slip (rtol 1e-12), brentq/event stick-slip",
             "n_rhs": 0, "n_segments": len(segments), "event_times": events,
             "stick_intervals": stick_intervals,
             "n_stick": sum(1 for _, k in events if k == "stick"),
             "n_slip": sum(1 for _, k in events if k == "slip"),
             "n_reversal": sum(1 for _, k in events if k == "reversal")}
    return {"x": x_out, "v": v_out, "F": F_out, "f": np.zeros_like(t_eval), "ok": ok,
            "message": message, "stats": stats, "T": T_out if heated else None}


# -- fluid and boundary friction: solve_ivp between events ---------------------------------------
# Mode switches on r = |M dv'| / |F_visc| (inertial over viscous force). q/r, q = gamma + 1, is the
# viscous relaxation rate times the time dv takes to change: r small = stiff, near-equilibrium
# motion. Hysteresis keeps a trajectory near a threshold from switching back and forth.
_R_TO_U_FORM = 0.5
_R_TO_V_FORM = 2.0


class _SmoothSystem:
    """Fluid or boundary friction as an ODE, in one of two equivalent state forms.

    v-form: y = (x [m], v [m/s][, f]). Used while inertia dominates the viscous force
    (r > 0.5) and for gamma >= 0. dv = 0 is an event: for gamma < 0 the force has an infinite
    slope there, and v has a |t - t0|^(gamma+2) kink that the integrator should not straddle.
    u-form: y = (x, u [(m/s)^(gamma+1)][, f]) with u = sgn(dv)|dv|^(gamma+1), so that the viscous
    force m u is linear in the state. Used for gamma < 0 while the viscous force nearly
    balances the rest (r < 2): there the motion hugs dv = F_rest/m-ish and crosses dv = 0
    smoothly, but the relaxation rate (gamma+1) m |dv|^gamma / M is unbounded, so an implicit
    solver is needed, and its Newton iteration converges in u but not on the cube root of v.
    """

    def __init__(self, p: _Problem, atol: np.ndarray):
        self.p = p
        law = p.law
        self.law = law
        self.boundary = law.regime == BOUNDARY
        self.heated = p.thermal is not None
        self.melting = self.boundary and law.effects.melting
        self.has_viscous = (law.regime == FLUID or law.effects.viscous) and law.m > 0
        self.q = law.gamma + 1.0
        self.u_form_available = self.has_viscous and law.gamma < 0
        lub = law.lubricant
        # f where mu_eff and lam_eff reach their floor of 0: kinks of the right-hand side.
        self.kinks = []
        if self.melting:
            if lub.mu_shear_bar > 0:
                self.kinks.append(("melt", "solidify", lub.mu_shear / lub.mu_shear_bar))
            if lub.lam_bar > 0:
                self.kinks.append(("melt_lambda", "solidify_lambda", lub.lam / lub.lam_bar))
        self.atol_v = atol
        scale = _state_scale(p)
        self.scale = np.concatenate([scale[:2 + self.boundary], scale[3:4] if self.heated else []])
        v_scale = self.scale[1]
        # Same relative accuracy in u as in v: u_scale = v_scale^q.
        self.atol_u = atol.copy()
        self.atol_u[1] = atol[1] / v_scale * v_scale ** self.q
        # Solvers tried on fig6/fig5: Radau is 1.5x slower than BDF in the v-form at equal
        # accuracy and diverges in the u-form; LSODA is faster at rtol = 1e-10 but took 40x
        # the steps at 1e-8 and hung on the pseudoplastic fluid in the v-form.
        self.v_method = "BDF" if self.boundary else "DOP853"
        self.u_method = "BDF"

    # -- conversions and forces --------------------------------------------------------------
    def dv_of_u(self, u: float) -> float:
        return math.copysign(abs(u) ** (1.0 / self.q), u)

    def u_of_dv(self, dv: float) -> float:
        return math.copysign(abs(dv) ** self.q, dv)

    def friction(self, t: float, dv: float, f: float) -> float:
        return self.law.force(float(dv), self.p.n_at(t), float(f))

    def viscous(self, dv: float) -> float:
        return self.law.viscous_force(float(dv)) if self.has_viscous else 0.0

    def inertial_and_viscous(self, t: float, x: float, dv: float, f: float) -> tuple[float, float]:
        """(M dv', F_visc) [N]: M dv' = F_stick - F, F_stick the force that would keep v = V."""
        return self.p.stick_force(t, x) - self.friction(t, dv, f), self.viscous(dv)

    def f_rate(self, t: float, f: float, dv: float, T: float) -> float:
        return self.law.kinetics_rate(float(f), float(dv), self.p.n_at(t), T) if self.melting else 0.0

    def temperature(self, y) -> float:
        """T [K] of a state (the scene's constant T without a Thermal FMU)."""
        return float(y[-1]) if self.heated else self.p.T

    def tail(self, t: float, f: float, dv: float, T: float, F: float) -> list[float]:
        """The derivatives of the state after (x, v|u): f' (boundary), T' (heated)."""
        out = [self.f_rate(t, f, dv, T)] if self.boundary else []
        if self.heated:
            out.append(self.p.heat_rate(T, F * dv))
        return out

    def unpack(self, t: float, y: np.ndarray, form: str) -> tuple[float, float, float, float]:
        """(x, v, dv, f) from a state in either form."""
        x = float(y[0])
        f = float(y[2]) if self.boundary else 0.0
        V = self.p.drive(t)[1]
        if form == "v":
            v = float(y[1])
            return x, v, V - v, f
        dv = self.dv_of_u(float(y[1]))
        return x, V - dv, dv, f

    def pack(self, x: float, v: float, dv: float, f: float, form: str, T: float | None = None) -> np.ndarray:
        second = v if form == "v" else self.u_of_dv(dv)
        return np.array([x, second] + ([f] if self.boundary else []) + ([T] if self.heated else []))

    # -- right-hand sides --------------------------------------------------------------------
    def rhs_v(self, t, y):
        x, v, dv, f = self.unpack(t, y, "v")
        F = self.friction(t, dv, f)
        acc = acceleration(BlockState(x, v), F, self.p.M, self.p.K)
        return [v, acc] + self.tail(t, f, dv, self.temperature(y), F)

    def _rhs_v_without_viscous(self, t, y):
        x, v, dv, f = self.unpack(t, y, "v")
        F_all = self.friction(t, dv, f)
        acc = acceleration(BlockState(x, v), F_all - self.viscous(dv), self.p.M, self.p.K)
        return np.array([v, acc] + self.tail(t, f, dv, self.temperature(y), F_all))

    def jac_v(self, t, y):
        """Jacobian of the v-form without the viscous term, by forward differences.

        The viscous slope is infinite at dv = 0 for gamma < 0, and there the v-form is only
        used where it is not the stiff part (r > 0.5), so leaving it out keeps Newton's
        iteration convergent (with it, BDF "converges" onto dv = 0 and stays there). The stiff
        kinetics of f and the elastic damping are in.
        """
        y = np.asarray(y, dtype=float)
        f0 = self._rhs_v_without_viscous(t, y)
        scale = self.scale[:len(y)]
        J = np.empty((len(y), len(y)))
        for j in range(len(y)):
            h = math.sqrt(_EPS) * max(abs(y[j]), scale[j])
            yj = y.copy()
            yj[j] += h
            J[:, j] = (self._rhs_v_without_viscous(t, yj) - f0) / (yj[j] - y[j])
        return J

    def rhs_u(self, t, y):
        x, v, dv, f = self.unpack(t, y, "u")
        F = self.friction(t, dv, f)
        acc = acceleration(BlockState(x, v), F, self.p.M, self.p.K)
        dv_dot = self.p.drive(t)[2] - acc
        # du/dt = q |dv|^(q-1) dv'; |dv|^(q-1) = |u|^((q-1)/q). The floor keeps a stage value
        # that lands on u = 0 finite (the step is then rejected, not poisoned by inf).
        u_abs = max(abs(float(y[1])), 1e-100)
        u_dot = self.q * u_abs ** ((self.q - 1.0) / self.q) * dv_dot
        return [v, u_dot] + self.tail(t, f, dv, self.temperature(y), F)

    # -- events ------------------------------------------------------------------------------
    def ratio_event(self, form: str, r: float):
        def event(t, y):
            x, _, dv, f = self.unpack(t, y, form)
            inertial, visc = self.inertial_and_viscous(t, x, dv, f)
            return inertial * inertial - (r * visc) ** 2
        return event

    def dv_sign_at_zero(self, t: float, x: float, f: float) -> int:
        """Side that dv leaves 0 to: the sign of M dv' = F_stick - F(0)."""
        inertial, _ = self.inertial_and_viscous(t, x, 0.0, f)
        if inertial == 0.0:  # dv' = 0 too: look a little ahead
            inertial, _ = self.inertial_and_viscous(t + 1e-9 * self.p.period, x, 0.0, f)
        return 1 if inertial >= 0 else -1

    def ratio_below(self, t: float, x: float, dv: float, f: float, r: float) -> bool:
        inertial, visc = self.inertial_and_viscous(t, x, dv, f)
        return abs(inertial) < r * abs(visc)


def _solve_ode(p: _Problem, t_eval: np.ndarray, t_end: float, rtol: float, atol: np.ndarray) -> dict:
    sys_ = _SmoothSystem(p, atol)
    b = p.scenario.block
    x, v, f = b.x0, b.v0, (p.scenario.friction.f0 if sys_.boundary else 0.0)
    t = 0.0
    dv = p.drive(0.0)[1] - v
    form = "u" if (sys_.u_form_available and dv != 0.0
                   and sys_.ratio_below(0.0, x, dv, f, _R_TO_U_FORM)) else "v"
    s = (1 if dv > 0 else -1) if dv != 0.0 else sys_.dv_sign_at_zero(0.0, x, f)
    T = p.T
    y = sys_.pack(x, v, dv, f, form, T)
    # For each kink: +1 while f is above it, -1 below (at it: the side f moves to).
    rate0 = sys_.f_rate(0.0, f, dv, T)
    sides = [(1 if f > k else -1) if f != k else (1 if rate0 > 0 else -1) for *_, k in sys_.kinks]

    segments = []  # (t_start, t_end, dense solution, form)
    events: list[tuple[float, str]] = []
    counters = {"n_rhs": 0, "n_jac": 0, "n_lu": 0, "n_steps": 0}
    time_in_form = {"v": 0.0, "u": 0.0}
    ok, message, stalls = True, "", 0
    while t < t_end:
        if len(segments) > _MAX_EVENTS or stalls > _MAX_STALLS:
            ok, message = False, (f"gave up at t = {t:.6g} s after {len(segments)} segments "
                                  f"({stalls} of zero length in a row): chattering at an event")
            break
        event_funcs, kinds = [], []
        if form == "v":
            def dv_zero(tt, yy):
                return p.drive(tt)[1] - yy[1]
            dv_zero.terminal, dv_zero.direction = True, -s
            event_funcs.append(dv_zero)
            kinds.append("dv_zero")
            if sys_.u_form_available:
                to_u = sys_.ratio_event("v", _R_TO_U_FORM)
                to_u.terminal, to_u.direction = True, -1
                event_funcs.append(to_u)
                kinds.append("to_u")
            rhs, method, tol_abs = sys_.rhs_v, sys_.v_method, sys_.atol_v
            options = {"jac": sys_.jac_v} if method in ("Radau", "BDF") else {}
        else:
            to_v = sys_.ratio_event("u", _R_TO_V_FORM)
            to_v.terminal, to_v.direction = True, 1
            u_zero = lambda tt, yy: yy[1]
            u_zero.terminal = False
            event_funcs += [to_v, u_zero]
            kinds += ["to_v", "u_zero"]
            rhs, method, tol_abs, options = sys_.rhs_u, sys_.u_method, sys_.atol_u, {}
        for j, ((*_, k), side) in enumerate(zip(sys_.kinks, sides)):
            kink = (lambda tt, yy, k=k: yy[2] - k)
            kink.terminal, kink.direction = True, -side
            event_funcs.append(kink)
            kinds.append(("kink", j))

        # the load program's kinks and jumps end a segment, like events
        t_stop = next(iter(p.breakpoints(t, t_end)), t_end)
        sol = solve_ivp(rhs, (t, t_stop), y, method=method, rtol=rtol, atol=tol_abs,
                        events=event_funcs, dense_output=True, **options)
        counters["n_rhs"] += sol.nfev
        counters["n_jac"] += sol.njev
        counters["n_lu"] += sol.nlu
        counters["n_steps"] += max(len(sol.t) - 1, 0)
        t_new = float(sol.t[-1])
        if t_new > t:
            segments.append((t, t_new, sol.sol, form))
            time_in_form[form] += t_new - t
        if sol.status == -1:
            ok, message = False, f"{method} failed at t = {t_new:.6g} s: {sol.message}"
            break
        stalls = stalls + 1 if t_new - t <= 4 * _EPS * max(t_end, p.period) else 0
        if form == "u":
            events += [(float(te), "dv_zero") for te in sol.t_events[kinds.index("u_zero")]]
        t = t_new
        if sol.status == 0 and t_stop >= t_end:
            break
        x, v, dv, f = sys_.unpack(t, sol.y[:, -1], form)
        T = sys_.temperature(sol.y[:, -1])
        if sol.status == 0:  # a load breakpoint: restart from the same state
            y = sys_.pack(x, v, dv, f, form, T)
            continue
        fired = [kinds[i] for i, te in enumerate(sol.t_events)
                 if kinds[i] != "u_zero" and te.size and te[-1] >= t - 1e-12 * t_end]
        for kind in fired:
            if kind == "dv_zero":
                v, dv = p.drive(t)[1], 0.0  # remove the event-location residue
                s = sys_.dv_sign_at_zero(t, x, f)
                events.append((t, "dv_zero"))
            elif kind == "to_u":
                form = "u"
            elif kind == "to_v":
                form = "v"
                s = (1 if dv > 0 else -1) if dv != 0.0 else sys_.dv_sign_at_zero(t, x, f)
            else:
                j = kind[1]
                f = sys_.kinks[j][2]
                sides[j] = -sides[j]
                events.append((t, sys_.kinks[j][0] if sides[j] > 0 else sys_.kinks[j][1]))
        y = sys_.pack(x, v, dv, f, form, T)

    x_out = np.full_like(t_eval, np.nan)
    v_out, F_out, f_out, T_out = x_out.copy(), x_out.copy(), x_out.copy(), x_out.copy()
    if segments:
        starts = np.array([seg[0] for seg in segments])
        index = np.searchsorted(starts, t_eval, side="right") - 1
        covered_until = segments[-1][1]
        for j, (_, _, dense, seg_form) in enumerate(segments):
            mask = (index == j) & (t_eval <= covered_until)
            if not np.any(mask):
                continue
            for i, yy in zip(np.flatnonzero(mask), dense(t_eval[mask]).T):
                xi, vi, dvi, fi = sys_.unpack(float(t_eval[i]), yy, seg_form)
                x_out[i], v_out[i], f_out[i] = xi, vi, fi
                T_out[i] = sys_.temperature(yy)
                F_out[i] = sys_.friction(float(t_eval[i]), dvi, fi)
    events.sort()
    stats = {"solver": (f"solve_ivp {sys_.v_method}" + (f" / {sys_.u_method} (u-form)"
                                                         if sys_.u_form_available else "")
                        + ", restarted at events"),
             "rtol": rtol, "atol": atol.tolist(), **counters, "n_segments": len(segments),
             "time_in_u_form": time_in_form["u"], "event_times": events,
             "n_dv_zero": sum(1 for _, k in events if k == "dv_zero"),
             "n_melt": sum(1 for _, k in events if k == "melt"),
             "n_solidify": sum(1 for _, k in events if k == "solidify")}
    return {"x": x_out, "v": v_out, "F": F_out, "f": f_out, "ok": ok, "message": message,
            "stats": stats, "T": T_out if sys_.heated else None}
