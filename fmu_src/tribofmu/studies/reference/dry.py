"""Dry friction (and no friction at all), solved piecewise exactly.

No friction: the free oscillator in closed form. Dry friction under a constant load without
heating: while slipping the force is the constant ``+-mu L`` and the block a harmonic
oscillator with a closed-form solution (:func:`advance_block`); while stuck
``x = x_s + X(t) - X(t_s)``. Stick -> slip (``|M V' + 2 K x|`` reaches ``mu L``) and
slip -> stick/reversal (``dv`` reaches 0) are located by brentq on these exact expressions,
to machine precision. Under a varying load or with heating, stick stays exact (T relaxes in
closed form as no power is dissipated) and slip is integrated by DOP853 at rtol 1e-12.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ...physics.block import BlockState, acceleration, advance_block
from .problem import EPS, MAX_EVENTS, MAX_STALLS, Problem, state_scale

__all__ = ["solve_free", "solve_dry", "solve_dry_varying", "first_fall"]


# -- no friction: the free oscillator ------------------------------------------------------------
def solve_free(p: Problem, t_eval: np.ndarray) -> dict:
    b = p.scenario.block
    state0 = BlockState(b.x0, b.v0)
    xv = np.array([[s.x, s.v] for s in (advance_block(state0, 0.0, 0.0, float(t), p.M, p.K)
                                        for t in t_eval)]).reshape(len(t_eval), 2)
    zeros = np.zeros_like(t_eval)
    return {"x": xv[:, 0], "v": xv[:, 1], "F": zeros, "f": zeros.copy(), "ok": True, "message": "",
            "stats": {"solver": "exact (free oscillator)", "n_rhs": 0, "event_times": []}}


# -- root location -------------------------------------------------------------------------------
def first_fall(g: Callable[[float], float], t0: float, t1: float, step: float,
                xtol: float) -> float | None:
    """First time in [t0, t1] [s] where g reaches 0 from above; None if g stays > 0.

    g must be smooth and g(t0) >= 0. A zero at t0 itself counts only if g falls right away
    (g may start at 0 and rise, e.g. dv at the start of a slip). ``step`` [s] is the sampling
    interval: a dip of g below 0 that starts and ends between two samples is caught by
    minimising g around every sampled local minimum.
    """
    root = lambda a, b: brentq(g, a, b, xtol=xtol, rtol=4 * EPS, maxiter=500)
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


def segment_stats(solver: str, segments: list, events: list[tuple[float, str]]) -> dict:
    """The dry solvers' stats: segments (t_start, t_end, kind, ...), events (t [s], kind)."""
    return {"solver": solver, "n_rhs": 0, "n_segments": len(segments), "event_times": events,
            "stick_intervals": [(seg[0], seg[1]) for seg in segments if seg[2] == "stick" and seg[1] > seg[0]],
            "n_stick": sum(1 for _, k in events if k == "stick"),
            "n_slip": sum(1 for _, k in events if k == "slip"),
            "n_reversal": sum(1 for _, k in events if k == "reversal")}


# -- dry friction: piecewise exact ----------------------------------------------------------------
def solve_dry(p: Problem, t_eval: np.ndarray, t_end: float) -> dict:
    law, M, K = p.law, p.M, p.K
    bound = abs(law.force(1.0, p.n))  # mu L [N]: slip force magnitude and static limit
    xtol = 4 * EPS * max(t_end, p.period)
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
        if len(segments) > MAX_EVENTS or stalls > MAX_STALLS:
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
            t_next = first_fall(lambda tt: bound - abs(p.stick_force(tt, stick_x(tt))),
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

            t_next = first_fall(rel_velocity, t_s, t_end, p.shortest_period() / 64, xtol)
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
    stats = segment_stats("exact piecewise (harmonic slip, rigid stick), brentq events", segments, events)
    return {"x": x_out, "v": v_out, "F": F_out, "f": np.zeros_like(t_eval), "ok": ok,
            "message": message, "stats": stats}


# -- dry friction under a varying load, or heating: exact stick, DOP853 slip ------------------
def solve_dry_varying(p: Problem, t_eval: np.ndarray, t_end: float) -> dict:
    """Dry friction with n = n(t) and/or the film temperature as a state.

    Stick: x = x_s + X(t) - X(t_s), v = V, T relaxes exactly toward T_ambient (no power);
    it ends where |F_stick| reaches mu L(t) (brentq on the exact margin). Slip: y = (x, v[, T])
    by DOP853 (rtol 1e-12) with F = s mu S (-n(t)), ending where dv reaches 0 (event), then
    stick or reversal as in :func:`solve_dry`. Integration also stops at load breakpoints.
    """
    law, M, K = p.law, p.M, p.K
    heated = p.thermal is not None
    bound = lambda tt: abs(law.force(1.0, p.n_at(tt)))  # mu L(t) [N]
    xtol = 4 * EPS * max(t_end, p.period)
    scale = state_scale(p)
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
        if len(segments) > MAX_EVENTS or stalls > MAX_STALLS:
            ok, message = False, (f"dry friction: gave up at t = {t:.6g} s after {len(segments)} "
                                  f"segments ({stalls} of zero length in a row): chattering")
            break
        if mode == "stick":
            X_s = p.drive(t)[0]
            t_s, x_s, T_s = t, x, T
            stick_x = lambda tt: x_s + p.drive(tt)[0] - X_s
            t_next = first_fall(lambda tt: bound(tt) - abs(p.stick_force(tt, stick_x(tt))),
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
    stats = segment_stats("exact stick, DOP853 slip (rtol 1e-12), brentq/event stick-slip", segments, events)
    return {"x": x_out, "v": v_out, "F": F_out, "f": np.zeros_like(t_eval), "ok": ok,
            "message": message, "stats": stats, "T": T_out if heated else None}
