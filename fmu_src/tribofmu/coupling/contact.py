"""The contact state machine of one implicit step: classify, then solve.

The friction pair is in one of three contact modes over a step, and before its first step
in none yet (as Modelica's ``PartialFriction`` starts ``Unknown``):

    UNKNOWN  --first step-->  STUCK | FORWARD | BACKWARD
    FORWARD/BACKWARD  --dv reaches 0 inside the step-->  STUCK       (stick onset)
    STUCK  --the force needed to stay stuck leaves the friction's bounds-->  slip (breakaway)
    FORWARD <--> BACKWARD   (a reversal passes through one stuck step, or none for a law
                             without a jump at dv = 0)

One step (:class:`ImplicitStep`) first *classifies* the step from the friction at +-delta (or from
the slip it predicts), then runs the solver of that mode (coupling/solvers.py): the slip root, the
stick force, or the stick ramp. The block's answers are predicted by its learned model where the
coupling has one (coupling/blocks.py's BlockPrediction: the block then steps once, at the answer,
which checks the prediction; a miss is the outcome RETRY_UNPREDICTED, and the caller solves the
step again without it), else modelled where they can be (BlockResponse, the step's own; the last
steps' slope and Jacobian come in from the coupling's ReuseCache). A ramped step (the force ramping
over the step) that meets stiffness, a stick or a reversal ends in the explicit outcome
:data:`RETRY_HELD`, rolled back: the caller solves the step again with the force held. The step
reports what it measured (:class:`StepReport`: loop gain, the block's velocity per unit impulse,
evaluations) instead of writing into the algorithm.

The loop function H(dv) = (the block's relative velocity after the step under the friction at dv) -
dv is decreasing, so the coupled answer is its single root, found on a bracket; on the jump of a
discontinuous law (dry friction at dv = 0) there is no root: the blocks are stuck and the force is
the one that keeps dv = 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from . import solvers
from .blocks import BlockAnswer, BlockModel, BlockPrediction, BlockResponse, BlockSlope, StickJacobian
from .evaluations import BlockSide, FrictionSide
from .interpolation import NS
from .settings import LIMITS, RESOLUTION, SETTINGS, CouplingSettings
from .solvers import Probe
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


@dataclass(frozen=True)
class RetryUnpredicted:
    """The outcome of a step whose real block step disagreed with its prediction (blocks.
    BlockPrediction): the caller rolls back and solves it again with real block answers."""

    why: str = "the block's real step disagreed with its prediction"


RETRY_UNPREDICTED = RetryUnpredicted()


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
    block_answers: list = field(default_factory=list)  # [N, m, m/s^2] (F_end, x, a) of real block steps
    predicted: bool = False  # the block's answers were predicted and the real step agreed
    guess_miss: float | None = None  # [m/s^4] the slip root's miss of its extrapolated dv, per h^3
    commit: Callable[[Point], bool] | None = None  # the block's real step left to the caller (defer)


@dataclass(frozen=True)
class StepSettings:
    """How one step solves: ``expected_gain`` the loop gain a slip step of this length should
    meet (0: unknown), ``gain_miss`` [1] the last one's relative miss of it (the root's first
    iterate is aimed that far beyond), ``root_tol`` [m/s] how far the slip root may miss,
    ``delta`` [m/s] the "zero" relative velocity, ``position_scale`` [m] for the stick ramp's
    fit; ``stepped_trials``: a slip going on is sought with the friction stepped from its first
    trial (:meth:`ImplicitStep.stepped_slip`), for a law that has not stuck; ``dv_slope_fit``:
    the slip's predicted dv's course and miss (blocks.ReuseCache.slope_fit)."""

    expected_gain: float
    root_tol: float
    delta: float
    position_scale: float
    stepped_trials: bool = False
    tuning: CouplingSettings = SETTINGS  # (coupling/settings.py)
    dv_slope_fit: tuple[float, float, float] | None = None
    gain_miss: float = 0.0


class ImplicitStep:
    """The solve of one implicit step: from ``point`` over ``h_ns`` with the drive already
    at the step's end (``drive`` = X, V, aX), the block and friction saved in ``saved``."""

    def __init__(self, settings: StepSettings, system: CoupledSystem, point: Point, saved: States,
                 h_ns: int, drive: tuple[float, float, float], ramp: bool,
                 block_slope: BlockSlope | None = None, stick_jacobian: StickJacobian | None = None,
                 block_model: BlockModel | None = None, known_trials: dict | None = None, defer: bool = False):
        self.settings, self.point = settings, point
        self.previous = Contact(point.mode)
        self.h_ns, t, self.h = h_ns, point.t_ns / NS, h_ns / NS
        self.X, self.V, self.aX = drive
        self.delta = settings.delta
        self.root_tol = max(self.delta, settings.root_tol)  # m/s
        self.report = StepReport()
        # (its probes' trials at +-delta read where it stood before are read from known_trials)
        self.friction = FrictionSide(system, [v for v in saved.handles.values() if v[0] is system.friction], t,
                                     self.h, known_trials, (self.delta, -self.delta))
        # the block, its real answers under one family of forces and the affine model through them
        # (with the block's learned model, its answers are predicted and the last one stepped)
        prediction = BlockPrediction(block_model, point.x, point.v, self.h) if block_model is not None else None
        response = BlockResponse(h_ns, ramp, block_slope, RESOLUTION.same_force_rtol, prediction)
        self.block = BlockSide(system, [v for v in saved.handles.values() if v[0] is system.block], t, self.h,
                               self.V, point.F, ramp, response, self.report)
        # the last stick ramp's, where it was of this length (exact for a linear block)
        self.stick_jacobian = stick_jacobian if stick_jacobian is not None and stick_jacobian.h_ns == h_ns else None
        self.probes: dict[float, Probe] = {}  # side (+-1.0) -> the held step under the friction at side * delta
        self.extrapolated: float | None = None  # [m/s] the slip's dv along the slope's course (if predicted)
        # the block's real step at a predicted answer is left to the caller (commit): a step
        # the caller then rolls back (landed, rejected) never steps the block
        self.defer = defer

    # -- evaluations ----------------------------------------------------------------------
    def block_real_at(self, F: float) -> bool:
        """The block really stepped under the end force F; False where its model had missed
        (by more than the root tolerance: the model must be as good as the root it finds)."""
        return self.block.real_at(F, self.root_tol)

    def defers(self) -> bool:
        """The block's real step is left to the caller (asked to; its last answer predicted)."""
        return self.defer and self.block.last is self.block.response.last_predicted

    def committer(self, real_at: Callable[[], bool]) -> Callable[[Point], bool]:
        """commit(point): the block's real step (``real_at``), point then holding its real x,
        v, a; False where it disagreed with the prediction."""
        def commit(point: Point) -> bool:
            if not real_at():
                return False
            point.x, point.v, point.a = self.block.real.x, self.block.real.v, self.block.real.a
            return True
        return commit

    def stuck_real_at(self, event: float) -> bool:
        """:meth:`block_real_at` the stuck step's force; a predicted stick ramp (event 1) must
        also leave the block on the drive's path to the ramp's tolerance (else it missed)."""
        response = self.block.response
        predicted = self.block.last is response.last_predicted
        if not self.block_real_at(self.block.last.F_end):
            return False
        if not predicted or self.previous != Contact.STUCK or event < 1.0:
            return True
        target = self.point.x + self.X - self.point.X
        if abs(self.block.real.x - target) <= RESOLUTION.stick_ramp_position_tol * self.settings.position_scale:
            return True
        response.prediction, response.prediction_missed = None, True
        return False

    def loop(self, dv: float) -> float:
        """H(dv): how far the block's answer is from the assumed dv."""
        self.report.iterations += 1
        return self.block.under(self.friction.at(dv)[0]) - dv

    def probe(self, side: float) -> float:
        """H at side * delta, the held step under the friction there (:class:`Probe`); stuck
        before, with the last stick ramp's Jacobian for this step and the other side probed
        already, the block's answer is that probe's moved along the Jacobian (no step)."""
        self.block.response.seed_allowed = False  # (the probes measure the friction's bounds and the block for real)
        other, jacobian = self.probes.get(-side), self.stick_jacobian
        if other is None or jacobian is None or self.previous != Contact.STUCK:
            value = self.loop(side * self.delta)
            block = self.block.last
            self.probes[side] = Probe(self.friction.last.F, self.V - block.v, block.x, self.aX - block.a)
            return value
        self.report.iterations += 1
        F, _ = self.friction.at(side * self.delta)
        dF = F - other.F
        probe = Probe(F, other.dv + jacobian.d_F * dF, other.x + jacobian.x_F * dF, other.dv_slope + jacobian.slope_F * dF)
        self.probes[side] = probe
        self.block.last = BlockAnswer(F, probe.x, self.V - probe.dv, self.aX - probe.dv_slope, F, 0.0)
        return probe.dv - side * self.delta

    # -- the machine ----------------------------------------------------------------------
    def solve(self) -> Point | RetryHeld | RetryUnpredicted:
        """The new point, or RETRY_HELD (rolled back) where a ramped step turns out stuck, reversing
        or stiff, or RETRY_UNPREDICTED where the block's real step disagreed with its prediction."""
        classified = self.classify()
        if isinstance(classified, RetryHeld):
            return self.rolled_back(classified)
        mode, slip, event = classified
        ended = self.end_stuck(event) if mode == Contact.STUCK else self.end_slip(slip, mode, event)
        if isinstance(ended, (RetryHeld, RetryUnpredicted)):
            return ended if isinstance(ended, RetryUnpredicted) else self.rolled_back(ended)
        event, f, F_mean = ended
        response, ramped = self.block.response, self.block.ramp
        self.report.block_slope = response.measured_slope(ramped)
        if response.prediction is not None:
            # one real step, no secant of two: the learned 1/M (a secant of two held steps
            # measured sin(w h)/(w h M), of two ramped 2 (1 - cos(w h))/(w h)^2 M, of a stick
            # ramp's a mix: 1/M as h -> 0, what its readers take it for)
            self.report.predicted = True
            self.report.velocity_per_impulse = response.prediction.model.inv_M
        F, x, v, a, F0, F_rate = self.block.last
        return Point(self.point.t_ns + self.h_ns, self.X, self.V, self.aX, x, v, a, F, f, F_start=F0,
                     F_rate=F_rate, mode=mode, event=event, ramped=ramped, F_mean=F_mean)

    def rolled_back(self, retry: RetryHeld) -> RetryHeld:
        """retry, the block and the friction back at the step's start (each where it moved)."""
        self.block.restore()
        self.friction.restore()  # (one that only read trials holds its start state: no call)
        return retry

    def end_stuck(self, event: float) -> tuple[float, float, None] | RetryUnpredicted:
        """Stuck at the end: the stick ramp or force, the block there (or left to the report's
        commit), the friction stepped at rest: (event, f, None)."""
        response = self.block.response
        event = self.solve_stuck(event)
        if self.defers():
            self.report.commit = self.committer(lambda: self.stuck_real_at(event))
        elif not self.stuck_real_at(event):
            if response.prediction_missed:
                return RETRY_UNPREDICTED
            event = self.solve_stuck(event)  # again, every iterate stepped
            self.block_real_at(self.block.last.F_end)
        self.friction.step(0.0)
        return event, self.friction.last.f, None  # (the block felt the stick force, not the friction's)

    def end_slip(self, slip: tuple[float, float], mode: Contact,
                 event: float) -> tuple[float, float, float | None] | RetryHeld | RetryUnpredicted:
        """Slipping at the end: the slip root settled, the block there (or left to the report's
        commit): (event, f, the friction's mean force)."""
        dv, gain = slip
        self.report.loop_gain = gain
        if self.block.ramp and gain >= self.settings.tuning.max_ramp_gain:
            return RETRY_HELD_STIFF
        stepped = self.friction.stepped
        if stepped is None or stepped.dv != dv:  # (else the stepped trials settled it there)
            dv = self.settle(dv, gain, mode)
        if self.defers():
            self.report.commit = self.committer(lambda F=self.friction.last.F: self.block_real_at(F))
        elif not self.block_real_at(self.friction.last.F):
            if self.block.response.prediction_missed:
                return RETRY_UNPREDICTED
            dv = self.settle(dv, gain, mode)  # again, every iterate stepped
            self.block_real_at(self.friction.last.F)
        dv, _, f, F_mean = self.friction.last
        if self.extrapolated is not None and mode == self.previous:
            self.report.guess_miss = (dv - self.extrapolated) / self.h ** 3
        return event, f, F_mean

    def settle(self, dv: float, gain: float, mode: Contact) -> float:
        """The slip root with the friction's state integrated along the step.

        The trials that found dv held the friction's state at the step's start (its outputs'
        direct feedthrough, no step): stepping the friction to dv integrates the state (the
        lubricant kinetics, the costly part) once, instead of once a trial. Where the state
        moved the force, G(dv) = (the block's answer to the force after the friction stepped
        to dv) - dv is not yet 0: :meth:`secant_rounds` find its root."""
        dv, _, settled = self.secant_rounds(dv, gain, mode.direction, keep_side=True)
        if not settled:
            self.friction.step(dv)
            self.block.under(self.friction.last.F)
        return dv

    def stepped_g(self, dv: float) -> float:
        """G(dv): the block's answer to the force after the friction stepped to dv, less dv."""
        self.report.iterations += 1
        self.friction.step(dv)
        return self.block.under(self.friction.last.F) - dv

    def secant_rounds(self, dv: float, gain: float, direction: float,
                      keep_side: bool) -> tuple[float, float, bool]:
        """:func:`~.solvers.secant_rounds` on G (:meth:`stepped_g`): (dv, the gain the secant
        measured, whether G(dv) is within the root tolerance there), the friction stepped to dv."""
        return solvers.secant_rounds(self.stepped_g, dv, gain, direction, keep_side, floor=self.delta,
                                     root_tol=self.root_tol, rounds=LIMITS.max_settle_rounds)

    def classify(self) -> tuple[Contact, tuple[float, float] | None, float] | RetryHeld:
        """The step's contact mode, its slip root (dv [m/s], loop gain) when slipping, and the
        fraction of the step at which a stuck contact broke away (1: none)."""
        previous, delta = self.previous, self.delta
        first = -1.0 if previous == Contact.BACKWARD else 1.0
        if previous.slipping and self.settings.expected_gain > 0:
            # (with no loop gain, as for dry friction, the first pass from +-delta is exact. A
            # lubricant whose last step measured no gain, its force falling with dv, may have
            # more roots than one: from the predicted dv its boundary gamma = -0.3 point found
            # another, 1.9e-3 nRMS(v) reported as 3.7e-4 (bench_trust); +-delta's trials
            # bracket the answer)
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
            if self.block.ramp:
                response = self.block.response
                if response.ramp_moved or not all(sample.rate == 0.0 for sample in response.samples):
                    return RETRY_HELD_TRANSITION
                # The ramp's rate was 0 in every real step so far (a force that did not move,
                # as dry friction's in slip): they are the held step's own, so the solve goes
                # on held instead of starting again (which stepped the same probe twice).
                self.block.hold()  # (the force held at its end value from here)
        return Contact.STUCK, None, 1.0

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
            event = solvers.stick_onset(self.point.dv, self.point.aX - self.point.a, probe.dv, probe.dv_slope,
                                        self.h, 1.0 / self.h_ns)  # (to 1 ns: the time grid)
        if event < 1.0 or previous != Contact.STUCK:
            self.stick_force()
        return event

    # -- the solvers ----------------------------------------------------------------------
    def predicted_slip(self, side: float) -> tuple[float, float] | None:
        """Slipping on, as before: start the root search at the predicted dv instead of at
        +-delta, which saves the probe and keeps trial velocities near the answer (a trial
        far beyond it can melt the lubricant: costly, and a detour for the root finder).
        Returns (dv, gain), or None where the prediction does not show slip on this side."""
        point, delta, fit, h = self.point, self.delta, self.settings.dv_slope_fit, self.h
        extrapolated = None
        if self.block.ramp and fit is not None:
            # A ramped step (the trapezoidal rule) follows the coupled motion to O(h^3): dv along
            # the slope's course (fig6: within the root's tolerance in 54 % of its steps) ...
            extrapolated = point.dv + (point.aX - point.a + fit[0] * h / 2.0 + fit[1] * h * h / 3.0) * h
        if extrapolated is not None and abs(extrapolated - point.dv) < abs(point.dv):
            # ... missed by the rule's own local error (~h^3), changing little from step to step:
            # with the last step's miss per h^3, 75 % (the guess below: 16 %). Not where dv may
            # reach 0 within the step: there the friction is not smooth, nor its error (gamma =
            # -0.95's fixed steps: 148 of 1383 with a negative dissipation; 110 so, 112 before)
            self.extrapolated = extrapolated
            guess = extrapolated + fit[2] * h ** 3
        else:
            # dv moves with the drive's acceleration less the block's; the loop's own answer
            # pulls it back by 1/(1 + gain) (a stiff loop hardly lets dv change).
            guess = point.dv + (point.aX - point.a) * self.h / (1.0 + self.settings.expected_gain)
        if not side * guess > delta:
            return None
        self.block.response.seed_allowed = True
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
        if settled:  # (the friction stands stepped to dv)
            return dv, gain
        self.friction.restore()
        return None

    def slip_root(self, lo: float, h_lo: float, direction: float, hi: float | None = None,
                  h_hi: float | None = None) -> tuple[float, float]:
        """:func:`~.solvers.slip_root` on the loop function (slip in ``direction``): (dv, loop gain)."""
        self.block.response.seed_allowed = True  # slip is confirmed: the root's trials may model from one real answer
        settings = self.settings
        return solvers.slip_root(self.loop, lo, h_lo, direction, delta=self.delta, root_tol=self.root_tol,
                                 expected_gain=settings.expected_gain, max_iterations=LIMITS.max_iterations,
                                 aim_beyond=settings.gain_miss, hi=hi, h_hi=h_hi)

    def stick_force(self) -> float:
        """:func:`~.solvers.stick_force` between the probes: the held force that keeps dv = 0."""
        return solvers.stick_force(self.block.under, self.probes[1.0], self.probes[-1.0], self.delta,
                                   LIMITS.max_iterations)

    def stick_ramp(self) -> float:
        """:func:`~.solvers.stick_ramp` from the probes (stuck all through): the fraction of the
        step at which the ramp leaves the friction's bounds (1: stuck throughout)."""
        pos, neg = self.probes[1.0], self.probes[-1.0]
        jacobian = self.stick_jacobian
        real = self.block.real
        start_at_pos = jacobian is not None and real is not None and real.F_end == pos.F
        outcome = solvers.stick_ramp(self.block.ramp_at, pos, neg, self.h, self.h_ns, self.point.x + self.X - self.point.X,
                                     jacobian, start_at_pos, delta=self.delta,
                                     position_tol=RESOLUTION.stick_ramp_position_tol * self.settings.position_scale,
                                     iterations=LIMITS.stick_ramp_iterations)
        if outcome.jacobian is not None:
            self.report.stick_jacobian = outcome.jacobian
        return outcome.event


