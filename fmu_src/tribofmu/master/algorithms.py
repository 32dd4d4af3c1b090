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


def velocity_slopes(start: Point, end: Point) -> tuple[float, float]:
    """dv/dt at both ends of the step start -> end, as results are interpolated: over a
    step that ends stuck, v follows V, so the slope is the drive's acceleration."""
    return (start.aX, end.aX) if end.mode == 0 else (start.a, end.a)

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
        new = Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F_start, mode=_mode(V - v, 0.0))
        system.finish_step(point, new, t, h)
        return [new]


class ImplicitCoupling(CouplingAlgorithm):
    """Fixed-step implicit coupling.

    A step is accepted when the force the block felt at its end equals the friction at the
    end-of-step relative velocity (or, stuck, lies within the jump). Over the step the
    force is ramped (slipping the same way, loop gain below max_ramp_gain), held (at
    transitions and where the loop is stiff: backward Euler), or, stuck throughout, the
    ramp that keeps both v = V and x - X.
    """

    name = "implicit"
    max_iterations = 60

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        new = self.solve_step(system, point, h_ns)
        self.counters.steps += 1
        return [new]

    def solve_step(self, system: CoupledSystem, point: Point, h_ns: int, ramp_allowed: bool = True) -> Point:
        """One implicit step of h_ns from point; leaves every slave at the new point.

        ramp_allowed=False holds the force over the step even where a ramp would do."""
        t, h = point.t_ns / NS, h_ns / NS
        X, V, aX = system.step_drive(t, h)
        if system.friction is None:
            x, v, a = system.step_block(0.0, 0.0, t, h)
            return Point(point.t_ns + h_ns, X, V, aX, x, v, a, mode=_mode(V - v, 0.0))
        saved = system.save(system.block, system.friction)
        try:
            new = self._solve(system, point, saved, t, h, h_ns, X, V, aX, ramp_allowed)
        finally:
            system.free(saved)
        system.finish_step(point, new, t, h)
        return new

    def _solve(self, system, point, saved, t, h, h_ns, X, V, aX, ramp_allowed):
        # Second order where the force is smooth: while the contact keeps slipping the same
        # way, the block feels a ramp from the force at the step's start to the one at its
        # end (trapezoidal coupling). Where the loop is stiff the ramp would ring, and at
        # stick or reversal the force jumps: there the force is held (L-stable).
        ramp = ramp_allowed and self.second_order and point.mode != 0 and self._loop_gain < self.max_ramp_gain
        new = self._solve_held(system, point, saved, t, h, h_ns, X, V, aX, ramp)
        if new is None:  # the ramp met stiffness or a transition: redo with the force held
            system.restore(saved)
            new = self._solve_held(system, point, saved, t, h, h_ns, X, V, aX, False)
        return new

    second_order = True
    # The trapezoidal ramp damps an error mode by (1 - g)/(1 + g) per step at loop gain g,
    # which rings toward -1 as g grows: above this gain the force is held instead. Measured
    # on fig6 (stiff solid lubricant): 30 rather than 3 cut rejections 7x at equal error.
    max_ramp_gain = 30.0
    _loop_gain = 0.0  # |d(block dv)/dF * dF/d(dv)| of the last slip step, from the iteration

    def _solve_held(self, system, point, saved, t, h, h_ns, X, V, aX, ramp):
        """One step with the force ramped from point.F (ramp) or held; None if a ramp
        step turns out stuck, reversing or stiff."""
        block_state = [v for v in saved.handles.values() if v[0] is system.block]
        friction_state = [v for v in saved.handles.values() if v[0] is system.friction]
        delta = 1e-10 * self.scales.velocity  # "zero" relative velocity [m/s]
        last = {}  # the latest evaluation of each slave; also: "it has stepped, restore first"
        F_start = point.F

        def friction_at(dv):
            if "friction" in last:
                for slave, handle in friction_state:
                    slave.restore(handle)
            F, f = system.step_friction(dv, t, h)
            last["friction"] = (dv, F, f)
            return F, f

        def block_at(F0, rate):  # the block's relative velocity and position after the step
            if "block" in last:
                for slave, handle in block_state:
                    slave.restore(handle)
            x, v, a = system.step_block(F0, rate, t, h)
            last["block"] = (F0 + rate * h, x, v, a, F0, rate)
            return V - v, x

        def block_under(F):  # F: the force at the end of the step
            return block_at(F_start, (F - F_start) / h)[0] if ramp else block_at(F, 0.0)[0]

        def loop(dv):  # H(dv): how far the block's answer is from the assumed dv
            self.counters.iterations += 1
            F, _ = friction_at(dv)
            return block_under(F) - dv

        # Try the side the contact was on first: most steps need two evaluations.
        first = -1.0 if point.mode < 0 else 1.0
        probes = {}  # side -> (friction at +-delta, block's dv and x under it, force held)

        def probe(side):
            value = loop(side * delta)
            probes[side] = (last["friction"][1], V - last["block"][2], last["block"][1])
            return value

        mode = 0
        event = 1.0
        for side in (first, -first):
            h_side = probe(side)
            if side * h_side > 0:  # the block slips past +-delta on this side
                if point.mode == 0 and point.F_rate != 0.0:
                    # It was stuck, its force ramping toward the bound: it broke away when
                    # the ramp reached the bound, maybe well inside this step.
                    reach = (probes[side][0] - point.F) / (point.F_rate * h)
                    event = reach if 0.0 < reach < 1.0 else 1.0
                dv, gain = self._slip_root(loop, side * delta, h_side, side, delta)
                mode = int(side)
                break
            if ramp:
                return None
        if mode == 0:
            if point.mode == 0 and point.t_ns > 0:  # stuck all through the step
                event = self._stick_ramp(block_at, probes, delta, h, X - point.X, point.x)
            if event < 1.0 or point.mode != 0 or point.t_ns == 0:
                self._stick_force(block_under, probes, delta)
            self.counters.stick_steps += 1
            _, f = friction_at(0.0)
        else:
            if ramp and gain >= self.max_ramp_gain:
                self._loop_gain = gain
                return None
            self._loop_gain = gain
            if last["friction"][0] != dv:
                friction_at(dv)
            _, F, f = last["friction"]
            if last["block"][0] != F:
                block_under(F)
        F, x, v, a, F0, F_rate = last["block"]
        return Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F0, F_rate=F_rate, mode=mode,
                     event=event, ramped=ramp)

    def _slip_root(self, loop, lo, h_lo, direction, delta):
        """Root of the decreasing loop function beyond lo (slip in `direction`).

        Returns (dv, loop gain): the gain is -(slope of the loop function) - 1, i.e. how
        strongly the block's answer reacts to the assumed dv, measured on the bracket.
        """
        # One fixed-point pass from lo lands beyond the root: the friction there is at
        # least as large, so the block answers with a smaller dv.
        hi = lo + h_lo
        h_hi = loop(hi)
        if direction * h_hi >= 0 and h_hi != 0:  # not beyond: the law is not monotone here
            for _ in range(self.max_iterations):
                lo, h_lo = hi, h_hi
                hi = lo + 2.0 * (h_lo if h_lo != 0 else direction * delta)
                h_hi = loop(hi)
                if direction * h_hi < 0 or h_hi == 0:
                    break
        gain = lambda: max(0.0, -(h_hi - h_lo) / (hi - lo) - 1.0) if hi != lo else 0.0
        if h_hi == 0:
            return hi, gain()
        # Illinois regula falsi on [lo, hi]; for laws constant in dv it ends at once.
        side = 0
        x = hi
        for _ in range(self.max_iterations):
            x = (lo * h_hi - hi * h_lo) / (h_hi - h_lo)
            hx = loop(x)
            if abs(hx) <= delta or hx == 0:
                break
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
                break
        return x, gain()

    def _stick_force(self, block_under, probes, delta):
        """The force that keeps the blocks together over the step (dv = 0 at its end).

        It lies between the friction at -delta and at +delta (the probes already made);
        the secant on the block's answer starts from those two evaluations.
        """
        (F_pos, a_pos, _), (F_neg, a_neg, _) = probes[1.0], probes[-1.0]
        a, da, b, db = F_neg, a_neg, F_pos, a_pos
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

    def _stick_ramp(self, block_at, probes, delta, h, dX, x_start):
        """Stuck over the whole step: the force ramp F0 + rate s that keeps the blocks
        together, i.e. ends with dv = 0 and moves the block exactly as far as the drive.

        A held force can match only one of the two, and then the position drifts by
        O(h^3) a step through the spring term; the ramp matches both, and needs no force
        from the previous step (so no ringing). The block's answer is affine in (F0, rate)
        for a linear block; it is not assumed: the Newton steps use secant slopes.
        """
        (F_pos, d_pos, x_pos), (F_neg, d_neg, x_neg) = probes[1.0], probes[-1.0]
        if F_pos == F_neg:
            return 0.0
        x_target = x_start + dX
        # slopes in F0 from the two held probes, in rate from one more evaluation
        dF = F_pos - F_neg
        d_F, x_F = (d_pos - d_neg) / dF, (x_pos - x_neg) / dF
        rate_probe = dF / h
        F0, rate = F_neg, 0.0
        d0, x0 = d_neg, x_neg
        d_r, x_r = None, None
        for _ in range(8):
            if d_r is None:
                d1, x1 = block_at(F0, rate + rate_probe)
                d_r, x_r = (d1 - d0) / rate_probe, (x1 - x0) / rate_probe
            det = d_F * x_r - d_r * x_F
            if det == 0:
                break
            # Newton on (dv_end, x_end - x_target) = 0 with the secant Jacobian
            rx = x0 - x_target
            F0, rate = F0 - (d0 * x_r - d_r * rx) / det, rate - (d_F * rx - x_F * d0) / det
            d0, x0 = block_at(F0, rate)
            if abs(d0) <= delta and abs(x0 - x_target) <= 1e-12 * self.scales.position:
                break
        # Where the ramp leaves the friction's bounds the contact breaks away inside the
        # step: return the fraction of the step at which it does (1.0: stuck throughout).
        low, high = min(F_neg, F_pos), max(F_neg, F_pos)
        F1 = F0 + rate * h
        if not low <= F0 <= high:
            return 0.0
        if F1 > high:
            return (high - F0) / (F1 - F0)
        if F1 < low:
            return (low - F0) / (F1 - F0)
        return 1.0


