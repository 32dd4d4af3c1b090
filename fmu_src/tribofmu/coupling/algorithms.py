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
- ``adaptive``: the implicit step under error control, one solve per step: an embedded
  estimate (the coupling force predicted from the last steps against the one the solve
  found) rejects and retries steps that miss the tolerance, so steps shrink at stick/slip
  transitions and melting, grow elsewhere (coupling/embedded.py).
- ``doubling``: the same under step doubling (one step against two halves: three solves per
  two accepted steps), the adaptive coupling before issue 31, kept for comparison.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
import math
from dataclasses import asdict, dataclass

from ..physics.stepsize import COUPLING_STEPS
from .contact import BlockSlope, ImplicitStep, StickJacobian, RetryHeld, StepSettings, slip_mode
from .estimate import GlobalErrorEstimate
from .interpolation import NS, hermite, hermite_mid, velocity_slopes
from .system import Contact, CoupledSystem, Point, States

# The "zero" relative velocity, as a fraction of the scene's velocity scale: |dv| within it
# counts as stuck. Far below any velocity error the error control resolves (the root
# tolerance is 1e-3 of the per-step tolerance's share of |v|), far above v's round-off.
ZERO_VELOCITY = 1e-10
# A step's error is measured against the block's own motion: its largest |v| and |x| so far,
# floored at this fraction of the scene's scales (from complete rest the motion is round-off,
# and no step would pass).
SCALE_FLOOR = 1e-6
# The smallest and largest step, as fractions of the scene's period: 1e-7 T resolves any
# event the kinetics can produce; T/20 keeps the drive's own cosine resolved.
MIN_STEP_PERIODS, MAX_STEP_PERIODS = 1e-7, 1.0 / 20.0
# An event (a breakaway) this early in a step, as a fraction of it, is not landed on: the
# step is accepted with the event inside (its own error estimate judges it).
MIN_LANDING_FRACTION = 0.01
# w2 is learned only from points whose |x| is beyond this fraction of the largest |x| so far:
# nearer the spring's rest a = F/M - w2 x divides round-off by x.
W2_POSITION_FLOOR = 1e-3
# How much smaller than its allowance a grazing step's error is treated: > 1 rejects it (dv
# dips past 0 between communication points: a stick or a reversal the step would pass over).
GRAZING_ERROR = 4.0
# Where between two communication points the interpolated relative velocity is checked for a
# crossing of 0 (quarters: a dip shorter than a quarter step is below the step's resolution).
GRAZING_SAMPLES = (0.25, 0.5, 0.75)


@dataclass
class Magnitudes:
    """The largest |v| [m/s], |x| [m], |F| [N], |f| [1] of the accepted points so far: what a
    step's error is measured against. Updated only when a step is accepted (:meth:`accept`)."""

    v: float = 0.0
    x: float = 0.0
    F: float = 0.0
    f: float = 0.0

    def accept(self, point: Point) -> None:
        self.v, self.x, self.F = max(self.v, abs(point.v)), max(self.x, abs(point.x)), max(self.F, abs(point.F))
        self.f = max(self.f, abs(point.f))


