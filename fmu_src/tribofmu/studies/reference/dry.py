"""Laws that stick (dry, mixed friction; and no friction at all), solved piecewise.

No friction: the free oscillator in closed form. Dry friction under a constant load without
heating: while slipping the force is the constant ``+-mu L`` and the block a harmonic
oscillator with a closed-form solution (:func:`advance_block`); while stuck
``x = x_s + X(t) - X(t_s)``. Stick -> slip (``|M V' + 2 K x|`` reaches the law's static limit,
``mu L``) and slip -> stick/reversal (``dv`` reaches 0) are located by brentq on these exact
expressions, to machine precision. A slip force that varies (mixed friction's Stribeck
curve, a varying load) or heating (:func:`solve_stick_slip`): stick stays exact (T relaxes in
closed form as no power is dissipated), slip is integrated by DOP853 at rtol 1e-12 (a smooth
ODE: dv keeps its sign through a slip phase), the events as above.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ...physics.block import BlockState, acceleration, advance_block
from .problem import EPS, MAX_EVENTS, MAX_STALLS, Problem, state_scale
from .segments import Samples, Segment, Trajectory

__all__ = ["solve_free", "solve_dry", "solve_stick_slip", "first_fall", "Stick", "HarmonicSlip",
           "IntegratedSlip"]


# -- the pieces of a dry motion ----------------------------------------------------------------
@dataclass(frozen=True)
class Free:
    """No friction: the free oscillator from (x0 [m], v0 [m/s]) at t = 0."""

    p: Problem = field(repr=False)
    x0: float
    v0: float
    t_start: float = 0.0
    t_end: float = math.inf
    kind: str = "free"

    def sample(self, t: np.ndarray) -> Samples:
        xv = np.array([[s.x, s.v] for s in (advance_block(BlockState(self.x0, self.v0), 0.0, 0.0, float(tt),
                                                          self.p.M, self.p.K) for tt in t)]).reshape(len(t), 2)
        zeros = np.zeros_like(t)
        return {"x": xv[:, 0], "v": xv[:, 1], "F": zeros, "f": zeros.copy(), "T": np.full_like(t, self.p.T)}


@dataclass(frozen=True)
class Stick:
    """The blocks stuck together from t_start [s]: x = x_s + X(t) - X(t_start), v = V(t), F the
    stick force; the film temperature relaxes from T_s [K] toward ambient (no power)."""

    p: Problem = field(repr=False)
    t_start: float
    t_end: float
    x_s: float
    T_s: float
    kind: str = "stick"

    def x(self, t: float) -> float:
        return self.x_s + self.p.drive(t)[0] - self.p.drive(self.t_start)[0]

    def temperature(self, t: float) -> float:
        th = self.p.thermal
        if th is None:
            return self.p.T
        if th.G == 0.0:
            return self.T_s
        return th.T_ambient + (self.T_s - th.T_ambient) * math.exp(-th.G / th.C * (t - self.t_start))

    def sample(self, t: np.ndarray) -> Samples:
        X_s = self.p.drive(self.t_start)[0]
        x = np.array([self.x_s + self.p.drive(float(tt))[0] - X_s for tt in t])
        return {"x": x, "v": np.array([self.p.drive(float(tt))[1] for tt in t]),
                "F": np.array([self.p.stick_force(float(tt), xx) for tt, xx in zip(t, x)]),
                "f": np.zeros_like(t), "T": np.array([self.temperature(float(tt)) for tt in t])}


@dataclass(frozen=True)
class HarmonicSlip:
    """Slip at the constant force s mu L [N] from (x_s [m], v_s [m/s]) at t_start: the
    harmonic oscillator in closed form."""

    p: Problem = field(repr=False)
    t_start: float
    t_end: float
    x_s: float
    v_s: float
    s: int  # sign of dv while slipping
    bound: float  # mu L [N]
    kind: str = "slip"

    def state(self, t: float) -> BlockState:
        return advance_block(BlockState(self.x_s, self.v_s), self.s * self.bound, 0.0, t - self.t_start,
                             self.p.M, self.p.K)

    def sample(self, t: np.ndarray) -> Samples:
        xv = np.array([[st.x, st.v] for st in (self.state(float(tt)) for tt in t)]).reshape(len(t), 2)
        return {"x": xv[:, 0], "v": xv[:, 1], "F": np.full_like(t, self.s * self.bound), "f": np.zeros_like(t),
                "T": np.full_like(t, self.p.T)}


@dataclass(frozen=True)
class IntegratedSlip:
    """Slip on the law's branch s (F = s mu L(t) for dry friction) integrated by solve_ivp:
    ``dense`` gives (x, v[, T])."""

    p: Problem = field(repr=False)
    t_start: float
    t_end: float
    dense: Callable = field(repr=False)
    s: int
    kind: str = "slip"

    def sample(self, t: np.ndarray) -> Samples:
        y = np.asarray(self.dense(np.minimum(t, self.t_end))).reshape(-1, len(t))
        F = np.array([self.p.law.slip_force(self.p.drive(float(tt))[1] - vv, self.p.n_at(float(tt)), self.s)
                      for tt, vv in zip(t, y[1])])
        T = y[2] if self.p.thermal is not None else np.full_like(t, self.p.T)
        return {"x": y[0], "v": y[1], "F": F, "f": np.zeros_like(t), "T": T}


# -- no friction: the free oscillator ------------------------------------------------------------
def solve_free(p: Problem, t_eval: np.ndarray) -> Trajectory:
    b = p.scenario.block
    stats = {"solver": "exact (free oscillator)", "n_rhs": 0, "event_times": []}
    return Trajectory.from_segments([Free(p, b.x0, b.v0)], t_eval, math.inf, True, "", stats, heated=False)


# -- root location -------------------------------------------------------------------------------
def first_fall(g: Callable[[float], float], t0: float, t1: float, step: float,
               xtol: float, past: bool = False) -> float | None:
    """First time in [t0, t1] [s] where g reaches 0 from above; None if g stays > 0.

    g must be smooth and g(t0) >= 0. A zero at t0 itself counts only if g falls right away
    (g may start at 0 and rise, e.g. dv at the start of a slip). ``step`` [s] is the sampling
    interval: a dip of g below 0 that starts and ends between two samples is caught by
    minimising g around every sampled local minimum. past: return a time where g <= 0 (at most
    about xtol after the zero): with a loose xtol a root on the near side would start the next
    phase before its condition holds (a stick that has not reached the bound), which chatters.
    """
    def root(a: float, b: float) -> float:
        r = brentq(g, a, b, xtol=xtol, rtol=4 * EPS, maxiter=500)
        while past and r < b and g(r) > 0:
            r = min(r + xtol, b)
        return r
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
        if t_prev is None:
            # The first interval has no sample before it to show a dip: g may start falling
            # and come back up before t_b (a stick beginning near a drive reversal, where the
            # stick force swings out past the bound and back within one sample).
            dip = minimize_scalar(g, bounds=(t_a, t_b), method="bounded",
                                  options={"xatol": EPS ** 0.5 * (t_b - t_a)})
            if dip.fun < 0 and dip.x > t_a:
                if g_a > 0:
                    return root(t_a, dip.x)
                peak = minimize_scalar(lambda t: -g(t), bounds=(t_a, dip.x), method="bounded",
                                       options={"xatol": 1e-3 * (dip.x - t_a)})
                return root(peak.x, dip.x) if g(peak.x) > 0 else t_a
        elif g_prev > g_a < g_b:
            dip = minimize_scalar(g, bounds=(t_prev, t_b), method="bounded",
                                  options={"xatol": EPS ** 0.5 * (t_b - t_prev)})
            if dip.fun <= 0 and g_prev > 0:
                return root(t_prev, dip.x)
        t_prev, g_prev = t_a, g_a
        t_a, g_a = t_b, g_b
    return None


def segment_stats(solver: str, segments: list[Segment], events: list[tuple[float, str]]) -> dict:
    """The dry solvers' stats from their segments and events (t [s], kind)."""
    return {"solver": solver, "n_rhs": 0, "n_segments": len(segments), "event_times": events,
            "stick_intervals": [(seg.t_start, seg.t_end) for seg in segments
                                if seg.kind == "stick" and seg.t_end > seg.t_start],
            "n_stick": sum(1 for _, k in events if k == "stick"),
            "n_slip": sum(1 for _, k in events if k == "slip"),
            "n_reversal": sum(1 for _, k in events if k == "reversal")}


