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

from abc import ABC, abstractmethod
import math
from dataclasses import dataclass

from ..physics.roots import illinois
from .estimate import GlobalErrorEstimate
from .interpolation import NS, hermite, hermite_mid, velocity_slopes
from .system import CoupledSystem, Point, States




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
    ramp that keeps both v = V and x - X. One step's solve is a :class:`ImplicitStep`.
    """

    name = "implicit"
    max_iterations = 60
    second_order = True
    # The trapezoidal ramp damps an error mode by (1 - g)/(1 + g) per step at loop gain g,
    # which rings toward -1 as g grows: above this gain the force is held instead. Measured
    # on fig6 (stiff solid lubricant): 30 rather than 3 cut rejections 7x at equal error.
    max_ramp_gain = 30.0

    def __init__(self, step=None, tol=None):
        super().__init__(step, tol)
        self.loop_gain = 0.0  # |d(block dv)/dF * dF/d(dv)| of the last slip step ...
        self.loop_gain_step = 1.0  # ... whose length this was [s]
        self.velocity_per_impulse = 0.0  # [m/s / (N s)] the block's, last measured (0: not yet)

    def expected_gain(self, h: float) -> float:
        """The loop gain a slip step of h [s] should meet: the last one's, scaled by the
        step (the block's response to a force change grows with the step)."""
        return self.loop_gain * h / self.loop_gain_step

    # The slip root is solved to this fraction of the step's error allowance: tighter buys
    # nothing the error control can see, and each iteration is a friction and a block step.
    root_tol_fraction = 1e-3

    def root_tolerance(self) -> float:
        """How far [m/s] the coupling loop may miss its root while slipping."""
        return self.root_tol_fraction * self.tol * self.scales.velocity

    def measured_gain(self, gain: float, h: float) -> None:
        self.loop_gain, self.loop_gain_step = gain, h

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        new = self.solve_step(system, point, h_ns)
        self.counters.steps += 1
        return [new]

    def solve_step(self, system: CoupledSystem, point: Point, h_ns: int, ramp_allowed: bool = True) -> Point:
        """One implicit step of h_ns from point; leaves every slave at the new point.

        ramp_allowed=False holds the force over the step even where a ramp would do."""
        t, h = point.t_ns / NS, h_ns / NS
        drive = system.step_drive(t, h)
        if system.friction is None:
            x, v, a = system.step_block(0.0, 0.0, t, h)
            new = Point(point.t_ns + h_ns, *drive, x, v, a, mode=_mode(drive[1] - v, 0.0))
        else:
            saved = system.save(system.block, system.friction)
            try:
                # Second order where the force is smooth: while the contact keeps slipping the
                # same way, the block feels a ramp from the force at the step's start to the
                # one at its end (trapezoidal coupling). Where the loop is stiff the ramp would
                # ring, and at stick or reversal the force jumps: there the force is held.
                ramp = (ramp_allowed and self.second_order and point.mode != 0
                        and self.expected_gain(h) < self.max_ramp_gain)
                new = ImplicitStep(self, system, point, saved, h_ns, drive, ramp).solve()
                if new is None:  # the ramp met stiffness or a transition: hold the force
                    system.restore(saved)
                    new = ImplicitStep(self, system, point, saved, h_ns, drive, False).solve()
            finally:
                system.free(saved)
        system.finish_step(point, new, t, h)
        return new


class ImplicitStep:
    """The solve of one implicit step: from ``point`` over ``h_ns`` with the drive already
    at the step's end (``drive`` = X, V, aX), the block and friction saved in ``saved``.

    The loop function H(dv) = (the block's relative velocity after the step under the
    friction at dv) - dv is decreasing, so the coupled answer is its single root, found on
    a bracket; on the jump of a discontinuous law (dry friction at dv = 0) there is no
    root: the blocks are stuck and the force is the one that keeps dv = 0.
    """

    def __init__(self, algorithm: ImplicitCoupling, system: CoupledSystem, point: Point, saved: States,
                 h_ns: int, drive: tuple[float, float, float], ramp: bool):
        self.algorithm, self.system, self.point, self.ramp = algorithm, system, point, ramp
        self.h_ns, self.t, self.h = h_ns, point.t_ns / NS, h_ns / NS
        self.X, self.V, self.aX = drive
        self.block_state = [v for v in saved.handles.values() if v[0] is system.block]
        self.friction_state = [v for v in saved.handles.values() if v[0] is system.friction]
        self.delta = 1e-10 * algorithm.scales.velocity  # "zero" relative velocity [m/s]
        self.root_tol = max(self.delta, algorithm.root_tolerance())  # m/s
        self.counters = algorithm.counters
        self.friction_last = None  # (dv, F, f, F_mean) of the friction's latest step; None: not stepped
        self.block_last = None  # (F_end, x, v, a, F0, rate) of the block's latest step
        self.probes = {}  # side -> (friction at side * delta, block's dv and x under it, held)

    # -- evaluations ----------------------------------------------------------------------
    def friction_at(self, dv: float) -> tuple[float, float]:
        if self.friction_last is not None:
            for slave, handle in self.friction_state:
                slave.restore(handle)
        F, f, F_mean = self.system.step_friction(dv, self.t, self.h)
        self.friction_last = (dv, F, f, F_mean)
        return F, f

    def block_at(self, F0: float, rate: float) -> tuple[float, float]:
        """The block's relative velocity and position after the step under F0 + rate s."""
        if self.block_last is not None:
            for slave, handle in self.block_state:
                slave.restore(handle)
        x, v, a = self.system.step_block(F0, rate, self.t, self.h)
        impulse = (F0 + 0.5 * rate * self.h) * self.h
        if self.block_last is not None:
            # the block's velocity per unit impulse (1/M for a lone mass), from the secant
            _, _, v_last, _, F0_last, rate_last = self.block_last
            d_impulse = impulse - (F0_last + 0.5 * rate_last * self.h) * self.h
            if d_impulse != 0.0 and v != v_last:
                self.algorithm.velocity_per_impulse = abs((v - v_last) / d_impulse)
        self.block_last = (F0 + rate * self.h, x, v, a, F0, rate)
        return self.V - v, x

    def block_under(self, F: float) -> float:
        """The block's relative velocity after the step whose force ends at F."""
        if self.ramp:
            return self.block_at(self.point.F, (F - self.point.F) / self.h)[0]
        return self.block_at(F, 0.0)[0]

    def loop(self, dv: float) -> float:
        """H(dv): how far the block's answer is from the assumed dv."""
        self.counters.iterations += 1
        F, _ = self.friction_at(dv)
        return self.block_under(F) - dv

    def probe(self, side: float) -> float:
        value = self.loop(side * self.delta)
        self.probes[side] = (self.friction_last[1], self.V - self.block_last[2], self.block_last[1])
        return value

    # -- the solve ------------------------------------------------------------------------
    def solve(self) -> Point | None:
        """The new point; None if a ramped step turns out stuck, reversing or stiff."""
        point, delta, algorithm = self.point, self.delta, self.algorithm
        first = -1.0 if point.mode < 0 else 1.0
        mode, event, slip = 0, 1.0, None
        if point.mode != 0 and algorithm.loop_gain > 0:
            # (with no loop gain, as for dry friction, the first pass from +-delta is exact)
            slip = self.predicted_slip(first)
        if slip is None:
            for side in (first, -first):
                h_side = self.probe(side)
                if side * h_side > 0:  # the block slips past +-delta on this side
                    if point.mode == 0 and point.F_rate != 0.0:
                        # It was stuck, its force ramping toward the bound: it broke away when
                        # the ramp reached the bound, maybe well inside this step.
                        reach = (self.probes[side][0] - point.F) / (point.F_rate * self.h)
                        event = reach if 0.0 < reach < 1.0 else 1.0
                    slip = self.slip_root(side * delta, h_side, side)
                    mode = int(side)
                    break
                if self.ramp:
                    return None
        else:
            mode = int(first)
        if mode == 0:
            if point.mode == 0 and point.t_ns > 0:  # stuck all through the step
                event = self.stick_ramp()
            elif point.mode != 0:
                # It was slipping and ends stuck: dv reached 0 inside the step, where the
                # block's dv under the slip force (the probe on the slip side) crosses it.
                slipping_on = self.probes[first][1]
                if point.dv != slipping_on:
                    event = min(1.0, max(0.0, point.dv / (point.dv - slipping_on)))
            if event < 1.0 or point.mode != 0 or point.t_ns == 0:
                self.stick_force()
            self.counters.stick_steps += 1
            _, f = self.friction_at(0.0)
        else:
            dv, gain = slip
            algorithm.measured_gain(gain, self.h)
            if self.ramp and gain >= algorithm.max_ramp_gain:
                return None
            if self.friction_last[0] != dv:
                self.friction_at(dv)
            _, F, f, F_mean = self.friction_last
            if self.block_last[0] != F:
                self.block_under(F)
        F, x, v, a, F0, F_rate = self.block_last
        return Point(point.t_ns + self.h_ns, self.X, self.V, self.aX, x, v, a, F, f, F_start=F0,
                     F_rate=F_rate, mode=mode, event=event, ramped=self.ramp,
                     F_mean=F_mean if mode != 0 else math.nan)

    def predicted_slip(self, side: float) -> tuple[float, float] | None:
        """Slipping on, as before: start the root search at the predicted dv instead of at
        +-delta, which saves the probe and keeps trial velocities near the answer (a trial
        far beyond it can melt the lubricant: costly, and a detour for the root finder).
        Returns (dv, gain), or None where the prediction does not show slip on this side."""
        point, delta = self.point, self.delta
        # dv moves with the drive's acceleration less the block's; the loop's own answer
        # pulls it back by 1/(1 + gain) (a stiff loop hardly lets dv change).
        guess = point.dv + (point.aX - point.a) * self.h / (1.0 + self.algorithm.expected_gain(self.h))
        if not side * guess > delta:
            return None
        h_guess = self.loop(guess)
        if side * h_guess > 0:  # the root lies beyond the guess: slip confirmed
            return self.slip_root(guess, h_guess, side)
        h_lo = self.probe(side)  # between +-delta and the guess, or no slip at all
        if not side * h_lo > 0:
            return None
        return self.slip_root(side * delta, h_lo, side, guess, h_guess)

    def slip_root(self, lo: float, h_lo: float, direction: float, hi: float | None = None,
                  h_hi: float | None = None) -> tuple[float, float]:
        """Root of the decreasing loop function beyond lo (slip in `direction`), on the
        bracket [lo, hi] if given.

        Returns (dv, loop gain): the gain is -(slope of the loop function) - 1, i.e. how
        strongly the block's answer reacts to the assumed dv, measured on the bracket.
        """
        loop, delta, max_iterations = self.loop, self.delta, self.algorithm.max_iterations
        if hi is None:
            # Aim at the root with the last step's loop gain; where that falls short, the
            # fixed-point pass from the nearer point lands beyond the root: the friction
            # there is at least as large, so the block answers with a smaller dv.
            gain = self.algorithm.expected_gain(self.h)
            for fraction in ((1.05 / (1.0 + gain), 1.0) if gain > 0 else (1.0,)):
                hi = lo + fraction * h_lo
                h_hi = loop(hi)
                if direction * h_hi < 0 or h_hi == 0:
                    break
                lo, h_lo = hi, h_hi
            else:  # not beyond even so: the law is not monotone here; widen
                for _ in range(max_iterations):
                    hi = lo + 2.0 * (h_lo if h_lo != 0 else direction * delta)
                    h_hi = loop(hi)
                    if direction * h_hi < 0 or h_hi == 0:
                        break
                    lo, h_lo = hi, h_hi
        gain = max(0.0, -(h_hi - h_lo) / (hi - lo) - 1.0) if hi != lo else 0.0
        if h_hi == 0:
            return hi, gain
        if abs(h_lo) <= self.root_tol:
            return lo, gain
        if abs(h_hi) <= self.root_tol:
            return hi, gain
        return illinois(loop, lo, hi, h_lo, h_hi, xtol=delta, rtol=0.0, ftol=self.root_tol,
                        max_iterations=max_iterations), gain

    def stick_force(self) -> float:
        """The force that keeps the blocks together over the step (dv = 0 at its end).

        It lies between the friction at -delta and at +delta (the probes already made);
        the secant on the block's answer starts from those two evaluations.
        """
        (F_pos, a_pos, _), (F_neg, a_neg, _) = self.probes[1.0], self.probes[-1.0]
        a, da, b, db = F_neg, a_neg, F_pos, a_pos
        if da == db:
            self.block_under(F_pos)
            return F_pos
        F = b
        for _ in range(self.algorithm.max_iterations):
            F = b - db * (b - a) / (db - da)
            d = self.block_under(F)
            if abs(d) <= self.delta or d == db:
                break
            a, da, b, db = b, db, F, d
        return F

    def stick_ramp(self) -> float:
        """Stuck over the whole step: the force ramp F0 + rate s that keeps the blocks
        together, i.e. ends with dv = 0 and moves the block exactly as far as the drive.

        A held force can match only one of the two, and then the position drifts by
        O(h^3) a step through the spring term; the ramp matches both, and needs no force
        from the previous step (so no ringing). The block's answer is affine in (F0, rate)
        for a linear block; it is not assumed: the Newton steps use secant slopes.
        Returns the fraction of the step at which the ramp leaves the friction's bounds
        (the contact breaks away there), 1.0 if it stays stuck throughout.
        """
        (F_pos, d_pos, x_pos), (F_neg, d_neg, x_neg) = self.probes[1.0], self.probes[-1.0]
        if F_pos == F_neg:
            return 0.0
        h = self.h
        x_target = self.point.x + self.X - self.point.X
        # slopes in F0 from the two held probes, in rate from one more evaluation
        dF = F_pos - F_neg
        d_F, x_F = (d_pos - d_neg) / dF, (x_pos - x_neg) / dF
        rate_probe = dF / h
        F0, rate = F_neg, 0.0
        d0, x0 = d_neg, x_neg
        d_r, x_r = None, None
        for _ in range(8):
            if d_r is None:
                d1, x1 = self.block_at(F0, rate + rate_probe)
                d_r, x_r = (d1 - d0) / rate_probe, (x1 - x0) / rate_probe
            det = d_F * x_r - d_r * x_F
            if det == 0:
                break
            # Newton on (dv_end, x_end - x_target) = 0 with the secant Jacobian
            rx = x0 - x_target
            F0, rate = F0 - (d0 * x_r - d_r * rx) / det, rate - (d_F * rx - x_F * d0) / det
            d0, x0 = self.block_at(F0, rate)
            if abs(d0) <= self.delta and abs(x0 - x_target) <= 1e-12 * self.algorithm.scales.position:
                break
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
    default_tol = 2e-4  # per-step error against the block's own motion: see README, "What accuracy costs"
    default_step = 1e-4  # first try [s]

    def prepare(self, system, scales):
        super().prepare(system, scales)
        self.min_ns = max(2, int(scales.period * 1e-7 * NS) & ~1)
        self.max_ns = max(self.min_ns, int(scales.period / 20 * NS) & ~1)
        self.h_ns = min(max(self.step_ns & ~1, self.min_ns), self.max_ns)
        self._v_scale = self._x_scale = 0.0  # largest |v| [m/s] and |x| [m] of the block so far
        self._F_scale = self._f_scale = 0.0  # largest |F| [N], |f| [1] so far
        self.estimate = GlobalErrorEstimate()

    def advance(self, system, point, stop_ns):
        h_ns = min(self.h_ns, stop_ns - point.t_ns)
        if h_ns < 2 * self.min_ns and stop_ns - point.t_ns > h_ns:
            h_ns = min(2 * self.min_ns, stop_ns - point.t_ns)
        h_ns -= h_ns & 1  # two equal halves in integer nanoseconds
        if h_ns < 2:  # a last sliver of time: one plain implicit step
            self.counters.steps += 1
            last = self.solve_step(system, point, stop_ns - point.t_ns)
            last.global_error = self.estimate.advance((last.t_ns - point.t_ns) / NS, 0.0, 0.0, 0.0, last.mode == 0)
            return [last]
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
            impulse = self._impulse_misses(point, mid, end)
            err = max(self._error(point, full, end), self._interpolation_error(point, mid, end, h_ns),
                      max(map(abs, impulse)) / (self.tol * self._v_scale or 1.0))
            end.est_error = mid.est_error = abs(full.v - end.v)  # m/s: step doubling's v estimate
            # local error ~ h^3 for a ramped step, h^2 for a held one
            factor = 0.9 * max(err, 1e-12) ** (-1.0 / 3.0 if full.ramped else -0.5)
            if err <= 1.0 or h_ns <= 2 * self.min_ns:
                self.counters.forced += err > 1.0
                self.counters.steps += 2
                self.h_ns = int(min(max(h_ns * min(factor, 4.0), self.min_ns), self.max_ns))
                self._carry_error(point, full, mid, end, impulse)
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
        h = h_ns / NS
        v_mid = hermite_mid(start.v, end.v, *velocity_slopes(start, end), h)
        x_mid = hermite_mid(start.x, end.x, start.v, end.v, h)
        error = max(abs(v_mid - mid.v) / (16 * self.tol * self._v_scale or 1.0),
                    abs(x_mid - mid.x) / (16 * self.tol * self._x_scale or 1.0))
        if (start.mode != 0 and start.mode == mid.mode == end.mode
                and self._grazes(start, mid, end, h, self.tol * self._v_scale)):
            error = max(error, 4.0)  # halve: the step may hide a stick or a reversal
        return error

    @staticmethod
    def _grazes(start: Point, mid: Point, end: Point, h: float, margin: float) -> bool:
        """Slipping one way at both ends and the middle, does the interpolated relative
        velocity of either half cross 0 by more than margin [m/s] in between? (dv grazing 0
        between communication points is a stick, or a reversal, that the step would miss;
        a crossing within the tolerance is not worth a smaller step.)"""
        for a, b in ((start, mid), (mid, end)):
            for s in (0.25, 0.5, 0.75):
                dv = (hermite(a.V, b.V, a.aX, b.aX, 0.5 * h, s)
                      - hermite(a.v, b.v, a.a, b.a, 0.5 * h, s))
                if dv * start.mode < -margin:
                    return True
        return False

    def root_tolerance(self) -> float:
        return self.root_tol_fraction * self.tol * self._v_scale

    def _impulse_misses(self, start: Point, *ends: Point) -> list[float]:
        """How far [m/s] the block's velocity after each of these steps is off because the
        force ramp it felt has another mean than the friction's own mean force along the
        step (reported by a friction with internal state); signed, computed less exact.

        A lubricant that re-solidifies while dv passes 0 grips the block for a fraction of a
        step: the force peaks inside the step and is back to nothing at its ends, so the
        ends (all that step doubling compares) miss it. Its impulse does not."""
        misses, previous = [], start
        for end in ends:
            miss = 0.0
            if end.mode != 0 and end.F_mean == end.F_mean and end.f != 0.0:
                h = (end.t_ns - previous.t_ns) / NS
                felt = end.F_start + 0.5 * end.F_rate * h
                miss = (felt - end.F_mean) * h * self.velocity_per_impulse
            misses.append(miss)
            previous = end
        return misses

    def _carry_error(self, start: Point, full: Point, mid: Point, end: Point, impulse: list[float]) -> None:
        """Carry the global error estimate over the accepted halves (see master/estimate.py):
        their local error is step doubling's difference over 2^p - 1 (p = 2 ramped, 1 held),
        shared between the halves, plus each half's impulse miss."""
        share = 0.5 / (3.0 if full.ramped else 1.0)
        local_x, local_v = share * (full.x - end.x), share * (full.v - end.v)
        # the friction's slope over the mass, from the loop gain: (h/M) c held, (h/2M) c ramped
        damping = self.loop_gain / self.loop_gain_step * (2.0 if full.ramped else 1.0)
        h = (mid.t_ns - start.t_ns) / NS
        estimate = self.estimate
        for point, miss in zip((mid, end), impulse):
            estimate.observe(point.x, point.a, point.F, self.velocity_per_impulse, 1e-3 * self._x_scale)
            point.global_error = estimate.advance(h, damping if point.mode != 0 else 0.0, local_x,
                                                  local_v + miss, point.mode == 0)

    def _error(self, start: Point, full: Point, halves: Point) -> float:
        """The step's error relative to what tol allows: the difference between one step
        and two halves in v and x, measured against the block's own motion so far (its
        largest |v| and |x|, or the step's own values while the motion grows).

        A friction with an internal state (f, the lubricant's excess volume) is also held
        to tol in the force it produces, against the largest |F| so far: f's error matters
        only through F, and it does matter, because f carries it forward where it creeps
        toward melting. (f itself is a poor measure: once molten its value does not enter
        F at all, while solid its small drift decides when it melts.) A law without state
        (f = 0) is not: its force jumps at stick and slip by design.
        """
        # Floored at 1e-6 of the scene's scales: from complete rest the motion so far is
        # round-off, and no step would pass.
        self._v_scale = max(self._v_scale, abs(halves.v), abs(full.v), 1e-6 * self.scales.velocity)
        self._x_scale = max(self._x_scale, abs(halves.x), abs(full.x), 1e-6 * self.scales.position)
        error = max(abs(full.v - halves.v) / (self.tol * self._v_scale or 1.0),
                    abs(full.x - halves.x) / (self.tol * self._x_scale or 1.0))
        if full.f != 0.0 or halves.f != 0.0:
            self._F_scale = max(self._F_scale, abs(halves.F), abs(full.F))
            error = max(error, abs(full.F - halves.F) / (self.tol * self._F_scale or 1.0))
            self._f_scale = max(self._f_scale, abs(halves.f), abs(full.f))
            error = max(error, abs(full.f - halves.f) / (self.tol * self._f_scale or 1.0))
        return error


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