class AdaptiveCoupling(ImplicitCoupling):
    """Implicit steps under error control by step doubling.

    tol is relative: a step is accepted when one step and two half steps differ by less
    than ``tol * scale * h / T`` in x and v (scale: the drive's amplitude and velocity; T:
    its period), so the error committed per drive period stays near tol whatever the number
    of steps, and by ``tol * (1 + |f|)`` in f.
    """

    name = "adaptive"
    default_tol = 1e-3  # measured: nRMS(v) 1e-5 .. 4.4e-4 on the paper's scenes (fig6: 1.4e-3)
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
            landing = int(h_ns * full.event) & ~1
            if full.event < 1.0 and landing >= 2 * self.min_ns and landing >= h_ns // 100:
                # A stuck contact breaks away inside the step: end the step right there.
                system.restore(start)
                self.counters.rejected += 1
                self.h_ns = landing
                return []
            system.restore(start)
            # The halves hold the force where the full step did: an estimate comparing a
            # ramped with a held step would measure the held step's first-order error.
            mid = self.solve_step(system, point, h_ns // 2, full.ramped)
            end = self.solve_step(system, mid, h_ns // 2, full.ramped)
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
        hermite_mid = lambda y0, dy0, dy1, y1: 0.5 * (y0 + y1) + h / 8.0 * (dy0 - dy1)
        v_mid = hermite_mid(start.v, *velocity_slopes(start, end), end.v)
        x_mid = hermite_mid(start.x, start.v, end.v, end.x)
        return max(abs(v_mid - mid.v) / (16 * self.tol * s.velocity),
                   abs(x_mid - mid.x) / (16 * self.tol * s.position))

    def _error(self, full: Point, halves: Point, h_ns: int) -> float:
        s = self.scales
        allowed = self.tol * (h_ns / NS) / s.period
        # f relaxes within microseconds and so carries no error forward: it is held to
        # tol per step (which still catches a melting or solidification the step misses).
        return max(abs(full.v - halves.v) / (allowed * s.velocity),
                   abs(full.x - halves.x) / (allowed * s.position),
                   abs(full.f - halves.f) / (self.tol * (1.0 + abs(halves.f))))


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