def _chattering(segments: list, stalls: int, t: float) -> str:
    return (f"dry friction: gave up at t = {t:.6g} s after {len(segments)} "
            f"segments ({stalls} of zero length in a row): chattering")


def _stick_end(p: Problem, stick: Stick, bound: Callable[[float], float], t_end: float,
               xtol: float, loose: bool) -> float | None:
    """When |F_stick| reaches mu L (None: stuck to t_end). The kink of |.| at F_stick = 0 is a
    maximum of the margin, far from its zeros, so it does not disturb the root finding."""
    return first_fall(lambda tt: bound(tt) - abs(p.stick_force(tt, stick.x(tt))),
                      stick.t_start, t_end, p.period / 64, xtol, past=loose)


def _at_dv_zero(p: Problem, t: float, x: float, bound: float, s: int,
                events: list[tuple[float, str]]) -> tuple[str, int]:
    """(mode, slip sign) after dv reached 0 at t [s] with the block at x [m]: stuck if the
    stick force is within mu L = bound [N], else the slip reverses (the blocks are pushed apart
    harder than mu L). Records the event."""
    F_stick = p.stick_force(t, x)
    if abs(F_stick) <= bound:
        events.append((t, "stick"))
        return "stick", s
    events.append((t, "reversal"))
    return "slip", 1 if F_stick > 0 else -1


