"""Coupling algorithms: small classes behind one interface, chosen by name from a registry.

An algorithm advances the coupled system from one communication point and returns the new
points (one per accepted communication step; none if it rejected and rolled back).

- ``jacobi``: fixed step; every slave steps with the others' outputs from the start of the
  step (the explicit baseline every co-simulation tool offers).
- ``gauss-seidel``: fixed step; drive, block, friction step in turn, each with the freshest
  outputs of the ones before.
- ``implicit``: fixed step; iterates with rollback until the force the block felt and the
  friction at the resulting relative velocity agree. The loop dv -> F -> dv is monotone, so
  the agreement is a root of a monotone scalar function; where it sits on the jump of a
  discontinuous law (dry friction at dv = 0) the blocks are stuck and the force is the one
  that keeps dv = 0. Stick is resolved exactly without telling the friction FMU anything
  about the block.
- ``adaptive``: the implicit step with step doubling: the difference between one step and
  two half steps estimates the error; steps that miss the tolerance are rolled back and
  retried smaller, so steps shrink at stick/slip transitions and melting, grow elsewhere.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from .system import CoupledSystem, Point

NS = 1_000_000_000  # nanoseconds per second


@dataclass
class Counters:
    steps: int = 0  # accepted communication steps
    rejected: int = 0  # steps rolled back and retried smaller
    iterations: int = 0  # evaluations of the coupling loop (implicit solves)
    forced: int = 0  # steps accepted at the minimum step although above tolerance
    stick_steps: int = 0


class CouplingAlgorithm(ABC):
    """Advance a :class:`CoupledSystem` from a point; the algorithm chooses its step."""

    name = "abstract"

    def __init__(self, step: float | None = None, tol: float | None = None):
        self.counters = Counters()
        self.step_ns = max(2, int(round((step or self.default_step) * NS)))
        self.tol = tol if tol is not None else self.default_tol

    default_step = 1e-4  # s
    default_tol = 1e-3

    def prepare(self, system: CoupledSystem, scales: "Scales") -> None:
        """Called once before the first step with the problem's scales."""
        self.scales = scales

    @abstractmethod
    def advance(self, system: CoupledSystem, point: Point, stop_ns: int) -> list[Point]:
        """Advance from point toward stop_ns; returns the accepted points (may be empty)."""

    def next_step(self, point: Point, stop_ns: int) -> int:
        return min(self.step_ns, stop_ns - point.t_ns)


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes, for tolerances: position [m], velocity [m/s], period [s]."""

    position: float
    velocity: float
    period: float


class ExplicitCoupling(CouplingAlgorithm):
    """Fixed-step explicit coupling; ``sequential`` picks Gauss-Seidel over Jacobi."""

    def __init__(self, step=None, tol=None, sequential: bool = False):
        super().__init__(step, tol)
        self.sequential = sequential
        self.name = "gauss-seidel" if sequential else "jacobi"

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        t, h = point.t_ns / NS, h_ns / NS
        F_start = point.F
        X, V, aX = system.step_drive(t, h)
        x, v, a = system.step_block(F_start, 0.0, t, h)
        # Jacobi gives the friction the relative velocity of the step's start; Gauss-Seidel
        # the one the drive and block just produced.
        dv_in = (V - v) if self.sequential else point.dv
        system.step_friction(dv_in, t, h)
        F, f = system.friction_outputs(V - v)  # direct feedthrough at the new point
        self.counters.steps += 1
        return [Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F_start,
                      mode=_mode(V - v, 0.0))]


class ImplicitCoupling(CouplingAlgorithm):
    """Fixed-step implicit coupling (backward Euler in the exchanged force).

    Over a step the block feels a constant force F; the step is accepted when F equals
    the friction at the end-of-step relative velocity (or, stuck, lies within the jump).
    """

    name = "implicit"
    max_iterations = 60

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        new = self.solve_step(system, point, h_ns)
        self.counters.steps += 1
        return [new]

    def solve_step(self, system: CoupledSystem, point: Point, h_ns: int) -> Point:
        """One implicit step of h_ns from point; leaves every slave at the new point."""
        t, h = point.t_ns / NS, h_ns / NS
        X, V, aX = system.step_drive(t, h)
        if system.friction is None:
            x, v, a = system.step_block(0.0, 0.0, t, h)
            return Point(point.t_ns + h_ns, X, V, aX, x, v, a, mode=_mode(V - v, 0.0))
        saved = system.save(system.block, system.friction)
        try:
            return self._solve(system, point, saved, t, h, h_ns, X, V, aX)
        finally:
            system.free(saved)

    def _solve(self, system, point, saved, t, h, h_ns, X, V, aX):
        block_state = {k: v for k, v in saved.handles.items() if v[0] is system.block}
        friction_state = {k: v for k, v in saved.handles.items() if v[0] is system.friction}
        delta = 1e-10 * self.scales.velocity  # "zero" relative velocity [m/s]
        last = {}  # the latest evaluation of each slave; also: "it has stepped, restore first"

        def friction_at(dv):
            if "friction" in last:
                for slave, handle in friction_state.values():
                    slave.restore(handle)
            F, f = system.step_friction(dv, t, h)
            last["friction"] = (dv, F, f)
            return F, f

        def block_under(F):
            if "block" in last:
                for slave, handle in block_state.values():
                    slave.restore(handle)
            x, v, a = system.step_block(F, 0.0, t, h)
            last["block"] = (F, x, v, a)
            return V - v

        def loop(dv):  # H(dv): how far the block's answer is from the assumed dv
            self.counters.iterations += 1
            F, _ = friction_at(dv)
            return block_under(F) - dv

        # Try the side the contact was on first: most steps need two evaluations.
        first = -1.0 if point.mode < 0 else 1.0
        probes = {}  # side -> (friction force at +-delta, block's dv under it)

        def probe(side):
            value = loop(side * delta)
            probes[side] = (last["friction"][1], last["block"][2])
            return value

        mode = 0
        for side in (first, -first):
            h_side = probe(side)
            if side * h_side > 0:  # the block slips past +-delta on this side
                dv = self._slip_root(loop, side * delta, h_side, side, delta)
                mode = int(side)
                break
        if mode == 0:
            F = self._stick_force(block_under, probes, V, delta)
            self.counters.stick_steps += 1
            _, f = friction_at(0.0)
        else:
            if last["friction"][0] != dv:
                friction_at(dv)
            _, F, f = last["friction"]
            if last["block"][0] != F:
                block_under(F)
        _, x, v, a = last["block"]
        return Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F, mode=mode)

    def _slip_root(self, loop, lo, h_lo, direction, delta):
        """Root of the decreasing loop function beyond lo (slip in `direction`)."""
        # One fixed-point pass from lo lands beyond the root: the friction there is at
        # least as large, so the block answers with a smaller dv.
        hi = lo + h_lo
        h_hi = loop(hi)
        if direction * h_hi >= 0:  # not beyond: the law is not monotone here; search outward
            for _ in range(self.max_iterations):
                lo, h_lo = hi, h_hi
                hi = lo + 2.0 * (h_lo if h_lo != 0 else direction * delta)
                h_hi = loop(hi)
                if direction * h_hi < 0 or h_hi == 0:
                    break
        if h_hi == 0:
            return hi
        # Illinois regula falsi on [lo, hi]; for laws constant in dv it ends at once.
        side = 0
        x = hi
        for _ in range(self.max_iterations):
            x = (lo * h_hi - hi * h_lo) / (h_hi - h_lo)
            hx = loop(x)
            if abs(hx) <= delta or hx == 0:
                return x
            if (hx > 0) == (h_lo > 0):
                lo, h_lo = x, hx
                if side == -1:
                    h_hi *= 0.5
                side = -1
            else:
                hi, h_hi = x, hx
                if side == 1:
                    h_lo *= 0.5
                side = 1
            if abs(hi - lo) <= delta:
                return x
        return x

    def _stick_force(self, block_under, probes, V, delta):
        """The force that keeps the blocks together over the step (dv = 0 at its end).

        It lies between the friction at -delta and at +delta (the probes already made);
        the secant on the block's answer starts from those two evaluations.
        """
        (F_pos, v_pos), (F_neg, v_neg) = probes[1.0], probes[-1.0]
        a, da, b, db = F_neg, V - v_neg, F_pos, V - v_pos
        if da == db:
            block_under(F_pos)
            return F_pos
        F = b
        for _ in range(self.max_iterations):
            F = b - db * (b - a) / (db - da)
            d = block_under(F)
            if abs(d) <= delta or d == db:
                break
            a, da, b, db = b, db, F, d
        return F


class AdaptiveCoupling(ImplicitCoupling):
    """Implicit steps under error control by step doubling.

    tol is relative: a step is accepted when one step and two half steps differ by less
    than ``tol * scale * h / T`` in x and v (scale: the drive's amplitude and velocity; T:
    its period) and by ``tol * h / T`` in f, so the error committed per drive period stays
    near tol whatever the number of steps.
    """

    name = "adaptive"
    default_tol = 1e-4
    default_step = 1e-4  # first try [s]

    def prepare(self, system, scales):
        super().prepare(system, scales)
        self.min_ns = max(2, int(scales.period * 1e-7 * NS) & ~1)
        self.max_ns = max(self.min_ns, int(scales.period / 20 * NS) & ~1)
        self.h_ns = min(max(self.step_ns & ~1, self.min_ns), self.max_ns)

    def advance(self, system, point, stop_ns):
        h_ns = min(self.h_ns, stop_ns - point.t_ns)
        if h_ns < 2 * self.min_ns and stop_ns - point.t_ns > h_ns:
            h_ns = min(2 * self.min_ns, stop_ns - point.t_ns)
        h_ns -= h_ns & 1  # two equal halves in integer nanoseconds
        if h_ns < 2:  # a last sliver of time: one plain implicit step
            self.counters.steps += 1
            return [self.solve_step(system, point, stop_ns - point.t_ns)]
        start = system.save()
        try:
            full = self.solve_step(system, point, h_ns)
            system.restore(start)
            mid = self.solve_step(system, point, h_ns // 2)
            end = self.solve_step(system, mid, h_ns // 2)
            err = max(self._error(full, end, h_ns), self._interpolation_error(point, mid, end, h_ns))
            end.est_error = mid.est_error = err * self.tol
            factor = 0.9 / math.sqrt(max(err, 1e-12))
            if err <= 1.0 or h_ns <= 2 * self.min_ns:
                self.counters.forced += err > 1.0
                self.counters.steps += 2
                self.h_ns = int(min(max(h_ns * min(factor, 4.0), self.min_ns), self.max_ns))
                return [mid, end]
            system.restore(start)
            self.counters.rejected += 1
            self.h_ns = int(max(h_ns * max(factor, 0.1), self.min_ns))
            return []
        finally:
            system.free(start)

    def _interpolation_error(self, start: Point, mid: Point, end: Point, h_ns: int) -> float:
        """How far cubic Hermite interpolation over the whole step misses the computed
        midpoint, relative to tol: results are sampled between communication points, and
        this bounds that error (halves interpolate 16 times better)."""
        s, h = self.scales, h_ns / NS
        hermite_mid = lambda y0, dy0, y1, dy1: 0.5 * (y0 + y1) + h / 8.0 * (dy0 - dy1)
        v_mid = hermite_mid(start.v, start.a, end.v, end.a)
        x_mid = hermite_mid(start.x, start.v, end.x, end.v)
        return max(abs(v_mid - mid.v) / (16 * self.tol * s.velocity),
                   abs(x_mid - mid.x) / (16 * self.tol * s.position))

    def _error(self, full: Point, halves: Point, h_ns: int) -> float:
        s = self.scales
        allowed = self.tol * (h_ns / NS) / s.period
        return max(abs(full.v - halves.v) / (allowed * s.velocity),
                   abs(full.x - halves.x) / (allowed * s.position),
                   abs(full.f - halves.f) / allowed)


def _mode(dv: float, delta: float) -> int:
    return (dv > delta) - (dv < -delta)


ALGORITHMS = {
    "jacobi": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=False),
    "gauss-seidel": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=True),
    "implicit": ImplicitCoupling,
    "adaptive": AdaptiveCoupling,
}


def make_algorithm(name: str, step: float | None = None, tol: float | None = None) -> CouplingAlgorithm:
    """The algorithm registered under name; raises ValueError naming the known ones."""
    try:
        factory = ALGORITHMS[name]
    except KeyError:
        raise ValueError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})") from None
    return factory(step=step, tol=tol)
