"""Fluid and boundary friction: integration between events, restarted at every event.

Events: ``dv = 0`` (``|dv|^(gamma+1)`` has an infinite slope there for ``gamma < 0``), the kinks
of ``mu_eff`` (``f = mu/mub``, melting/solidification) and ``lam_eff`` (``f = lam/lamb``), the
load program's breakpoints, and switches between two equivalent state forms (see
:class:`SmoothSystem`): ``(x, v[, f])`` while inertia dominates, ``(x, u[, f])`` with
``u = sgn(dv)|dv|^(gamma+1)`` while the viscous force nearly balances the rest.

In the u-form ``dv`` creeps through 0 with an unbounded relaxation rate
``(gamma+1) m |dv|^gamma / M`` (1e13 1/s at gamma = -0.9 next to dv = 0), which no explicit
method and no Newton iteration on ``|u|^(1/q)`` gets through. The fluid law's u-form is written
``eps(u) u' = F_stick - m u`` (``eps = M d(dv)/du``, which vanishes at u = 0) and solved by the
mass-form Radau IIA of :mod:`.radau`; boundary friction keeps scipy's BDF on ``u' = ...`` there.
The v-form uses DOP853 (fluid) or BDF with a finite-difference Jacobian (boundary: ``f``
relaxes at up to 1e7 1/s). Fluid and boundary laws have no static friction (F(0) = 0), so
``dv = 0`` persists only where ``M V' + 2 K x`` vanishes identically; the u-form follows such a
state as it is.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ...physics.block import BlockState, acceleration
from .problem import EPS, MAX_EVENTS, MAX_STALLS, Problem, state_scale
from .radau import RadauMass
from .segments import Samples, Trajectory

__all__ = ["SmoothSystem", "SmoothSegment", "solve_smooth"]


# -- fluid and boundary friction: solve_ivp between events ---------------------------------------
# Mode switches on r = |M dv'| / |F_visc| (inertial over viscous force). q/r, q = gamma + 1, is the
# viscous relaxation rate times the time dv takes to change: r small = stiff, near-equilibrium
# motion. Hysteresis keeps a trajectory near a threshold from switching back and forth.
_R_TO_U_FORM = 0.5
_R_TO_V_FORM = 2.0
# Leaving dv = 0 starts in the u-form when the viscous balance is reached within this fraction
# of the shortest period (see SmoothSystem.settles_at_once).
_SETTLE_AT_ONCE = 1e-9


def forward_jacobian(g: Callable, y, scale) -> np.ndarray:
    """dg/dy by forward differences, column j stepped by sqrt(eps) max(|y_j|, scale_j)."""
    y = np.asarray(y, dtype=float)
    g0 = np.asarray(g(y), dtype=float)
    J = np.empty((len(g0), len(y)))
    for j in range(len(y)):
        yj = y.copy()
        yj[j] += math.sqrt(EPS) * max(abs(y[j]), scale[j])
        J[:, j] = (np.asarray(g(yj), dtype=float) - g0) / (yj[j] - y[j])
    return J


class SmoothSystem:
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

    def __init__(self, p: Problem, atol: np.ndarray):
        self.p = p
        law = p.law
        self.law = law
        self.boundary = law.has_state
        self.heated = p.thermal is not None
        self.melting = self.boundary and law.effects.melting
        self.has_viscous = law.has_power_law_term and law.m > 0
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
        scale = state_scale(p)
        self.scale = np.concatenate([scale[:2 + self.boundary], scale[3:4] if self.heated else []])
        v_scale = self.scale[1]
        # Same relative accuracy in u as in v: u_scale = v_scale^q.
        self.atol_u = atol.copy()
        self.atol_u[1] = atol[1] / v_scale * v_scale ** self.q
        # Solvers tried on fig6/fig5: Radau is 1.5x slower than BDF in the v-form at equal
        # accuracy and diverges in the u-form; LSODA is faster at rtol = 1e-10 but took 40x
        # the steps at 1e-8 and hung on the pseudoplastic fluid in the v-form.
        self.v_method = "BDF" if self.boundary else "DOP853"
        # The u-form as diag(E) y' = G (see radau.py): BDF on u' = G_u / eps(u) fails near
        # u = 0 for gamma <= -0.8. Boundary friction keeps BDF (its f kinetics are not yet
        # measured with the mass form).
        self.u_method = "BDF" if self.boundary else "Radau-mass"
        self.u_scale = v_scale ** self.q

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
        return forward_jacobian(lambda yy: self._rhs_v_without_viscous(t, yy), y, self.scale[:len(y)])

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

    # -- the u-form as an implicit system diag(E(y)) y' = G(t, y) --------------------------------
    def mass_exponent(self) -> float:
        return (1.0 - self.q) / self.q

    def mass(self, y) -> np.ndarray:
        """Diagonal of E: 1 for x, f, T; eps(u) = M d(dv)/du = (M/q)|u|^((1-q)/q) [kg (m/s)^-q] for u."""
        E = np.ones(len(y))
        E[1] = self.p.M / self.q * abs(float(y[1])) ** self.mass_exponent()
        return E

    def mass_slope(self, y) -> np.ndarray:
        """d E_i / d y_i (0 but for u)."""
        dE = np.zeros(len(y))
        p = self.mass_exponent()
        u = float(y[1])
        # The floor keeps p < 1 (gamma > -1/2) finite at u = 0; there the slope is infinite.
        dE[1] = self.p.M / self.q * p * max(abs(u), 1e-300) ** (p - 1.0) * math.copysign(1.0, u)
        return dE

    def rhs_u_mass(self, t, y) -> np.ndarray:
        """G: (v, M dv' = F_stick - F [N][, f'][, T'])."""
        x, v, dv, f = self.unpack(t, y, "u")
        F = self.friction(t, dv, f)
        return np.array([v, self.p.stick_force(t, x) - F] + self.tail(t, f, dv, self.temperature(y), F))

    def jac_u_mass(self, t, y) -> np.ndarray:
        """dG/dy by forward differences (G is linear in x and, for the fluid law, in u)."""
        scale = self.scale[:len(y)].copy()
        scale[1] = self.u_scale
        return forward_jacobian(lambda yy: self.rhs_u_mass(t, yy), y, scale)

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

    def settles_at_once(self, t: float, x: float, f: float) -> bool:
        """Whether dv, leaving 0 at t [s], reaches the viscous balance too fast for the v-form.

        From dv = 0 the viscous force m|dv|^q balances the driving force F_d = M dv' once
        |dv| ~ (|F_d|/m)^(1/q), after about t* = M (|F_d|/m)^(1/q) / |F_d|. Near gamma = -1 this
        is far below any step size (1e-26 s at gamma = -0.95 from rest on fig5): the v-form
        overshoots dv = 0 within its first step, again and again. The mass-form u-form starts
        at the balance (:meth:`balanced_u`), which is exact to O(t*).
        """
        if not (self.u_form_available and self.u_method == "Radau-mass"):
            return False
        driving, _ = self.inertial_and_viscous(t, x, 0.0, f)
        if driving == 0.0:
            return False
        dv_star = (abs(driving) / self.law.m) ** (1.0 / self.q)
        return self.p.M * dv_star / abs(driving) < _SETTLE_AT_ONCE * self.p.shortest_period()

    def balanced_u(self, t: float, x: float, f: float) -> float:
        """u where the friction force equals the driving force, F(dv(u)) = F_stick (dv' = 0)."""
        driving, _ = self.inertial_and_viscous(t, x, 0.0, f)
        stick = self.p.stick_force(t, x)
        u_far = 2.0 * driving / self.law.m  # F - F(0) >= m u_far = 2 driving there
        return brentq(lambda u: stick - self.friction(t, self.dv_of_u(u), f), 0.0, u_far,
                      xtol=1e-300, rtol=4 * EPS)

    def ratio_below(self, t: float, x: float, dv: float, f: float, r: float) -> bool:
        inertial, visc = self.inertial_and_viscous(t, x, dv, f)
        return abs(inertial) < r * abs(visc)


def solve_smooth(p: Problem, t_eval: np.ndarray, t_end: float, rtol: float,
                 atol: np.ndarray) -> Trajectory:
    sys_ = SmoothSystem(p, atol)
    b = p.scenario.block
    x, v, f = b.x0, b.v0, (p.scenario.friction.f0 if sys_.boundary else 0.0)
    t = 0.0
    dv = p.drive(0.0)[1] - v
    form = "u" if (sys_.u_form_available and dv != 0.0
                   and sys_.ratio_below(0.0, x, dv, f, _R_TO_U_FORM)) else "v"
    s = (1 if dv > 0 else -1) if dv != 0.0 else sys_.dv_sign_at_zero(0.0, x, f)
    T = p.T
    if dv == 0.0 and sys_.settles_at_once(0.0, x, f):
        form = "u"
        y = sys_.pack(x, v, dv, f, form, T)
        y[1] = sys_.balanced_u(0.0, x, f)
    else:
        y = sys_.pack(x, v, dv, f, form, T)
    # For each kink: +1 while f is above it, -1 below (at it: the side f moves to).
    rate0 = sys_.f_rate(0.0, f, dv, T)
    sides = [(1 if f > k else -1) if f != k else (1 if rate0 > 0 else -1) for *_, k in sys_.kinks]

    segments: list[SmoothSegment] = []
    events: list[tuple[float, str]] = []
    counters = {"n_rhs": 0, "n_jac": 0, "n_lu": 0, "n_steps": 0}
    time_in_form = {"v": 0.0, "u": 0.0}
    ok, message, stalls = True, "", 0
    while t < t_end:
        if len(segments) > MAX_EVENTS or stalls > MAX_STALLS:
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
        name = method
        if method == "Radau-mass":
            rhs, method, options = sys_.rhs_u_mass, RadauMass, {
                "mass": sys_.mass, "mass_slope": sys_.mass_slope, "jac": sys_.jac_u_mass}
        sol = solve_ivp(rhs, (t, t_stop), y, method=method, rtol=rtol, atol=tol_abs,
                        events=event_funcs, dense_output=True, **options)
        counters["n_rhs"] += sol.nfev
        counters["n_jac"] += sol.njev
        counters["n_lu"] += sol.nlu
        counters["n_steps"] += max(len(sol.t) - 1, 0)
        t_new = float(sol.t[-1])
        if t_new > t:
            segments.append(SmoothSegment(sys_, t, t_new, sol.sol, form))
            time_in_form[form] += t_new - t
        if sol.status == -1:
            ok, message = False, f"{name} failed at t = {t_new:.6g} s: {sol.message}"
            break
        stalls = stalls + 1 if t_new - t <= 4 * EPS * max(t_end, p.period) else 0
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
        u_start = None
        fired = [kinds[i] for i, te in enumerate(sol.t_events)
                 if kinds[i] != "u_zero" and te.size and te[-1] >= t - 1e-12 * t_end]
        for kind in fired:
            if kind == "dv_zero":
                v, dv = p.drive(t)[1], 0.0  # remove the event-location residue
                s = sys_.dv_sign_at_zero(t, x, f)
                events.append((t, "dv_zero"))
                if sys_.settles_at_once(t, x, f):
                    form = "u"
                    u_start = sys_.balanced_u(t, x, f)
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
        if u_start is not None and form == "u":
            y[1] = u_start

    events.sort()
    stats = {"solver": (f"{sys_.v_method}" + (f" / {sys_.u_method} (u-form)"
                                                         if sys_.u_form_available else "")
                        + ", restarted at events"),
             "rtol": rtol, "atol": atol.tolist(), **counters, "n_segments": len(segments),
             "time_in_u_form": time_in_form["u"], "event_times": events,
             "n_dv_zero": sum(1 for _, k in events if k == "dv_zero"),
             "n_melt": sum(1 for _, k in events if k == "melt"),
             "n_solidify": sum(1 for _, k in events if k == "solidify")}
    until = segments[-1].t_end if segments else -math.inf
    return Trajectory.from_segments(segments, t_eval, until, ok, message, stats, sys_.heated)


@dataclass(frozen=True)
class SmoothSegment:
    """Fluid or boundary motion between two events: solve_ivp's dense output of the state in
    one form ("v" or "u", see :class:`SmoothSystem`)."""

    system: SmoothSystem = field(repr=False)
    t_start: float
    t_end: float
    dense: Callable = field(repr=False)
    form: str
    kind: str = "smooth"

    def sample(self, t: np.ndarray) -> Samples:
        sys_ = self.system
        out = {name: np.empty_like(t) for name in ("x", "v", "F", "f", "T")}
        for i, yy in enumerate(np.asarray(self.dense(t)).reshape(-1, len(t)).T):
            ti = float(t[i])
            x, v, dv, f = sys_.unpack(ti, yy, self.form)
            out["x"][i], out["v"][i], out["f"][i] = x, v, f
            out["T"][i] = sys_.temperature(yy)
            out["F"][i] = sys_.friction(ti, dv, f)
        return out