# -- dry friction: piecewise exact ----------------------------------------------------------------
def solve_dry(p: Problem, t_eval: np.ndarray, t_end: float, xtol: float | None = None) -> Trajectory:
    """xtol [s]: how closely events are located (default: machine precision)."""
    bound = p.law.static_limit(p.n)  # mu L [N]: slip force magnitude and static limit
    loose = xtol is not None
    xtol = xtol if loose else 4 * EPS * max(t_end, p.period)
    b = p.scenario.block
    segments: list[Stick | HarmonicSlip] = []
    events: list[tuple[float, str]] = []
    ok, message = True, ""

    t, x, v = 0.0, b.x0, b.v0
    dv = p.drive(0.0)[1] - v
    mode, s = ("slip", 1 if dv > 0 else -1) if dv != 0.0 else ("stick", 0)
    stalls = 0
    while t < t_end:
        if len(segments) > MAX_EVENTS or stalls > MAX_STALLS:
            ok, message = False, _chattering(segments, stalls, t)
            break
        if mode == "stick":
            stick = Stick(p, t, t_end, x, p.T)
            t_next = _stick_end(p, stick, lambda _: bound, t_end, xtol, loose)
            segments.append(stick if t_next is None else replace(stick, t_end=t_next))
            if t_next is None:
                break
            x, v = stick.x(t_next), p.drive(t_next)[1]
            s = 1 if p.stick_force(t_next, x) > 0 else -1
            mode = "slip"
            events.append((t_next, "slip"))
        else:
            slip = HarmonicSlip(p, t, t_end, x, v, s, bound)

            def rel_velocity(tt: float) -> float:
                return slip.s * (p.drive(tt)[1] - slip.state(tt).v)

            t_next = first_fall(rel_velocity, t, t_end, p.shortest_period() / 64, xtol, past=loose)
            segments.append(slip if t_next is None else replace(slip, t_end=t_next))
            if t_next is None:
                break
            x = slip.state(t_next).x
            v = p.drive(t_next)[1]  # dv = 0 here by construction; remove the roundoff
            mode, s = _at_dv_zero(p, t_next, x, bound, s, events)
        stalls = stalls + 1 if segments[-1].t_end - segments[-1].t_start <= (0.0 if loose else xtol) else 0
        t = segments[-1].t_end

    stats = segment_stats("exact piecewise (harmonic slip, rigid stick), brentq events", segments, events)
    return Trajectory.from_segments(segments, t_eval, segments[-1].t_end if ok and segments else t, ok, message, stats,
                                    heated=False)