def solve_step(settings: StepSettings, system: CoupledSystem, point: Point, saved: States, h_ns: int,
               drive: tuple[float, float, float], ramp: bool, block_slope: BlockSlope | None = None,
               stick_jacobian: StickJacobian | None = None, block_model: BlockModel | None = None,
               known_trials: dict | None = None, defer: bool = False
               ) -> tuple[Point | RetryHeld | RetryUnpredicted, StepReport]:
    """One implicit step from ``point`` over ``h_ns`` [ns] (the drive already at its end,
    ``drive`` = X, V, aX; the block and friction saved in ``saved``): the new point (every
    slave standing there), RETRY_HELD (rolled back) or RETRY_UNPREDICTED, and what it measured.
    ``block_slope``, ``stick_jacobian`` and ``block_model``: the last steps' (blocks.ReuseCache),
    to save real block steps (with a model, the block steps once, at the answer); ``known_trials``:
    the friction's probe answers read at its state before (evaluations.KnownTrials); ``defer``:
    a predicted block's real step is left to the report's ``commit`` (the point's x, v, a are the
    prediction's until then)."""
    step = ImplicitStep(settings, system, point, saved, h_ns, drive, ramp, block_slope, stick_jacobian,
                        block_model, known_trials, defer)
    return step.solve(), step.report
