"""The contact state machine of one implicit step: classify, then solve.

The friction pair is in one of three contact modes over a step, and before its first step
in none yet (as Modelica's ``PartialFriction`` starts ``Unknown``):

    UNKNOWN  --first step-->  STUCK | FORWARD | BACKWARD
    FORWARD/BACKWARD  --dv reaches 0 inside the step-->  STUCK       (stick onset)
    STUCK  --the force needed to stay stuck leaves the friction's bounds-->  slip (breakaway)
    FORWARD <--> BACKWARD   (a reversal passes through one stuck step, or none for a law
                             without a jump at dv = 0)

One step (:class:`ImplicitStep`) first *classifies* the step from the friction at +-delta
(or from the slip it predicts), then runs the solver of that mode: the slip root, the
stick force, or the stick ramp. A ramped step (the force ramping over the step) that meets
stiffness, a stick or a reversal ends in the explicit outcome :data:`RETRY_HELD`: the caller
rolls back and solves the step again with the force held. The step reports what it measured
(:class:`StepReport`: loop gain, the block's velocity per unit impulse, evaluations) instead
of writing into the algorithm.

The loop function H(dv) = (the block's relative velocity after the step under the friction
at dv) - dv is decreasing, so the coupled answer is its single root, found on a bracket; on
the jump of a discontinuous law (dry friction at dv = 0) there is no root: the blocks are
stuck and the force is the one that keeps dv = 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from ..physics.roots import illinois
from .interpolation import NS, hermite
from .system import Contact, CoupledSystem, Point, States


def slip_mode(dv: float, delta: float) -> Contact:
    """The mode of a relative velocity dv [m/s] with |dv| <= delta [m/s] counted as stuck."""
    return Contact((dv > delta) - (dv < -delta))


@dataclass(frozen=True)
class RetryHeld:
    """The outcome of a ramped step that cannot stay ramped (why: stiff, stuck, reversing)."""

    why: str


RETRY_HELD_STIFF = RetryHeld("the loop is too stiff to ramp the force")
RETRY_HELD_TRANSITION = RetryHeld("the contact sticks or reverses inside the step")


class FrictionAnswer(NamedTuple):
    """The friction's latest answer: at the relative velocity dv [m/s], the force F [N], the
    state f [1], and its mean force over the step [N] (None for a trial, which does not step)."""

    dv: float
    F: float
    f: float
    F_mean: float | None


class Probe(NamedTuple):
    """The held step under the friction at +-delta: that force [N], the relative velocity
    dv [m/s] and the position x [m] the block answered with at the step's end, and the
    relative acceleration d(dv)/dt [m/s^2] there."""

    F: float
    dv: float
    x: float
    dv_slope: float


class BlockAnswer(NamedTuple):
    """The block's state at the step's end under the force F0 + rate s (F_end at the end)."""

    F_end: float  # N
    x: float  # m
    v: float  # m/s
    a: float  # m/s^2
    F0: float  # N
    rate: float  # N/s


# The block's answer to the force is affine in it (a linear block: a mass on springs), and the
# loop function's iterates differ only in the force: from two real steps under two forces of
# one family (held, or ramped from the step's start force) the block's answer to a third is
# their affine combination, without a step. The final force is always stepped for real and the
# model checked against it: a block that is not affine (to this many root tolerances) is
# stepped for every iterate instead.
MODEL_MISS_TOLERANCE = 1.0
# End forces this close (relative) are one force to the block's model: two real answers a few
# ulps apart differ by round-off, and an affine model through them extrapolates round-off
# (a Stribeck force at its floor, 6.0 and 6.000000000000001 N: a slip root where the block
# sticks).
SAME_FORCE_RTOL = 1e-12
# A slip step's first real block step plus the block's slope d(v, x, a)/dF_end [per N] from the
# last step of the same family (held or ramped) model its answer to the other forces the root
# tries: one real trial instead of two. The slope of a linear block depends on the step alone;
# from another step length it is scaled by h (v) and h^2 (x), the leading terms of a mass's
# response (h/M held, h/2M ramped; h^2/2M, h^2/6M), exact as h -> 0: off by O(w2 h^2) of the
# slope, which the final real step's check (MODEL_MISS_TOLERANCE) catches, and the step then
# models from its two real answers instead.
class BlockSlope(NamedTuple):
    """The block's response to its end force over a step of ``h_ns`` [ns] held or ramped
    (``ramp``): d v/dF_end [m/s/N], d x/dF_end [m/N], d a/dF_end [m/s^2/N]."""

    h_ns: int
    ramp: bool
    v: float
    x: float
    a: float

    def scaled(self, h_ns: int) -> "BlockSlope":
        r = h_ns / self.h_ns
        return BlockSlope(h_ns, self.ramp, self.v * r, self.x * r * r, self.a)


class StickJacobian(NamedTuple):
    """A stuck step's block response over ``h_ns`` [ns] to the force F0 + rate s: d dv_end/dF0
    [m/s/N], d x_end/dF0 [m/N], d (d(dv)/dt)_end/dF0 [1/(kg)] (held), and d dv_end/d rate,
    d x_end/d rate [per N/s]. Affine for a linear block and a function of the step alone: the
    next stuck step of the same length models its second probe and starts the stick ramp's
    Newton from it instead of measuring it again (two real block steps fewer)."""

    h_ns: int
    d_F: float
    x_F: float
    slope_F: float
    d_r: float
    x_r: float


# The stick onset inside a step is located to this fraction of the step (1 ns in a 1 s step:
# below the integer-nanosecond time grid of any step the controller takes).
STICK_ONSET_XTOL = 1e-9
# The stick ramp's Newton iterations on (dv, x) with secant slopes: the block's answer is
# affine in (F0, rate), so two or three converge; more means the block is not linear.
STICK_RAMP_ITERATIONS = 8
# The stick ramp keeps x on the drive to this fraction of the scene's position scale
# (round-off of x, ~1e-16 relative, times the few operations of one step).
STICK_RAMP_POSITION_TOL = 1e-12
# Aiming at the slip root with the last step's loop gain, the first iterate is placed this
# fraction beyond the aim, so that it brackets the root when the gain is a little off.
ROOT_AIM_BEYOND = 0.05


@dataclass
class StepReport:
    """What one step measured, for the algorithm to keep or drop (a rolled-back step's
    measurements are still good measurements of the system)."""

    loop_gain: float | None = None  # |d(block dv)/dF * dF/d(dv)| of a slip step
    velocity_per_impulse: float | None = None  # [m/s / (N s)] the block's (1/M for a lone mass)
    iterations: int = 0  # evaluations of the coupling loop
    stuck: bool = False
    bounds: tuple[float, float] | None = None  # [N] the friction's force range at dv = 0 (stuck steps)
    block_slope: BlockSlope | None = None  # measured from two real block steps of one family
    stick_jacobian: StickJacobian | None = None  # measured by a stick ramp


@dataclass(frozen=True)
class StepSettings:
    """How one step solves: ``expected_gain`` the loop gain a slip step of this length should
    meet (0: unknown), ``max_ramp_gain`` above which a ramp would ring, ``root_tol`` [m/s]
    how far the slip root may miss, ``delta`` [m/s] the "zero" relative velocity,
    ``max_iterations`` of any iteration, ``position_scale`` [m] for the stick ramp's fit;
    ``stepped_trials``: a slip going on is sought with the friction stepped from its first
    trial (:meth:`ImplicitStep.stepped_slip`), for a law that has not stuck."""

    expected_gain: float
    max_ramp_gain: float
    root_tol: float
    delta: float
    max_iterations: int
    position_scale: float
    stepped_trials: bool = False


class ImplicitStep:
    """The solve of one implicit step: from ``point`` over ``h_ns`` with the drive already
    at the step's end (``drive`` = X, V, aX), the block and friction saved in ``saved``."""

    def __init__(self, settings: StepSettings, system: CoupledSystem, point: Point, saved: States,
                 h_ns: int, drive: tuple[float, float, float], ramp: bool,
                 block_slope: BlockSlope | None = None, stick_jacobian: StickJacobian | None = None):
        self.settings, self.system, self.point, self.ramp = settings, system, point, ramp
        self.previous = Contact(point.mode)
        self.h_ns, self.t, self.h = h_ns, point.t_ns / NS, h_ns / NS
        self.X, self.V, self.aX = drive
        self.block_state = [v for v in saved.handles.values() if v[0] is system.block]
        self.friction_state = [v for v in saved.handles.values() if v[0] is system.friction]
        self.delta = settings.delta
        self.root_tol = max(self.delta, settings.root_tol)  # m/s
        self.report = StepReport()
        self.friction_last: FrictionAnswer | None = None  # the friction's latest answer
        # the friction's latest step's answer (its state is at the step's end); None: not
        # stepped since the step's start
        self.stepped_answer: FrictionAnswer | None = None
        self.friction_input = None  # [m/s] the dv the friction holds as its input (None: unknown)
        self.block_last: BlockAnswer | None = None  # the block's latest answer (real or modelled)
        self.block_real: BlockAnswer | None = None  # its latest real step (the FMU stands there)
        self.block_samples: list[BlockAnswer] = []  # real answers under block_under's family of forces
        self.use_model = True  # off once the block turned out not affine in the force
        # the last step's slope of this family, for a model from one real answer (slip solves)
        self.block_slope = block_slope
        self.seed = self.seed_of_family()
        self.seed_allowed = False  # on while a slip root is sought (probes and stick forces step for real)
        self.last_seeded = False  # the latest modelled answer came from one real answer and the seed
        # the last stick ramp's, where it was of this length (exact for a linear block)
        self.stick_jacobian = stick_jacobian if stick_jacobian is not None and stick_jacobian.h_ns == h_ns else None
        self.settled_dv: float | None = None  # [m/s] a slip root found with the friction stepped to it
        self.probes: dict[float, Probe] = {}  # side (+-1.0) -> the held step under the friction at side * delta

    # -- evaluations ----------------------------------------------------------------------
    def friction_at(self, dv: float) -> tuple[float, float]:
        """A trial: F [N], f [1] at the relative velocity dv [m/s] with the friction's state
        where it stands (its output's direct feedthrough; no step)."""
        F, f = self.system.friction_outputs(dv)
        self.friction_last = FrictionAnswer(dv, F, f, None)
        self.friction_input = dv
        return F, f

    def step_friction(self, dv: float) -> None:
        """The friction's step to dv [m/s] at the step's end (from the step's start again if
        it stepped before): its state (the lubricant's f) moves along the way."""
        stepped = self.stepped_answer
        if stepped is not None:
            if stepped.dv == dv:
                self.friction_last = stepped  # (it stands there already)
                return
            self.restore_friction()
        # (the last trial's dv is still the friction's input: no second set)
        F, f, F_mean = self.system.step_friction(dv, self.t, self.h, set_input=dv != self.friction_input)
        self.friction_input = dv
        self.friction_last = self.stepped_answer = FrictionAnswer(dv, F, f, F_mean)

    def restore_friction(self) -> None:
        """The friction back at the step's start (state and input)."""
        for slave, handle in self.friction_state:
            slave.restore(handle)
        self.stepped_answer = self.friction_input = None

    def block_at(self, F0: float, rate: float) -> tuple[float, float]:
        """The block's relative velocity and position after the step under F0 + rate s
        (a real step of the block)."""
        last = self.block_real
        if last is not None:
            for slave, handle in self.block_state:
                slave.restore(handle)
        x, v, a = self.system.step_block(F0, rate, self.t, self.h)
        if last is not None:
            # the block's velocity per unit impulse (1/M for a lone mass), from the secant
            d_impulse = (F0 - last.F0 + 0.5 * (rate - last.rate) * self.h) * self.h
            if d_impulse != 0.0 and v != last.v:
                self.report.velocity_per_impulse = abs((v - last.v) / d_impulse)
        self.block_last = self.block_real = BlockAnswer(F0 + rate * self.h, x, v, a, F0, rate)
        return self.V - v, x

    def block_under(self, F: float, real: bool = False) -> float:
        """The block's relative velocity after the step whose force ends at F: modelled from
        two real steps under other end forces where it can be (:data:`MODEL_MISS_TOLERANCE`),
        else (or with real=True) stepped."""
        F0, rate = (self.point.F, (F - self.point.F) / self.h) if self.ramp else (F, 0.0)
        if not real:
            modelled = self.block_model(F, F0, rate)
            if modelled is not None:
                self.block_last = modelled
                return self.V - modelled.v
        dv = self.block_at(F0, rate)[0]
        # (the end force as the family names it: F0 + rate h can differ from F in the last bit)
        self.block_last = self.block_real = self.block_real._replace(F_end=F)
        self.block_samples.append(self.block_real)
        return dv

    def block_model(self, F: float, F0: float, rate: float) -> BlockAnswer | None:
        """The block's answer to the end force F, affine in it through the last two real
        answers under distinct end forces (None: fewer than two, or the model is off)."""
        samples = self.block_samples
        if not self.use_model or not samples:
            return None
        b = samples[-1]
        if abs(F - b.F_end) <= SAME_FORCE_RTOL * abs(b.F_end):
            # (a law whose force does not move with dv, as dry friction's in slip; a last bit
            # of round-off apart, a second real answer would make a model of round-off)
            self.last_seeded = False
            return b if F == b.F_end else b._replace(F_end=F)
        if len(samples) < 2:
            if self.seed is None or not self.seed_allowed:
                return None
            self.last_seeded = True
            dF, seed = F - b.F_end, self.seed
            return BlockAnswer(F, b.x + seed.x * dF, b.v + seed.v * dF, b.a + seed.a * dF, F0, rate)
        self.last_seeded = False
        spanning = self.spanning_samples()
        if spanning is None:
            return None
        a, b = spanning
        w = (F - a.F_end) / (b.F_end - a.F_end)
        return BlockAnswer(F, a.x + w * (b.x - a.x), a.v + w * (b.v - a.v), a.a + w * (b.a - a.a), F0, rate)

    def block_real_at(self, F: float) -> bool:
        """Leave the block really stepped under the end force F (if its latest answer was
        modelled, or under another force); False if the model had missed the real answer by
        more than MODEL_MISS_TOLERANCE root tolerances (the model is then switched off)."""
        real = self.block_real
        if real is not None and real.F_end == F and self.block_last is real:
            return True
        modelled = self.block_last if self.block_last is not None and self.block_last.F_end == F else None
        seeded = modelled is not None and self.last_seeded
        self.block_under(F, real=True)
        if modelled is not None and abs(modelled.v - self.block_real.v) > MODEL_MISS_TOLERANCE * self.root_tol:
            # a seeded model is off by its slope's scaling: the two real answers model exactly
            # from here; a model from two real answers that misses: the block is not affine
            self.use_model = seeded
            return False
        return True

    def spanning_samples(self) -> tuple[BlockAnswer, BlockAnswer] | None:
        """The real answer farthest in force from the latest one, and the latest (near ones
        amplify the round-off of their difference); None with fewer than two or no spread."""
        samples = self.block_samples
        if len(samples) < 2:
            return None
        b = samples[-1]
        a = max(samples[:-1], key=lambda s: abs(s.F_end - b.F_end))
        if abs(a.F_end - b.F_end) <= SAME_FORCE_RTOL * abs(b.F_end):
            return None
        # More force, more speed: answers whose v differ by round-off (forces of 1e-13 N
        # that differ by 1e-16 N, at a reversal) or the wrong way are no slope (one read
        # -0.05 (m/s)/N, and the next step's modelled trials ran dv out to 1e206 m/s).
        dv = b.v - a.v
        if dv * (b.F_end - a.F_end) <= 0.0 or abs(dv) <= SAME_FORCE_RTOL * max(abs(a.v), abs(b.v)):
            return None
        return a, b

    def measured_slope(self) -> BlockSlope | None:
        """The block's slope from the two real answers farthest apart in force, if any."""
        spanning = self.spanning_samples()
        if spanning is None:
            return None
        a, b = spanning
        dF = b.F_end - a.F_end
        return BlockSlope(self.h_ns, self.ramp, (b.v - a.v) / dF, (b.x - a.x) / dF, (b.a - a.a) / dF)

    def loop(self, dv: float) -> float:
        """H(dv): how far the block's answer is from the assumed dv."""
        self.report.iterations += 1
        F, _ = self.friction_at(dv)
        return self.block_under(F) - dv

    def probe(self, side: float) -> float:
        """H at side * delta, the held step under the friction there (:class:`Probe`); stuck
        before, with the last stick ramp's Jacobian for this step and the other side probed
        already, the block's answer is that probe's moved along the Jacobian (no step)."""
        self.seed_allowed = False  # (the probes measure the friction's bounds and the block for real)
        other, jacobian = self.probes.get(-side), self.stick_jacobian
        if other is None or jacobian is None or self.previous != Contact.STUCK:
            value = self.loop(side * self.delta)
            block = self.block_last
            self.probes[side] = Probe(self.friction_last.F, self.V - block.v, block.x, self.aX - block.a)
            return value
        self.report.iterations += 1
        F, _ = self.friction_at(side * self.delta)
        dF = F - other.F
        probe = Probe(F, other.dv + jacobian.d_F * dF, other.x + jacobian.x_F * dF, other.dv_slope + jacobian.slope_F * dF)
        self.probes[side] = probe
        self.block_last = BlockAnswer(F, probe.x, self.V - probe.dv, self.aX - probe.dv_slope, F, 0.0)
        return probe.dv - side * self.delta

    # -- the machine ----------------------------------------------------------------------
    def solve(self) -> Point | RetryHeld:
        """The new point, or RETRY_HELD where a ramped step turns out stuck, reversing or stiff."""
        classified = self.classify()
        if isinstance(classified, RetryHeld):
            return classified
        mode, slip, event = classified
        if mode == Contact.STUCK:
            event = self.solve_stuck(event)
            if not self.block_real_at(self.block_last.F_end):
                event = self.solve_stuck(event)  # again, every iterate stepped
                self.block_real_at(self.block_last.F_end)
            self.step_friction(0.0)
            f, F_mean = self.friction_last.f, None  # the block felt the stick force, not the friction's
        else:
            dv, gain = slip
            self.report.loop_gain = gain
            if self.ramp and gain >= self.settings.max_ramp_gain:
                return RETRY_HELD_STIFF
            if self.settled_dv != dv:
                dv = self.settle(dv, gain, mode)
            if not self.block_real_at(self.friction_last.F):
                dv = self.settle(dv, gain, mode)  # again, every iterate stepped
                self.block_real_at(self.friction_last.F)
            _, F, f, F_mean = self.friction_last
        self.report.block_slope = self.measured_slope()
        F, x, v, a, F0, F_rate = self.block_last
        return Point(self.point.t_ns + self.h_ns, self.X, self.V, self.aX, x, v, a, F, f, F_start=F0,
                     F_rate=F_rate, mode=mode, event=event, ramped=self.ramp, F_mean=F_mean)

    # Friction steps one slip step may take to settle its root with the state integrated.
    # A law without state needs one; the lubricant, whose f moves the force, two or three.
    max_settle_rounds = 6

    def settle(self, dv: float, gain: float, mode: Contact) -> float:
        """The slip root with the friction's state integrated along the step.

        The trials that found dv held the friction's state at the step's start (its outputs'
        direct feedthrough, no step): stepping the friction to dv integrates the state (the
        lubricant kinetics, the costly part) once, instead of once a trial. Where the state
        moved the force, G(dv) = (the block's answer to the force after the friction stepped
        to dv) - dv is not yet 0: :meth:`secant_rounds` find its root."""
        dv, _, settled = self.secant_rounds(dv, gain, mode.direction, keep_side=True)
        if not settled:
            self.step_friction(dv)
            self.block_under(self.friction_last.F)
        return dv

    def secant_rounds(self, dv: float, gain: float, direction: float,
                      keep_side: bool) -> tuple[float, float, bool]:
        """A secant on G(dv) (see :meth:`settle`), started with the loop's own slope
        -(1 + gain), one friction step an iterate, at most max_settle_rounds. An iterate that
        would leave the slip side (``direction`` * dv <= delta) is pulled back halfway to it
        (keep_side) or ends the rounds. Returns (dv, the gain the secant measured, whether G(dv)
        is within the root tolerance there, the friction stepped to dv)."""
        floor = self.delta
        dv_a = g_a = None
        for _ in range(self.max_settle_rounds):
            self.report.iterations += 1
            self.step_friction(dv)
            g = self.block_under(self.friction_last.F) - dv
            if dv_a is not None and g != g_a:
                measured = -(g - g_a) / (dv - dv_a) - 1.0
                if measured < 0.0 and not keep_side and direction * g < 0.0:
                    # G rises on the way toward delta: a force falling with dv (velocity
                    # weakening, a Stribeck curve) can give G more roots than one there, or
                    # none and a stick; the trials' bracket from delta decides
                    return dv, gain, False
                gain = max(0.0, measured)
            if abs(g) <= self.root_tol:
                return dv, gain, True
            new = dv + g / (1.0 + gain) if dv_a is None or g == g_a else dv - g * (dv - dv_a) / (g - g_a)
            if not min(dv, dv + g) <= new <= max(dv, dv + g):
                # The root lies between dv and the block's answer dv + g (a force that rises
                # with dv brakes the block more beyond dv): a secant through a curving G that
                # leaves it (a gamma = 1 lubricant: 3e159 m/s) steps with the gain instead.
                new = dv + g / (1.0 + gain)
            dv_a, g_a = dv, g
            if not direction * new > floor:
                if not keep_side:
                    return dv, gain, False
                new = 0.5 * (dv + direction * floor)
            dv = new
        return dv, gain, False

    def classify(self) -> tuple[Contact, tuple[float, float] | None, float] | RetryHeld:
        """The step's contact mode, its slip root (dv [m/s], loop gain) when slipping, and the
        fraction of the step at which a stuck contact broke away (1: none)."""
        previous, delta = self.previous, self.delta
        first = -1.0 if previous == Contact.BACKWARD else 1.0
        if previous.slipping and self.settings.expected_gain > 0:
            # (with no loop gain, as for dry friction, the first pass from +-delta is exact)
            slip = self.predicted_slip(first)
            if slip is not None:
                return Contact(int(first)), slip, 1.0
        for side in (first, -first):
            h_side = self.probe(side)
            if side * h_side > 0:  # the block slips past +-delta on this side
                event = 1.0
                if previous == Contact.STUCK and self.point.F_rate != 0.0:
                    # It was stuck, its force ramping toward the bound: it broke away when
                    # the ramp reached the bound, maybe well inside this step.
                    reach = (self.probes[side].F - self.point.F) / (self.point.F_rate * self.h)
                    event = reach if 0.0 < reach < 1.0 else 1.0
                return Contact(int(side)), self.slip_root(side * delta, h_side, side), event
            if self.ramp:
                if not all(sample.rate == 0.0 for sample in self.block_samples):
                    return RETRY_HELD_TRANSITION
                # The ramp's rate was 0 in every real step so far (a force that did not move,
                # as dry friction's in slip): they are the held step's own, so the solve goes
                # on held instead of starting again (which stepped the same probe twice).
                self.hold()
        return Contact.STUCK, None, 1.0

    def hold(self) -> None:
        """Go on as a held step (the force held at its end value) from here."""
        self.ramp = False
        self.seed = self.seed_of_family()

    def seed_of_family(self) -> BlockSlope | None:
        """The last step's block slope, scaled to this step, where it was of this step's
        family (held or ramped); else None."""
        slope = self.block_slope
        return slope.scaled(self.h_ns) if slope is not None and slope.ramp == self.ramp else None

    def solve_stuck(self, event: float) -> float:
        """Stuck at the step's end: the stick ramp (stuck all through), or the stick force
        (it was slipping, or nothing is known before); returns the event fraction."""
        self.report.stuck = True
        F_pos, F_neg = self.probes[1.0].F, self.probes[-1.0].F
        self.report.bounds = (min(F_pos, F_neg), max(F_pos, F_neg))
        previous = self.previous
        if previous == Contact.STUCK:
            event = self.stick_ramp()
        elif previous.slipping:
            # It was slipping and ends stuck: dv reached 0 inside the step, where the
            # block's dv under the slip force (the probe on the slip side) crosses it:
            # the root of its cubic Hermite interpolant (a straight line lands short of a
            # curving dv, and the retried step then lands short again, and again).
            side = -1.0 if previous == Contact.BACKWARD else 1.0
            probe = self.probes[side]
            event = self.stick_onset(probe.dv, probe.dv_slope)
        if event < 1.0 or previous != Contact.STUCK:
            self.stick_force()
        return event

    def stick_onset(self, dv_end: float, slope_end: float) -> float:
        """The fraction of the step at which dv, slipping from the point's dv to dv_end [m/s]
        (past 0) with slopes d(dv)/dt at both ends [m/s^2], reaches 0 (1: it does not)."""
        point, h = self.point, self.h
        dv0, slope0 = point.dv, point.aX - point.a
        if dv0 == dv_end or dv0 * dv_end > 0.0:
            return 1.0

        def dv(s: float) -> float:
            return hermite(dv0, dv_end, slope0, slope_end, h, s)

        return min(1.0, max(0.0, illinois(dv, 0.0, 1.0, dv0, dv_end, xtol=STICK_ONSET_XTOL, rtol=0.0)))

    # -- the solvers ----------------------------------------------------------------------
    def predicted_slip(self, side: float) -> tuple[float, float] | None:
        """Slipping on, as before: start the root search at the predicted dv instead of at
        +-delta, which saves the probe and keeps trial velocities near the answer (a trial
        far beyond it can melt the lubricant: costly, and a detour for the root finder).
        Returns (dv, gain), or None where the prediction does not show slip on this side."""
        point, delta = self.point, self.delta
        # dv moves with the drive's acceleration less the block's; the loop's own answer
        # pulls it back by 1/(1 + gain) (a stiff loop hardly lets dv change).
        guess = point.dv + (point.aX - point.a) * self.h / (1.0 + self.settings.expected_gain)
        if not side * guess > delta:
            return None
        self.seed_allowed = True
        if self.settings.stepped_trials:
            slip = self.stepped_slip(guess, side)
            if slip is not None:
                return slip
        h_guess = self.loop(guess)
        if side * h_guess > 0:  # the root lies beyond the guess: slip confirmed
            return self.slip_root(guess, h_guess, side)
        h_lo = self.probe(side)  # between +-delta and the guess, or no slip at all
        if not side * h_lo > 0:
            return None
        return self.slip_root(side * delta, h_lo, side, guess, h_guess)

    def stepped_slip(self, guess: float, side: float) -> tuple[float, float] | None:
        """Slipping on, for a law that has not stuck: the root sought with the friction stepped
        from the first trial (:meth:`settle`'s rounds from the predicted dv), without the
        trials at the friction's start state. Those find a root that the state's move over the
        step shifts again (a lubricant's f: two or three friction steps followed anyway), and
        each came with a block answer. Returns (dv, gain); None, with the friction back at the
        step's start, where the rounds leave the slip side, see G rise on the way toward delta
        or do not settle (a reversal, a stick: the trials and probes decide).

        (A law that sticks can have a loop function that is not monotone near dv = 0, with a
        root beyond delta that is not the answer: its trials bracket the root first.)"""
        dv, gain, settled = self.secant_rounds(guess, self.settings.expected_gain, side, keep_side=False)
        if settled:
            self.settled_dv = dv
            return dv, gain
        self.restore_friction()
        return None

    def slip_root(self, lo: float, h_lo: float, direction: float, hi: float | None = None,
                  h_hi: float | None = None) -> tuple[float, float]:
        """Root of the decreasing loop function beyond lo (slip in `direction`), on the
        bracket [lo, hi] if given.

        Returns (dv, loop gain): the gain is -(slope of the loop function) - 1, i.e. how
        strongly the block's answer reacts to the assumed dv, measured on the bracket.
        """
        loop, delta, max_iterations = self.loop, self.delta, self.settings.max_iterations
        self.seed_allowed = True  # slip is confirmed: the root's trials may model from one real answer
        if hi is None:
            # Aim at the root with the last step's loop gain; where that falls short, the
            # fixed-point pass from the nearer point lands beyond the root: the friction
            # there is at least as large, so the block answers with a smaller dv.
            gain = self.settings.expected_gain
            for fraction in (((1.0 + ROOT_AIM_BEYOND) / (1.0 + gain), 1.0) if gain > 0 else (1.0,)):
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
        # (a bracket narrower than the "zero" velocity, as when the predicted dv already was
        # the root, measures round-off: keep the gain the step expected)
        if abs(hi - lo) > delta:
            gain = max(0.0, -(h_hi - h_lo) / (hi - lo) - 1.0)
        else:
            gain = self.settings.expected_gain
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
        pos, neg = self.probes[1.0], self.probes[-1.0]
        F_pos, F_neg = pos.F, neg.F
        a, da, b, db = F_neg, neg.dv, F_pos, pos.dv
        if da == db:
            self.block_under(F_pos)
            return F_pos
        F = b
        for _ in range(self.settings.max_iterations):
            F = b - db * (b - a) / (db - da)
            d = self.block_under(F)
            if abs(d) <= self.delta or d == db:
                break
            a, da, b, db = b, db, F, d
        low, high = min(F_neg, F_pos), max(F_neg, F_pos)
        if not low <= F <= high:
            # Round-off past the bound (a step of a few ns, where the probes' dv differ by
            # less than delta): the stick force is the friction's to bound, dv stays within delta.
            F = min(max(F, low), high)
            self.block_under(F)
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
        pos, neg = self.probes[1.0], self.probes[-1.0]
        F_pos, d_pos, x_pos, F_neg, d_neg, x_neg = pos.F, pos.dv, pos.x, neg.F, neg.dv, neg.x
        if F_pos == F_neg:
            return 0.0
        h = self.h
        x_target = self.point.x + self.X - self.point.X
        jacobian = self.stick_jacobian
        dF = F_pos - F_neg
        rate_probe = dF / h
        if jacobian is not None:
            # the last stick ramp's slopes; Newton from the probe the block really answered
            d_F, x_F, d_r, x_r = jacobian.d_F, jacobian.x_F, jacobian.d_r, jacobian.x_r
            real = self.probes[1.0] if self.block_real.F_end == F_pos else self.probes[-1.0]
            F0, rate, d0, x0 = real.F, 0.0, real.dv, real.x
        else:
            # slopes in F0 from the two held probes, in rate from one more evaluation
            d_F, x_F = (d_pos - d_neg) / dF, (x_pos - x_neg) / dF
            F0, rate = F_neg, 0.0
            d0, x0 = d_neg, x_neg
            d_r, x_r = None, None
        for _ in range(STICK_RAMP_ITERATIONS):
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
            if abs(d0) <= self.delta and abs(x0 - x_target) <= STICK_RAMP_POSITION_TOL * self.settings.position_scale:
                break
        if jacobian is None and d_r is not None:
            self.report.stick_jacobian = StickJacobian(self.h_ns, d_F, x_F, (pos.dv_slope - neg.dv_slope) / dF, d_r, x_r)
        low, high = min(F_neg, F_pos), max(F_neg, F_pos)
        F1 = F0 + rate * h
        if not low <= F0 <= high:
            return 0.0
        if F1 > high:
            return (high - F0) / (F1 - F0)
        if F1 < low:
            return (low - F0) / (F1 - F0)
        return 1.0