# -- a law that sticks, its slip force varying, or heating: exact stick, DOP853 slip ------------
def solve_stick_slip(p: Problem, t_eval: np.ndarray, t_end: float,
                     xtol: float | None = None) -> Trajectory:
    """A law that sticks (dry, mixed), with n = n(t) and/or the film temperature as a state.

    Stick: x = x_s + X(t) - X(t_s), v = V, T relaxes exactly toward T_ambient (no power);
    it ends where |F_stick| reaches the law's static limit (mu L(t) for dry friction; brentq
    on the exact margin). Slip: y = (x, v[, T]) by DOP853 (rtol 1e-12) with the law's slip
    force on the branch s, ending where dv reaches 0 (event), then stick or reversal as in
    :func:`solve_dry`. Integration also stops at load breakpoints.
    xtol [s]: how closely stick onsets are located (default: machine precision).
    """
    law, M, K = p.law, p.M, p.K
    heated = p.thermal is not None
    bound = lambda tt: law.static_limit(p.n_at(tt))  # mu L(t) [N] for dry friction
    loose = xtol is not None
    xtol = xtol if loose else 4 * EPS * max(t_end, p.period)
    scale = state_scale(p)
    atol = np.array([1e-12 * scale[0], 1e-12 * scale[1]] + ([1e-12 * scale[3]] if heated else []))
    b = p.scenario.block
    segments: list[Stick | IntegratedSlip] = []
    events: list[tuple[float, str]] = []
    ok, message = True, ""

    t, x, v, T = 0.0, b.x0, b.v0, p.T
    dv = p.drive(0.0)[1] - v
    mode, s = ("slip", 1 if dv > 0 else -1) if dv != 0.0 else ("stick", 0)
    stalls = 0
    while t < t_end - xtol:
        if len(segments) > MAX_EVENTS or stalls > MAX_STALLS:
            ok, message = False, _chattering(segments, stalls, t)
            break
        if mode == "stick":
            stick = Stick(p, t, t_end, x, T)
            t_next = _stick_end(p, stick, bound, t_end, xtol, loose)
            segments.append(stick if t_next is None else replace(stick, t_end=t_next))
            if t_next is None:
                break
            x, v, T = stick.x(t_next), p.drive(t_next)[1], stick.temperature(t_next)
            s = 1 if p.stick_force(t_next, x) > 0 else -1
            mode = "slip"
            events.append((t_next, "slip"))
        else:
            s_seg = s

            def rhs(tt, y):
                F = law.slip_force(p.drive(tt)[1] - y[1], p.n_at(tt), s_seg)
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
            segments.append(IntegratedSlip(p, t, t_new, sol.sol, s_seg))
            x, v = float(sol.y[0, -1]), float(sol.y[1, -1])
            T = float(sol.y[2, -1]) if heated else p.T
            if sol.status == 1:  # dv reached 0
                v = p.drive(t_new)[1]
                mode, s = _at_dv_zero(p, t_new, x, bound(t_new), s, events)
        stalls = stalls + 1 if segments[-1].t_end - segments[-1].t_start <= (0.0 if loose else xtol) else 0
        t = segments[-1].t_end

    stats = segment_stats("exact stick, DOP853 slip (rtol 1e-12), brentq/event stick-slip", segments, events)
    until = (segments[-1].t_end if segments else 0.0) + xtol
    return Trajectory.from_segments(segments, t_eval, until, ok, message, stats, heated)