@dataclass
class Counters:
    steps: int = 0  # accepted communication steps
    rejected: int = 0  # steps rolled back for their error and retried smaller
    landed: int = 0  # steps rolled back to end where the contact broke away inside them
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

    def finish(self, system: CoupledSystem) -> None:
        """Called once after the last step (or a failure): release what the algorithm holds."""

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
        new = Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F_start, mode=slip_mode(V - v, 0.0))
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
    # A slip going on is sought with the friction stepped from its first trial while the law has
    # not stuck (contact.ImplicitStep.stepped_slip): on fig6 29 -> 23 FMU calls a step.
    stepped_trials = True

    def __init__(self, step=None, tol=None):
        super().__init__(step, tol)
        self.loop_gain = 0.0  # |d(block dv)/dF * dF/d(dv)| of the last slip step ...
        self.loop_gain_step = 1.0  # ... whose length this was [s]
        self.velocity_per_impulse = 0.0  # [m/s / (N s)] the block's, last measured (0: not yet)
        self.stick_bounds = None  # [N] (low, high): the friction's force range at the last stick
        # the block's slope in its end force last measured, held (False) and ramped (True):
        # a cache of the solves' own measurements (see contact.BlockSlope), not state
        self.block_slopes: dict[bool, BlockSlope] = {}
        self.stick_jacobian: StickJacobian | None = None  # the last stick ramp's (see contact.StickJacobian)

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

    # What the algorithm carries from step to step besides its settings (tol, step) and what
    # prepare() derives from the scales: its saved state (a pair FMU's FMU state) is these.
    state_names = ("loop_gain", "loop_gain_step", "velocity_per_impulse")

    def export_state(self) -> dict:
        """The algorithm's state as plain values (JSON-able; floats round-trip exactly)."""
        state = {name: getattr(self, name) for name in self.state_names}
        state["scales"] = [self.scales.position, self.scales.velocity, self.scales.period]
        state["counters"] = asdict(self.counters)
        # (they seed the next solve's first guesses: its root lands within its tolerance
        # elsewhere without them, so a continued run would differ in the last digits)
        state["block_slopes"] = [list(slope) for slope in self.block_slopes.values()]
        state["stick_jacobian"] = list(self.stick_jacobian) if self.stick_jacobian is not None else None
        return state

    def import_state(self, state: dict) -> None:
        """Continue from :meth:`export_state`'s values (call after prepare(), which it
        overrides); a state without one of the names is refused (another format)."""
        missing = {*self.state_names, "scales", "counters", "block_slopes", "stick_jacobian"} - set(state)
        if missing:
            raise ValueError(f"{self.name} state lacks {', '.join(sorted(missing))}")
        for name in self.state_names:
            setattr(self, name, state[name])
        self.scales = Scales(*state["scales"])
        self.counters = Counters(**state["counters"])
        slopes = [BlockSlope(*slope) for slope in state["block_slopes"]]
        self.block_slopes = {slope.ramp: slope for slope in slopes}
        jacobian = state["stick_jacobian"]
        self.stick_jacobian = StickJacobian(*jacobian) if jacobian is not None else None

    def _solve(self, system, point, saved, h_ns, drive, ramp) -> Point | RetryHeld:
        """One ImplicitStep; keeps what it measured (the loop gain, the block's response)."""
        h = h_ns / NS
        settings = StepSettings(self.expected_gain(h), self.max_ramp_gain, self.root_tolerance(),
                                ZERO_VELOCITY * self.scales.velocity, self.max_iterations, self.scales.position,
                                stepped_trials=self.stepped_trials and self.stick_bounds is None)
        step = ImplicitStep(settings, system, point, saved, h_ns, drive, ramp, self.block_slopes.get(ramp),
                            self.stick_jacobian)
        new = step.solve()
        report = step.report
        self.counters.iterations += report.iterations
        self.counters.stick_steps += report.stuck and not isinstance(new, RetryHeld)
        if report.loop_gain is not None:
            self.loop_gain, self.loop_gain_step = report.loop_gain, h
        if report.velocity_per_impulse is not None:
            self.velocity_per_impulse = report.velocity_per_impulse
        if report.bounds is not None:
            self.stick_bounds = report.bounds
        if report.block_slope is not None:  # (of the family the step ended in: it may go on held)
            self.block_slopes[report.block_slope.ramp] = report.block_slope
        if report.stick_jacobian is not None:
            self.stick_jacobian = report.stick_jacobian
        return new

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
            if end.mode.slipping and end.F_mean is not None and end.f != 0.0:
                h = (end.t_ns - previous.t_ns) / NS
                felt = end.F_start + 0.5 * end.F_rate * h
                miss = (felt - end.F_mean) * h * self.velocity_per_impulse
            misses.append(miss)
            previous = end
        return misses

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        new = self.solve_step(system, point, h_ns)
        self.counters.steps += 1
        return [new]

    def solve_step(self, system: CoupledSystem, point: Point, h_ns: int, ramp_allowed: bool = True,
                   saved: States | None = None) -> Point:
        """One implicit step of h_ns from point; leaves every slave at the new point.

        ramp_allowed=False holds the force over the step even where a ramp would do. saved:
        the slaves' states at point when the caller holds them already (the step restores the
        block and friction from them and frees nothing); else the step saves and frees its own."""
        t, h = point.t_ns / NS, h_ns / NS
        drive = system.step_drive(t, h)
        if system.friction is None:
            x, v, a = system.step_block(0.0, 0.0, t, h)
            new = Point(point.t_ns + h_ns, *drive, x, v, a, mode=slip_mode(drive[1] - v, 0.0))
        else:
            own = saved is None
            saved = system.save(system.block, system.friction) if own else system.loop_states(saved)
            try:
                # Second order where the force is smooth: while the contact keeps slipping the
                # same way, the block feels a ramp from the force at the step's start to the
                # one at its end (trapezoidal coupling). Where the loop is stiff the ramp would
                # ring, and at stick or reversal the force jumps: there the force is held.
                ramp = (ramp_allowed and self.second_order and Contact(point.mode).slipping
                        and self.expected_gain(h) < self.max_ramp_gain)
                new = self._solve(system, point, saved, h_ns, drive, ramp)
                if isinstance(new, RetryHeld):  # the ramp met stiffness or a transition
                    system.restore(saved)
                    new = self._solve(system, point, saved, h_ns, drive, False)
            finally:
                if own:
                    system.free(saved)
        system.finish_step(point, new, t, h)
        return new


