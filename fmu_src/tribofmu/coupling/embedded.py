"""The adaptive coupling with one implicit solve per accepted step: an embedded error estimate
instead of step doubling.

Step doubling (``benchmarks/doubling.py``) solves three times per two accepted steps. Here
each step is solved once, and its error is estimated from what the solve and the steps before
it know (as an embedded Runge-Kutta pair, or Milne's device, does without a second solve):

- a **ramped** step (the force ramps linearly over the step: the trapezoidal rule on the
  coupling force) errs by the force's curvature: the block felt the chord, the friction
  followed the curve, and the impulse between them is ``-F'' h^3 / 12``. F'' comes from the
  coupling force itself: the *predictor* (the force extrapolated linearly from the last two
  communication points) against the *corrector* (the force the solve found), a divided
  difference over the last two steps;
- a **held** step (the force held at its end value: backward Euler, at transitions and where
  the loop is too stiff to ramp) errs by the force's slope, ``-F' h^2 / 2``, F' from the force
  at the step's two ends;
- a **stuck** step is exact in v (the stick force keeps dv = 0) and, its force ramped to keep
  x on the drive, in x.
In a stiff loop an error in the block's velocity is pulled back by the friction within the
step: the estimates are divided by ``1 + g`` (g the loop gain the solve measured), as stiff
ODE codes filter their error estimates through ``(I - h J)^-1``. The friction's own mean
force over the step (a lubricant gripping between communication points) enters as before
(:meth:`~.algorithms.ImplicitCoupling._impulse_misses`). The global estimate: :mod:`.estimate`.

Events: a stuck contact breaking away inside a step is landed on (the step is solved again to
end there, counted as ``landed``), and the step before a breakaway the last stick ramp
predicts ends at it, so the landing's extra solve is rarely needed. A stuck step's own force
is a chord (a ramp, or held where the contact stuck inside the step); the force that keeps
the block on the drive at the step's end is the chord's plus M (aX - a), the block's
acceleration miss. When that force is past the friction's bound the contact broke away
inside the step although the chord stayed within it (a micro-stick shorter than the step):
the step is landed where that force, interpolated from its start, reaches the bound
(:meth:`EmbeddedCoupling.missed_breakaway`). A slip step over which the results' dense output
of dv dips through 0 (a stick or a reversal it would pass over) is landed on the crossing too
(:meth:`~.controlled.ErrorControlledCoupling.grazing`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from .controlled import STUCK_ORDER, W2_POSITION_FLOOR, ErrorControlledCoupling
from .estimate import chord_damping
from .interpolation import NS
from .limits import StepLimits
from .path_error import passed_phase_change, path_local_error
from .local_errors import (force_curvature, held_slope_lag, ramp_step, slip_x_error, stick_onset_x_error,
                           unstable_loop_factor)
from .settings import ERROR_SETTINGS, RESOLUTION
from .system import Contact, CoupledSystem, Point
from .variational import lubricant_step


@dataclass(frozen=True)
class LocalError:
    """One step's estimated local errors (signed: they superpose in the carried estimate):
    x [m], v [m/s] of the block, F [N] the force's deviation from what the block felt, and
    ``impulse`` [m/s] the block's miss of the friction's own mean force over the step."""

    x: float = 0.0
    v: float = 0.0
    F: float = 0.0
    impulse: float = 0.0
    f: float = 0.0  # [1] the friction's state off its predicted path
    stuck: bool = False  # stuck throughout: F is the stick force's miss (the breakaway's timing)
    # (x [m], v [m/s], f [1], v inside [m/s]) of a slip step of a friction with state: its path's
    # defect carried to its end and to its middle (coupling/path_error.py); None: not such a step
    path: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class ForceHistory:
    """The coupling force's slope over the last accepted step, for the predictor: valid only
    when that step slipped the same way as the one before it ended (``mode``)."""

    slope: float = 0.0  # N/s, (F at its end - F at its start) / h
    h: float = 0.0  # s, its length (0: no history)
    mode: Contact = Contact.UNKNOWN
    jerk: float = 0.0  # m/s^3, the block's (a at its end - a at its start) / h, any mode
    f_slope: float = 0.0  # 1/s, the friction's state f: (f at its end - f at its start) / h
    stuck_throughout: bool = False  # it was a stick ramp (its F_rate: the stick force's slope)

    def __post_init__(self):  # (from a JSON snapshot the mode comes as a plain int)
        object.__setattr__(self, "mode", Contact(self.mode))


class EmbeddedCoupling(StepLimits, ErrorControlledCoupling):
    """Implicit steps under error control by an embedded estimate: one solve per step."""

    name = "adaptive"
    state_names = ErrorControlledCoupling.state_names + ("stick_bounds",)
    errors = ERROR_SETTINGS  # the estimate's weights (coupling/settings.py); an instance may be given others

    # -- state -----------------------------------------------------------------------------
    def export_state(self) -> dict:
        state = super().export_state()
        if self.stick_bounds is not None:
            state["stick_bounds"] = list(self.stick_bounds)
        state["history"] = asdict(self.history)
        return state

    def import_state(self, state: dict) -> None:
        if "history" not in state:
            raise ValueError(f"{self.name} state lacks history")
        super().import_state(state)
        self.stick_bounds = tuple(self.stick_bounds) if self.stick_bounds is not None else None  # (JSON: a list)
        self.history = ForceHistory(**state["history"])

    def prepare(self, system, scales):
        super().prepare(system, scales)
        self.history = ForceHistory()

    # -- the step --------------------------------------------------------------------------
    def planned_step(self, point: Point, stop_ns: int) -> int:
        """The step to try from point: the controller's, ended at a breakaway the last stick
        ramp predicts, at the stop, and never leaving a sliver shorter than the minimum."""
        h_ns = min(self.h_ns, stop_ns - point.t_ns)
        limit = self.interpolation_limit(point) * NS
        if limit < h_ns:
            h_ns = max(self.min_ns, int(limit))
        if stop_ns - point.t_ns - h_ns < self.min_ns:
            h_ns = stop_ns - point.t_ns
        breakaway = self.predicted_breakaway(point)
        if breakaway is not None:
            landing = int(breakaway * NS)
            margin = self.settings.event_margin
            if margin * h_ns < landing < (1.0 - margin) * h_ns and landing >= self.min_ns:
                h_ns = landing
        return h_ns

    def missed_breakaway(self, point: Point, new: Point) -> float | None:
        """Stuck at the end of the step from point to new, but the force that keeps the block
        on the drive there, new.F + M (aX - a), is past the friction's bound: the fraction of
        the step at which that force, linear from its value at the step's start (or from the
        stick onset inside the step), reached the bound; None when it stays within (or
        leaves only in the step's last settings.event_margin, where the next step breaks away)."""
        bounds = self.stick_bounds
        if not new.mode.stuck or bounds is None or self.velocity_per_impulse <= 0.0:
            return None
        mass = 1.0 / self.velocity_per_impulse  # kg, as the block answers an impulse
        low, high = bounds
        end = new.F + (new.aX - new.a) * mass
        slack = RESOLUTION.missed_breakaway_rtol * max(abs(low), abs(high))
        if low - slack <= end <= high + slack:
            return None
        bound = high if end > high else low
        onset = 0.0 if point.mode.stuck else min(max(new.event, 0.0), 1.0)
        start = point.F + (point.aX - point.a) * mass  # (at dv = 0: the stick onset or a stuck point)
        if low <= start <= high and start != end:
            fraction = (bound - start) / (end - start)
        else:  # no start inside the bounds to interpolate from: halve the stuck part
            fraction = 0.5 * (onset + 1.0)
        fraction = min(max(fraction, onset), 1.0)
        return fraction if fraction < 1.0 - self.settings.event_margin else None

    def advance(self, system: CoupledSystem, point: Point, stop_ns: int) -> list[Point]:
        h_ns = self.planned_step(point, stop_ns)
        start = self.states_at(system, point)
        # (a predicted block steps for real only once the step is to be kept: _committed)
        new = self.solve_step(system, point, h_ns, saved=start, defer=True)
        if self._landed_on_event(system, start, point, new, h_ns):
            return []
        h = h_ns / NS
        local = self.local_error(point, new, h)
        err = self.error_ratio(point, new, local, h)
        # local error ~ h^(order + 1): ramped h^3, held h^2; a stick ramp's breakaway
        # miss dF^2 with dF ~ h^2: h^4
        order = STUCK_ORDER if local.stuck else (2 if new.ramped else 1)
        # (_accepted's own condition: a step it keeps)
        if (err <= 1.0 or h_ns <= self.min_ns) and not self._committed(system, start, new):
            return self.advance(system, point, stop_ns)  # (once: the block's model is forgotten)
        if not self._accepted(system, start, h_ns, err, order, self.min_ns, 1):
            return []
        if local.stuck and h_ns <= self.h_ns <= self.errors.stuck_hold_growth * h_ns:
            self.h_ns = h_ns
        self._carry_error(point, new, local, h)
        self.history = self.next_history(point, new, h)
        self.magnitudes.accept(new)
        return [new]

    def _landed_on_event(self, system: CoupledSystem, start, point: Point, new: Point, h_ns: int) -> bool:
        """Whether the tried step from point to new passed over an event and was rolled back to
        end where it is (True: the next try is that step): a breakaway inside it, located by
        the solve or by the force past the friction's bound at its end; a stick or reversal
        its dense output passes over; a grip of the lubricant inside it, where is not known:
        halved (bisection)."""
        if self._landed(system, start, h_ns, new.event):
            return True
        missed = self.missed_breakaway(point, new)
        if missed is not None and self._landed(system, start, h_ns, missed):
            return True
        grazing = self.grazing(point, new, h_ns / NS)
        if grazing is not None and self._landed_at_crossing(system, start, h_ns, grazing):
            return True
        return self.passed_phase_change(point, new) and self._landed_at_crossing(system, start, h_ns, 0.5)

    @staticmethod
    def next_history(point: Point, new: Point, h: float) -> ForceHistory:
        jerk = (new.a - point.a) / h
        if new.mode.slipping and new.mode == point.mode:
            return ForceHistory((new.F - point.F) / h, h, new.mode, jerk, (new.f - point.f) / h)
        # a step into slip from a stick or a reversal: its slope is a transition's, no predictor
        return ForceHistory(0.0, 0.0, new.mode, jerk, stuck_throughout=new.mode.stuck and point.mode.stuck)

    # -- the embedded estimate --------------------------------------------------------------
    def local_error(self, point: Point, new: Point, h: float) -> LocalError:
        """The step's local errors from the solve's own outcome and the force history (see
        the module's docstring); pure: nothing is stored."""
        impulse = self._impulse_misses(point, new)[0]
        if new.mode.stuck:
            if point.mode.stuck and not self.history.stuck_throughout:
                return LocalError(impulse=impulse)  # the first stick ramp: no slope to predict from
            if point.mode == Contact.UNKNOWN:
                # The run's first step, stuck from the start: the start point's F is no force
                # the block felt (0 before any solve), so F - point.F is not the stick force's
                # change, and no slope is known yet (as for the first stick ramp). Charged as
                # a slip into stick it forced the step to its floor (3 -> 0.02 us at per-step
                # tol 3.9e-7 on mixed_stribeck delta = 1), where the stick ramp's force is
                # round-off (x hardly answers the rate, h^3/6M) that the breakaway term then
                # rejected for thousands of steps.
                return LocalError(impulse=impulse)
            if point.mode.stuck:
                # The stick ramp is exact in x and v; its force is a chord of the curving
                # stick force, and where that reaches the friction's bound the contact breaks
                # away: the end force's miss (half its distance from the last ramp's
                # extrapolation) moves the breakaway (fig2's rig at omega = 10: 6.4e-2 nRMS(v)
                # with stuck steps at T/20 unchecked).
                return LocalError(F=0.5 * (new.F - (point.F + point.F_rate * h)), impulse=impulse, stuck=True)
            # Slipping into stick inside the step: held at the stick force, v = V exact at
            # the end, x off as a held step's (the force's change over the step, 2h/3 of
            # its velocity miss). (Taking the stick onset's own fraction e instead, x ~ (e h)^2,
            # let onsets early in a step pass: fig2's rig at omega = 30, 4e-4 -> 2.6e-2 nRMS(v).)
            dv_impulse = -0.5 * (new.F - point.F) * h * self.velocity_per_impulse
            return LocalError(x=dv_impulse * 2.0 * h / 3.0, F=0.5 * (new.F - point.F), impulse=impulse)
        if point.mode == Contact.UNKNOWN:
            first = self.first_step_path_error(point, new, h)
            if first is not None:
                return LocalError(impulse=impulse, path=first)
        gain = self.expected_gain(h)
        filter_ = 1.0 / (1.0 + gain)  # a stiff loop pulls an error back
        history = self.history
        path = self.path_error(point, new, h)
        if self.curvature_known(point, new):
            curvature = force_curvature(point, new, h, history.slope, history.h)  # the chord misses -F'' h^3 / 12
            miss = -curvature * h ** 3 / 12.0  # N s
            v = miss * self.velocity_per_impulse * filter_
            f_predicted = point.f + history.f_slope * h
            f_miss = (new.f - f_predicted) * h / (h + history.h)
            x = slip_x_error(point, new, v, h, gain, self.velocity_per_impulse, self.force_course(new), True)
            return LocalError(x=x, v=v, F=curvature * h * h / 8.0, impulse=impulse, f=f_miss, path=path)
        # held (or ramped with no history): the force held at its end value misses -F' h^2 / 2;
        # f's miss filtered as the force's: f follows dv, whose error a stiff loop pulls back
        miss = -0.5 * (new.F - point.F) * h  # N s
        v = miss * self.velocity_per_impulse * filter_
        x = slip_x_error(point, new, v, h, gain, self.velocity_per_impulse, self.force_course(new), False)
        return LocalError(x=x, v=v, F=0.5 * (new.F - point.F) * filter_, impulse=impulse,
                          f=0.5 * (new.f - point.f) * filter_, path=path)

    def passed_phase_change(self, point: Point, new: Point) -> bool:
        """Whether the lubricant re-solidified inside the step and melted again (see
        :func:`.path_error.passed_phase_change`)."""
        return passed_phase_change(self.estimate.law, point, new, max(abs(new.F), abs(point.F)), self.tol)

    def first_step_path_error(self, point: Point, new: Point, h: float) -> tuple[float, float, float, float] | None:
        """The run's first step, from the start into slip, as :meth:`path_error` charges a slip
        step (x [m], v [m/s], f [1], v inside [m/s]), where the held estimate cannot be read: the
        loop is stiff over the step by the law's own slope (its gain g = F_dv h / M, of the
        block's share of the end force, past 1) and the gain the step's solve measured, the
        secant from its first guess, under-reads it. The held estimate then takes the force's
        settling from the law's force at the start onto the loop's answer (within M / F_dv) for
        a slope over the whole step, and the lubricant's relaxation from its start value for
        f's miss, and filters them by the under-read gain: errors that do not fall with h,
        against the block's motion from rest, which does. The step fell to its floor and the
        next ones crept up from it (a solid lubricant, fig6's rig at gamma = -0.85, K = 2000:
        gain 10.9 measured for 1.7e4, per-step 3e-5: 167 steps shorter than 1e-6 of the drive's
        period, 10 forced). The path's error, through the law's slopes, answers a stiff loop
        quasi-statically, as the block does. None for any other first step (it is charged as
        held: where the gain was read, as at gamma = -0.3, runs are as they were)."""
        slopes = self.law_slopes(point, new)
        if slopes is None or not new.mode.slipping:
            return None
        law_gain = slopes[0] * h * (0.5 if new.ramped else 1.0)
        if law_gain <= max(1.0, self.expected_gain(h)):
            return None
        return path_local_error(point, new, h, self.estimate.w2, slopes, self.velocity_per_impulse)

    def law_slopes(self, point: Point, new: Point) -> tuple[float, float, float, float] | None:
        """The friction law's slopes over the step from point to new (estimate.state_slopes, dv
        no nearer 0 than the solve's resolution): the path error's and the carry's."""
        return self.estimate.state_slopes(point, new, self.velocity_per_impulse, RESOLUTION.zero_velocity * self.scales.velocity)

    def path_error(self, point: Point, new: Point, h: float) -> tuple[float, float, float, float] | None:
        """The slip step's local error (x [m], v [m/s], f [1], v inside [m/s]) from its own path,
        carried through the law's slopes (coupling/path_error.py), for a friction with state
        slipping at both ends (across a reversal too: a lubricant's force is continuous through
        dv = 0); None for any other step."""
        if not (new.mode.slipping and point.mode.slipping):
            return None
        slopes = self.law_slopes(point, new)
        return None if slopes is None else path_local_error(point, new, h, self.estimate.w2, slopes,
                                                            self.velocity_per_impulse)

    def force_course(self, new: Point) -> float:  # N/s, over the last step that slipped as new does
        return self.history.slope if self.history.h > 0.0 and self.history.mode == new.mode else 0.0

    def error_ratio(self, point: Point, new: Point, local: LocalError, h: float) -> float:
        """The step's error relative to what tol allows (<= 1: accept): its local errors in v
        and x against the block's own motion, the impulse miss, and, for a friction with an
        internal state, the force's against the largest |F| so far."""
        allowance = self.errors.error_weight * self.tol
        v_scale, x_scale = self.velocity_scale(point, new), self.position_scale(point, new)
        error = max(abs(local.v) / (allowance * v_scale), abs(local.x) / (allowance * x_scale),
                    abs(local.impulse) / (allowance * v_scale))
        if point.mode.stuck and new.mode.stuck:
            error = max(error, self.stuck_interpolation_error(point, new, h, v_scale, x_scale))
        if local.stuck and new.F_rate != 0.0:  # (the block's stick force: not the terms below)
            error = max(error, self.breakaway_timing_error(point, new, local, h, allowance * v_scale))
        elif new.f != 0.0 or point.f != 0.0:
            error = self.state_force_error(error, point, new, local, h)
        if local.path is not None:
            # the path's own error in x and v. (f's is in them, through the lubricant's loop;
            # charged on its own as well, it cut Fig. 6's solid steps near the melt, where the
            # loop's solve then took 3 evaluations where it had taken 1: 70 % more per run at
            # per-step tol 1e-3, at the same accuracy)
            x, v, _, _ = local.path
            error = max(error, abs(x) / (allowance * x_scale), abs(v) / (allowance * v_scale))
        if new.mode.slipping and (point.mode == new.mode or point.mode.stuck):
            # (across a transition a jumps and the interpolants take one-sided slopes; stuck,
            # v is the drive's V, interpolated with the drive's acceleration. A stuck step that
            # slips at its end broke away at its start (a later breakaway is landed on), and
            # slips all through from the stuck point's state: fig2's
            # rig at omega = 3 took 8 ms there, a quarter of the block's period, unchecked,
            # and its samples missed by 0.35 % of max|v|)
            error = max(error, self.interpolation_error(point, new, h, v_scale, x_scale))
        return error

    def breakaway_timing_error(self, point: Point, new: Point, local: LocalError, h: float,
                               v_allowed: float) -> float:
        """A stuck step's error through its breakaway's timing, relative to v_allowed [m/s]:
        a breakaway late by dt = dF / F_rate starts the slip late, the relative velocity grows
        as (F_rate / M) s^2 / 2 after it, so v misses F_rate/M dt^2 / 2 = dF^2 / (2 M F_rate),
        weighed by how near the bound the force is (:meth:`breakaway_reach`)."""
        late = 0.5 * self.velocity_per_impulse * local.F * local.F / abs(new.F_rate)
        reach = self.breakaway_reach(point, new, local.F, h)
        return reach * late / v_allowed

    def state_force_error(self, error: float, point: Point, new: Point, local: LocalError, h: float) -> float:
        """error raised to a friction with internal state's terms: the force's own deviation,
        its curvature (ramped) or slope (held) against tol x the largest |F| so far (widened by
        what the solve cannot resolve, :meth:`force_term_floor`), and the state's miss
        against tol x the largest |f| (weighed by errors.state_weight)."""
        F_scale = max(self.magnitudes.F, abs(new.F), abs(point.F)) or 1.0
        allowed = self.tol * F_scale + self.force_term_floor(point, new, h)
        error = max(error, abs(local.F) / allowed)
        f_scale = max(self.magnitudes.f, abs(new.f), abs(point.f)) or 1.0
        return max(error, self.errors.state_weight * abs(local.f) / (self.tol * f_scale))

    def force_resolution(self, new: Point, h: float) -> float:
        """The force [N] the slip solve of a step of h [s] ending at new cannot tell from its
        root: it resolves dv to its resolution (:meth:`dv_resolution`, as the carry's chord reads
        a point's dv: _carry_error), delta or the root's tolerance, and the friction
        answers a change of dv at its slope dF/d(dv) = g / (c h vpi) (g the loop gain, vpi the
        block's velocity per impulse, c the block's share of the end force: 1/2 ramped, 1 held).
        A solid lubricant creeping at |dv| ~ 1e-12 m/s with a slope of 6.5e7 N/(m/s) gives
        2.7e-7 N at delta: its force jitters by that from step to step whatever h, and the force
        term read it as error (fig6 at gamma = -0.85, K = 2000, per-step 5e-5: 241,063 steps at
        the 20 ns floor; with delta alone, per-step 1e-5 stalled at 0.14 us steps)."""
        if self.velocity_per_impulse <= 0.0 or h <= 0.0 or not new.mode.slipping:
            return 0.0
        share = 0.5 if new.ramped else 1.0
        slope = self.expected_gain(h) / (share * h * self.velocity_per_impulse)
        return slope * self.dv_resolution()

    def curvature_known(self, point: Point, new: Point) -> bool:
        """Whether the ramped step from point to new has its force's curvature estimated from
        the step before it (the same slip mode all through): else it is charged as held."""
        history = self.history
        return new.ramped and history.h > 0.0 and history.mode == new.mode == point.mode

    def force_term_floor(self, point: Point, new: Point, h: float) -> float:
        """What the force term of :meth:`local_error` reads [N] when every force it combines
        is off by the solve's resolution (:meth:`force_resolution`), at most: the term's
        tolerance is widened by it, as an absolute tolerance, so that the error estimate
        never sees the solver's own resolution. Ramped: (F - F_predicted) h / (4 (h + h_prev))
        of three forces off by r each, at most r h / (2 h_prev); held: half the change of two
        forces, filtered by 1 / (1 + g) as the term is, at most r / (1 + g). (Filtering the
        ramped term by 1 / (1 + g) as well also stopped the collapse, but loosened Fig. 6 where
        that term times its melts: per-step 1e-3 1.14e-3 -> 1.55e-3 nRMS(v), and its check
        took 4 runs instead of 3.)"""
        resolution = self.force_resolution(new, h)
        if self.curvature_known(point, new):
            return resolution * 0.5 * h / self.history.h
        return resolution / (1.0 + self.expected_gain(h))

    def breakaway_reach(self, point: Point, new: Point, F_miss: float, h: float) -> float:
        """How much the breakaway's timing counts for the stuck step from point to new, its
        stick force ramping at new.F_rate [N/s] and off its curve by about F_miss [N]: 1 where
        the force can reach the friction's bound within the next step at its longest,
        controller.max_factor steps of h [s] (along its ramp or by its curvature): a breakaway
        the next step may hold; falling as the square of that reach over the distance to the
        bound farther off. (The tuning value breakaway_reach = 4 until 2026-11-27, the same
        number: max_factor is 4.) The stick ramp is exact in x and v whatever its force: its
        miss matters only through the breakaway's timing, which divides by the force's rate.
        Far from the bound, counted in full, it read the ramp's round-off as error: from rest
        (rate ~0) it forced the steps to their floor (mixed friction, delta = 1, at per-step
        2e-7: 346 steps in the first 0.1 % of the run, and the run's pace then stopped it).
        (Switched off beyond the reach instead, the steps grown far from the bound were
        rejected where it switched on: fig2 29 % rejected.) A breakaway the steps pass over is
        landed on (:meth:`missed_breakaway`)."""
        bounds = self.stick_bounds
        if bounds is None:
            return 1.0
        margin = min(min(bounds[1] - F, F - bounds[0]) for F in (point.F, new.F))
        reach = self.controller.max_factor * (abs(new.F_rate) * h + abs(F_miss))
        return 1.0 if margin <= reach else (reach / margin) ** 2

    def _carry_error(self, point: Point, new: Point, local: LocalError, h: float) -> None:
        """Carry the global error estimate over the accepted step (coupling/estimate.py)."""
        # (a chord over less than a point's dv resolution is that, not the slope; a fluid creeping
        # at |dv| ~ 1e-9 m/s read chords of either sign: gamma = -0.9, 0.56 estimated, 1.3e-3 true)
        damping = chord_damping(point, new, self.velocity_per_impulse, self.dv_resolution())
        if damping is None:  # (the loop gain: the slope's size, of the block's share of the end force)
            damping = self.loop_gain / self.loop_gain_step * (2.0 if new.ramped else 1.0)
        x_scale, v_scale = self.position_scale(point, new), self.velocity_scale(point, new)
        self.estimate.observe(new.x, new.a, new.F, self.velocity_per_impulse, W2_POSITION_FLOOR * x_scale)
        stuck = new.mode.stuck  # (a friction with state: its error carried by the law's slopes, estimate.py)
        slopes = self.law_slopes(point, new)
        gain = self.expected_gain(h)
        new.a_lag = held_slope_lag(point, new, h, gain)  # (the results' slope: local_errors.py)
        loop = unstable_loop_factor(damping, h, new.ramped, gain)  # (1 but on a Stribeck drop)
        # a slip step of a friction with state: its defect along its own path (coupling/path_error.py)
        path = local.path
        self.estimate.recentre(  # (then centre the last ramp)
            ramp_step(point, new, h, self.history.slope, self.history.h, local.v * loop, gain)
            if path is None and self.curvature_known(point, new) else None)
        transition = None  # (a slip step of a lubricant: carried by its own map, variational.py)
        if path is not None:
            x, v, f, new.inside_error = path
            transition = lubricant_step(self.estimate.law, point, new, h, self.velocity_per_impulse)
            if self.passed_phase_change(point, new):  # (taken at the shortest step)
                self.estimate.passed_event = True
        else:
            x = stick_onset_x_error(point, new, h, self.velocity_per_impulse, self.estimate.w2) \
                if stuck and point.mode.slipping else local.x * loop
            v, f = local.v * loop + local.impulse, 0.0
        new.global_error = self.estimate.advance(h, 0.0 if stuck else damping, x, v,
                                                 stuck, x_scale, v_scale, stuck and point.mode.stuck, slopes,
                                                 max(self.magnitudes.f, abs(new.f)) or math.inf, f, transition)
        self.estimate.watch(slopes, point.f, new.f)
        new.est_error = abs(local.v)