class ErrorControlledCoupling(ImplicitCoupling):
    """What every error-controlled implicit coupling shares: the step-size bounds, the
    motion's magnitudes its errors are measured against (known, floored by the scene's
    scales, before the first step), the global error estimate, and the accept / reject /
    land bookkeeping (:meth:`_landed`, :meth:`_accepted`). Subclasses estimate the errors."""

    default_tol = 2e-4  # per-step error against the block's own motion, when nothing chooses it (tribofmu.checked does for simulate)
    default_step = 1e-4  # first try [s]
    controller = COUPLING_STEPS
    # h_ns is kept a multiple of this [ns] (step doubling: two equal halves)
    step_granularity = 1
    state_names = ImplicitCoupling.state_names + ("h_ns", "rejected_last", "accepted_error")

    def prepare(self, system, scales):
        super().prepare(system, scales)
        self._held = None  # (point, system, the slaves' states there): see states_at
        g = self.step_granularity
        self.min_ns = max(g, int(scales.period * MIN_STEP_PERIODS * NS) // g * g)
        self.max_ns = max(self.min_ns, int(scales.period * MAX_STEP_PERIODS * NS) // g * g)
        self.h_ns = min(max(self.step_ns // g * g, self.min_ns), self.max_ns)
        self.estimate = GlobalErrorEstimate()
        self.magnitudes = Magnitudes()
        self.rejected_last = False  # the last step was rejected (its successor may not grow)
        self.accepted_error = 1.0  # the last accepted step's error ratio (the controller's PI term)

    def export_state(self) -> dict:
        state = super().export_state()
        state["estimate"] = [self.estimate.ex, self.estimate.ev, self.estimate.w2]
        state["magnitudes"] = asdict(self.magnitudes)
        return state

    def import_state(self, state: dict) -> None:
        missing = {"estimate", "magnitudes"} - set(state)
        if missing:
            raise ValueError(f"{self.name} state lacks {', '.join(sorted(missing))}")
        super().import_state(state)
        self.estimate.ex, self.estimate.ev, self.estimate.w2 = state["estimate"]
        self.magnitudes = Magnitudes(**state["magnitudes"])

    # -- scales: pure, from the accepted points' magnitudes and the scene's floor ------------
    def velocity_scale(self, *points: Point) -> float:
        return max(self.magnitudes.v, *(abs(p.v) for p in points), SCALE_FLOOR * self.scales.velocity)

    def position_scale(self, *points: Point) -> float:
        return max(self.magnitudes.x, *(abs(p.x) for p in points), SCALE_FLOOR * self.scales.position)

    def root_tolerance(self) -> float:
        return self.root_tol_fraction * self.tol * self.velocity_scale()

    # -- the bookkeeping of one tried step ---------------------------------------------------
    def states_at(self, system: CoupledSystem, point: Point) -> States:
        """Every slave's state at point, saved once however many tries a step from it takes
        (a rejected or landed try restores them and the next try starts from the same point
        object); the next point's are saved over the point before's (freed by :meth:`finish`)."""
        held = self._held
        if held is not None and held[0] is point and held[1] is system:
            return held[2]
        if held is not None and held[1] is system:
            states = system.save_over(held[2])
        else:
            self.finish(system)
            states = system.save()
        self._held = (point, system, states)
        return states

    def finish(self, system: CoupledSystem) -> None:
        held, self._held = getattr(self, "_held", None), None
        if held is not None:
            held[1].free(held[2])

    def _landed(self, system: CoupledSystem, start: States, h_ns: int, event: float) -> bool:
        """A stuck contact broke away at the fraction event of the tried step of h_ns: when
        the landing is worth a step of its own, roll back and make it the next try (True)."""
        g = self.step_granularity
        landing = int(h_ns * event) // g * g
        if event < 1.0 and landing >= max(g * self.min_ns, MIN_LANDING_FRACTION * h_ns):
            system.restore(start)
            self.counters.landed += 1
            self.h_ns = landing
            return True
        return False

    def _accepted(self, system: CoupledSystem, start: States, h_ns: int, error: float, order: int,
                  min_ns: int, steps: int) -> bool:
        """Accept the tried step of h_ns (``steps`` communication steps) when its error ratio
        is <= 1 or it is no longer than min_ns, else roll back to start; either way the next
        try's length follows from the controller (local error ~ h^(order + 1))."""
        factor = self.controller.factor(error, order, self.rejected_last, self.accepted_error)
        if error <= 1.0 or h_ns <= min_ns:
            self.counters.forced += error > 1.0
            self.counters.steps += steps
            self.rejected_last = False
            self.accepted_error = error
            self.h_ns = int(min(max(h_ns * factor, self.min_ns), self.max_ns)) // self.step_granularity \
                * self.step_granularity
            return True
        system.restore(start)
        self.counters.rejected += 1
        self.rejected_last = True
        self.h_ns = max(int(h_ns * factor), self.min_ns) // self.step_granularity * self.step_granularity
        return False


class StepDoublingCoupling(ErrorControlledCoupling):
    """Implicit steps under error control by step doubling (the adaptive coupling before
    issue 31; registered as ``doubling`` for comparison, see coupling/embedded.py).

    tol is relative: a step is accepted when one step and two half steps differ by less
    than tol times the block's own motion (its largest |v| and |x|) in x and v, and, for a
    friction with an internal state, by tol times the largest |F| and |f| in F and f.
    """

    name = "doubling"
    step_granularity = 2

    def advance(self, system, point, stop_ns):
        h_ns = min(self.h_ns, stop_ns - point.t_ns)
        if h_ns < 2 * self.min_ns and stop_ns - point.t_ns > h_ns:
            h_ns = min(2 * self.min_ns, stop_ns - point.t_ns)
        h_ns -= h_ns & 1  # two equal halves in integer nanoseconds
        if h_ns < 2:  # a last sliver of time: one plain implicit step
            self.counters.steps += 1
            last = self.solve_step(system, point, stop_ns - point.t_ns)
            last.global_error = self.estimate.advance((last.t_ns - point.t_ns) / NS, 0.0, 0.0, 0.0,
                                                      last.mode.stuck)
            self.magnitudes.accept(last)
            return [last]
        start = system.save()
        try:
            # the full step and the first half start where start was saved: they restore
            # from it instead of saving the block and friction again (2 saves and 2 frees less)
            full = self.solve_step(system, point, h_ns, saved=start)
            if self._landed(system, start, h_ns, full.event):
                return []
            system.restore(start)
            # The halves hold the force where the full step did: an estimate comparing a
            # ramped with a held step would measure the held step's first-order error.
            mid = self.solve_step(system, point, h_ns // 2, full.ramped, saved=start)
            end = self.solve_step(system, mid, h_ns // 2, full.ramped)
            impulse = self._impulse_misses(point, mid, end)
            v_scale = self.velocity_scale(full, end)
            err = max(self._error(point, full, end), self._interpolation_error(point, mid, end, h_ns),
                      max(map(abs, impulse)) / (self.tol * v_scale))
            end.est_error = mid.est_error = abs(full.v - end.v)  # m/s: step doubling's v estimate
            # local error ~ h^3 for a ramped step (order 2), h^2 for a held one (order 1)
            if not self._accepted(system, start, h_ns, err, 2 if full.ramped else 1, 2 * self.min_ns, 2):
                return []
            self._carry_error(point, full, mid, end, impulse)
            self.magnitudes.accept(mid)
            self.magnitudes.accept(end)
            return [mid, end]
        finally:
            system.free(start)

    # A cubic Hermite over the whole step misses its midpoint 16 times more than over either
    # half (error ~ h^4): the halves' interpolants are held to tol by allowing the whole
    # step's 16 tol.
    HALVES_INTERPOLATION = 16.0

    def _interpolation_error(self, start: Point, mid: Point, end: Point, h_ns: int) -> float:
        """How far cubic Hermite interpolation over the whole step misses the computed
        midpoint, relative to tol: results are sampled between communication points, and
        this bounds that error."""
        h = h_ns / NS
        v_mid = hermite_mid(start.v, end.v, *velocity_slopes(start, end), h)
        x_mid = hermite_mid(start.x, end.x, start.v, end.v, h)
        v_scale, x_scale = self.velocity_scale(mid, end), self.position_scale(mid, end)
        error = max(abs(v_mid - mid.v) / (self.HALVES_INTERPOLATION * self.tol * v_scale),
                    abs(x_mid - mid.x) / (self.HALVES_INTERPOLATION * self.tol * x_scale))
        if (start.mode.slipping and start.mode == mid.mode == end.mode
                and (grazes(start, mid, 0.5 * h, self.tol * v_scale) or grazes(mid, end, 0.5 * h, self.tol * v_scale))):
            error = max(error, GRAZING_ERROR)  # halve: the step may hide a stick or a reversal
        return error

    def _carry_error(self, start: Point, full: Point, mid: Point, end: Point, impulse: list[float]) -> None:
        """Carry the global error estimate over the accepted halves (see coupling/estimate.py):
        their local error is step doubling's difference over 2^p - 1 (p = 2 ramped, 1 held),
        shared between the halves, plus each half's impulse miss and, for a friction with
        internal state, the difference of the friction's own impulse over one step and two."""
        share = 0.5 / (3.0 if full.ramped else 1.0)
        local_x, local_v = share * (full.x - end.x), share * (full.v - end.v)
        # A lubricant that melts or re-solidifies inside the step moves the friction's own
        # impulse (its mean force times h) by what the event's timing is off; the block felt
        # the ramp between the ends, so its v does not show that. One step and two halves
        # deliver different impulses then: their difference, not divided by 2^p - 1 (an event
        # inside a step makes it first order), is the impulse error carried on.
        h_full = (end.t_ns - start.t_ns) / NS
        if (end.mode.slipping and end.f != 0.0
                and None not in (full.F_mean, mid.F_mean, end.F_mean)):
            event = (full.F_mean - 0.5 * (mid.F_mean + end.F_mean)) * h_full * self.velocity_per_impulse
            impulse = [miss + 0.5 * event for miss in impulse]
        # the friction's slope over the mass, from the loop gain: (h/M) c held, (h/2M) c ramped
        damping = self.loop_gain / self.loop_gain_step * (2.0 if full.ramped else 1.0)
        h = (mid.t_ns - start.t_ns) / NS
        x_scale, v_scale = self.position_scale(full, mid, end), self.velocity_scale(full, mid, end)
        estimate = self.estimate
        for point, miss in zip((mid, end), impulse):
            estimate.observe(point.x, point.a, point.F, self.velocity_per_impulse, W2_POSITION_FLOOR * x_scale)
            point.global_error = estimate.advance(h, 0.0 if point.mode.stuck else damping, local_x,
                                                  local_v + miss, point.mode.stuck, x_scale, v_scale)

    def _error(self, start: Point, full: Point, halves: Point) -> float:
        """The step's error relative to what tol allows (pure: nothing is stored): the
        difference between one step and two halves in v and x, measured against the block's
        own motion (its largest |v| and |x| so far, or the step's own values while the motion
        grows).

        A friction with an internal state (f, the lubricant's excess volume) is also held
        to tol in the force it produces, against the largest |F| so far: f's error matters
        only through F, and it does matter, because f carries it forward where it creeps
        toward melting. (f itself is a poor measure: once molten its value does not enter
        F at all, while solid its small drift decides when it melts.) A law without state
        (f = 0) is not: its force jumps at stick and slip by design.
        """
        v_scale, x_scale = self.velocity_scale(halves, full), self.position_scale(halves, full)
        error = max(abs(full.v - halves.v) / (self.tol * v_scale), abs(full.x - halves.x) / (self.tol * x_scale))
        if full.f != 0.0 or halves.f != 0.0:
            F_scale = max(self.magnitudes.F, abs(halves.F), abs(full.F)) or 1.0
            f_scale = max(self.magnitudes.f, abs(halves.f), abs(full.f)) or 1.0
            error = max(error, abs(full.F - halves.F) / (self.tol * F_scale),
                        abs(full.f - halves.f) / (self.tol * f_scale))
        return error


def grazes(start: Point, end: Point, h: float, margin: float) -> bool:
    """Slipping one way at both ends of a step of h [s], does the interpolated relative
    velocity cross 0 by more than margin [m/s] in between? (A stick or a reversal that the
    step would pass over; a crossing within the tolerance is not worth a smaller step.)"""
    direction = start.mode.direction
    for s in GRAZING_SAMPLES:
        dv = hermite(start.V, end.V, start.aX, end.aX, h, s) - hermite(start.v, end.v, start.a, end.a, h, s)
        if dv * direction < -margin:
            return True
    return False


ALGORITHMS = {
    "jacobi": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=False),
    "gauss-seidel": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=True),
    "implicit": ImplicitCoupling,
    "doubling": StepDoublingCoupling,
    "adaptive": lambda step=None, tol=None: __getattr__("AdaptiveCoupling")(step=step, tol=tol),
}


def make_algorithm(name: str, step: float | None = None, tol: float | None = None) -> CouplingAlgorithm:
    """The algorithm registered under name; raises ValueError naming the known ones."""
    try:
        factory = ALGORITHMS[name]
    except KeyError:
        raise ValueError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})") from None
    return factory(step=step, tol=tol)


def __getattr__(name: str):
    """``AdaptiveCoupling``: the adaptive coupling (one implicit solve per step, an embedded
    error estimate, :class:`~.embedded.EmbeddedCoupling`), which builds on the classes above:
    imported on first use, so that either module may be imported first."""
    if name == "AdaptiveCoupling":
        from .embedded import EmbeddedCoupling

        return EmbeddedCoupling
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
