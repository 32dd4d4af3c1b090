"""What every error-controlled implicit coupling shares (:class:`ErrorControlledCoupling`): the
step-size bounds, the motion's magnitudes the errors are measured against, the global error
estimate, the accept / reject / land bookkeeping, where a slip step would pass over a stick
(:func:`grazing_crossing`, which the step then lands on), and for a run that aims at its
window, the one tightening of its tolerance its lead-in decides (coupling/lead_in.py). The
adaptive coupling (coupling/embedded.py) estimates its errors on top of it."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from .settings import STEP_CONTROL
from .base import Magnitudes
from .estimate import GlobalErrorEstimate
from .implicit import ImplicitCoupling, LoopState
from .local_errors import held_slope_lag
from .interpolation import NS, hermite_first_below
from .lead_in import LeadIn
from .settings import LIMITS, RESOLUTION
from .system import CoupledSystem, Point, States

# (the name the embedded estimate reads it by)
W2_POSITION_FLOOR = RESOLUTION.w2_position_floor
# A stuck step's order (EmbeddedCoupling.advance: its breakaway miss ~ h^4).
STUCK_ORDER = 3


def _largest(magnitude: float, floor: float, values: list[float]) -> float:
    """max(magnitude, |each value|, floor), the builtin's comparisons written out in its order (a
    scale is asked about 9 times a step; the generator the builtin unpacked cost twice the rest)."""
    scale = magnitude
    for value in values:
        if abs(value) > scale:
            scale = abs(value)
    return floor if floor > scale else scale


@dataclass(frozen=True)
class ControlledState(LoopState):
    """What an error-controlled coupling carries besides the loop's measurements (besides its
    magnitudes and global estimate, exported beside): the step-size control's."""

    h_ns: int = 0  # [ns] the next step to try
    rejected_last: bool = False  # the last step was rejected (its successor may not grow)
    # the last accepted step's length [ns], error ratio and order (the controller's trend; 0: none)
    accepted_h_ns: int = 0
    accepted_error: float = 1.0
    accepted_order: int = 0


class ErrorControlledCoupling(ImplicitCoupling):
    """What every error-controlled implicit coupling shares: the step-size bounds, the
    motion's magnitudes its errors are measured against (known, floored by the scene's
    scales, before the first step), the global error estimate, and the accept / reject /
    land bookkeeping (:meth:`_landed`, :meth:`_landed_at_crossing`, :meth:`_accepted`).
    Subclasses estimate the errors."""

    default_tol = 2e-4  # per-step error against the block's own motion, when nothing chooses it (tribofmu.checked does for simulate)
    default_step = 1e-4  # first try [s]
    controller = STEP_CONTROL
    # h_ns is kept a multiple of this [ns] (step doubling: two equal halves)
    step_granularity = 1
    carried = ControlledState
    state_names = tuple(field.name for field in fields(ControlledState))
    aim: tuple[float, float, float | None] | None = None  # (window start [s], its budget, the run's end [s]): see aim_window

    def prepare(self, system, scales):
        super().prepare(system, scales)
        self._held = None  # (point, system, the slaves' states there): see states_at
        g = self.step_granularity
        self.min_ns = max(g, int(scales.period * LIMITS.min_step_periods * NS) // g * g)
        self.max_ns = max(self.min_ns, int(scales.period * LIMITS.max_step_periods * NS) // g * g)
        self.h_ns = min(max(self.step_ns // g * g, self.min_ns), self.max_ns)
        self.estimate = GlobalErrorEstimate(getattr(system, "law", None))  # (a law with state: its slopes)
        self.magnitudes = Magnitudes()
        self.rejected_last = False  # the last step was rejected (its successor may not grow)
        # the last accepted step's length [ns], error ratio and order: the controller's trend
        self.accepted_h_ns, self.accepted_error, self.accepted_order = 0, 1.0, 0
        lead_in = LeadIn(self.aim[0], scales.period, self.aim[1], self.aim[2]) if self.aim is not None else None
        self.lead_in = lead_in if lead_in is not None and lead_in.applies else None  # (none: nothing to follow)
        self.lead_in_decision = None  # what the lead-in measured and decided (LeadIn.decision), once it has
        self.aims_at_window = self.lead_in is not None  # (its progress says what its lead-in expects)
        # whether, by its lead-in's latest mark, this run can still meet its window's budget
        # (None: nothing measured yet): False, a next run will be needed (LeadIn.reachable)
        self.window_reachable: bool | None = None

    def aim_window(self, window_start: float, budget: float, run_end: float | None = None) -> None:
        """Before the run: the shown window opens at window_start [s] and is to meet budget
        (nRMS(v)), and the run ends at run_end [s] (None: as the window opens); the per-step
        tolerance may tighten once, some drive periods before the window, as the run's own
        carried error asks (coupling/lead_in.py). Without it the tolerance is fixed."""
        self.aim = (window_start, budget, run_end)

    def observe(self, points: list[Point]) -> None:
        """The run's newly accepted points (after each advance): where the run aims at a window
        (:meth:`aim_window`), its lead-in marks the carry and, at its decision, tightens the
        per-step tolerance for the rest of the run."""
        lead_in = self.lead_in
        if lead_in is None:
            return
        for p in points:
            stage = lead_in.observe(p.t_ns / NS, p.global_error, self.estimate.old_v(), p.v,
                                    self.convergence_order() or 1.0)
            if stage is not None:  # (a mark measured: what it found)
                self.window_reachable = lead_in.reachable
            if stage == "mark":
                self.estimate.mark()
            elif stage == "decide":
                order = self.convergence_order() or 1.0
                self.lead_in_decision = lead_in.decision(order)
                factor = max(self.lead_in_decision["factor"], RESOLUTION.min_step_tol / self.tol)
                self.tol *= factor
                # the next step as the controller would size it for the new tolerance: a step of
                # order p is ~tol^(1/(p + 1)) long, and the run's order p/(p + 1) gives 1/(p + 1)
                g = self.step_granularity
                self.h_ns = max(int(self.h_ns * factor ** (1.0 - order)) // g * g, self.min_ns)
                self.lead_in = None
                return

    def export_state(self) -> dict:
        state = super().export_state()
        state["estimate"] = self.estimate.export()
        state["magnitudes"] = asdict(self.magnitudes)
        return state

    def import_state(self, state: dict) -> None:
        missing = {"estimate", "magnitudes"} - set(state)
        if missing:
            raise ValueError(f"{self.name} state lacks {', '.join(sorted(missing))}")
        super().import_state(state)
        self.estimate.restore(state["estimate"])
        self.magnitudes = Magnitudes(**state["magnitudes"])

    # -- scales: pure, from the accepted points' magnitudes and the scene's floor ------------
    def velocity_scale(self, *points: Point) -> float:
        return _largest(self.magnitudes.v, RESOLUTION.scale_floor * self.scales.velocity, [p.v for p in points])

    def position_scale(self, *points: Point) -> float:
        return _largest(self.magnitudes.x, RESOLUTION.scale_floor * self.scales.position, [p.x for p in points])

    def root_tolerance(self) -> float:
        return self.settings.root_tol_fraction * self.tol * self.velocity_scale()

    def dv_resolution(self) -> float:
        """How far [m/s] a point's dv may be off the dv its force was found at: the slip root's
        bracket (delta) or, looser, the root's tolerance, to which the block's model is held."""
        return max(RESOLUTION.zero_velocity * self.scales.velocity, self.root_tolerance())

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
        if event < 1.0 and landing >= max(g * self.min_ns, self.settings.event_margin * h_ns):
            system.restore(start)
            self.counters.landed += 1
            self.h_ns = landing
            return True
        return False

    def _landed_at_crossing(self, system: CoupledSystem, start: States, h_ns: int, crossing: float) -> bool:
        """A slip step passed over a stick or a reversal, its dense output crossing at the
        fraction crossing of the tried step of h_ns (:func:`grazing_crossing`): roll back and
        make the step that ends there the next try (True), unless the step is no longer than
        the smallest. A crossing closer to the start than settings.event_margin is not worth a
        step of its own, but cannot be left inside an accepted step either (the step would
        pass over the stick): the next try ends at the margin, past it, where the contact's
        solve meets dv's change of sign and locates the stick onset inside (solvers.py)."""
        g = self.step_granularity
        landing = max(int(h_ns * crossing), math.ceil(self.settings.event_margin * h_ns), self.min_ns)
        landing = -(-landing // g) * g
        if landing < h_ns:
            system.restore(start)
            self.counters.landed += 1
            self.h_ns = landing
            return True
        return False

    def trend(self, h_ns: int, order: int) -> tuple[float, float] | None:
        """What the step-size rule extrapolates a rejected try of h_ns [ns] of this order from
        (:class:`~tribofmu.physics.stepsize.StepSizeController`'s predictive term): its length
        over the last accepted step's and that step's error ratio; None where the last accepted
        step's error was of another kind, its order another (a held step's against a ramped
        one's, a slip's against a stick's: their error constants are not one quantity moving
        on), or a stuck one's (its error is its breakaway's, weighed by how near the bound the
        force is, :meth:`.EmbeddedCoupling.breakaway_reach`: no power of h moving smoothly)."""
        if self.accepted_order != order or order >= STUCK_ORDER or self.accepted_h_ns <= 0:
            return None
        return h_ns / self.accepted_h_ns, self.accepted_error

    def convergence_order(self) -> float | None:
        """The power of the per-step tolerance at which this run's error is expected to fall
        (None before a step): a step of order p whose error the controller holds to its share
        of the per-step tolerance tol is h ~ tol^(1/(p + 1)) long, so a span takes ~tol^(-1/(p + 1))
        of them and their errors add to ~tol^(p/(p + 1)); over the run, the mean of p/(p + 1)
        over its accepted steps (held steps first order: 1/2; ramped second: 2/3; stick ramps
        third: 3/4). A shear-thinning fluid near gamma = -1, whose stiff loop holds its force in
        four steps of ten, reads 0.60; a dilatant one, ramped almost throughout, 0.66."""
        steps = self.counters.steps
        return self.counters.convergence_sum / steps if steps else None

    def grazing(self, point: Point, new: Point, h: float) -> float | None:
        """Slipping the same way at both ends of the step of h [s] from point to new, the
        fraction of it at which its dense output of dv crosses 0 by more than tol x the
        velocity scale (:func:`grazing_crossing`), or None. (Only for a law that sticks: with a
        jump at dv = 0 a dip is a stick the step would pass over; a law without one, as a
        fluid's, slips through 0 continuously. The dense output is the results', its held ends'
        slopes the motion's (``a_lag``): with the block's own, a stiff held step's curve dipped
        by its end slope's miss alone, 57 % of a creeping fluid's rejections, and an allowance
        for that miss let the delivered curve dip through 0 unlanded, shear-thinning at per-step
        1e-4 reading 4.6x its error: fig5_pseudoplastic.)"""
        if self.stick_bounds is None or not point.mode.slipping or point.mode != new.mode:
            return None
        end_lag = held_slope_lag(point, new, h, self.expected_gain(h))  # (kept on new once accepted)
        return grazing_crossing(point, new, h, self.tol * self.velocity_scale(point, new), end_lag)

    def _committed(self, system: CoupledSystem, start: States, new: Point) -> bool:
        """The block's real step at the step's predicted answer (deferred past the landing and
        the error check: a try rolled back never stepped it); new then holds its real x, v, a.
        False where it disagreed with the prediction: rolled back and the block's model
        forgotten, for the step to be solved again without it."""
        commit, self.pending_commit = self.pending_commit, None
        if commit is None or commit(new):
            return True
        system.restore(start)
        self.reuse.block.forget()
        return False

    def _accepted(self, system: CoupledSystem, start: States, h_ns: int, error: float, order: int,
                  min_ns: int, steps: int) -> bool:
        """Accept the tried step of h_ns (``steps`` communication steps) when its error ratio
        is <= 1 or it is no longer than min_ns, else roll back to start; either way the next
        try's length follows from the controller (local error ~ h^(order + 1)). A rejected
        try's retry is sized with the trend of the error since the last accepted step where
        that step's error was of the same kind (:meth:`trend`): its error's constant rose past
        what that step showed, and a retry sized from this try's error alone assumes it stays
        where it is now, and was rejected again where it rose on (Fig. 6's re-solidifications:
        three rejections in a row). An accepted step's successor is sized without it: there it
        shortened steps whose errors were within tol, accuracy no call asked for (a scratch
        run of the rule with the trend on every step, session 16: Fig. 6's and Fig. 2's default
        calls 25 % and 6 % more steps for errors 2.1x and 1.3x smaller)."""
        accepted = error <= 1.0 or h_ns <= min_ns
        trend = None if accepted else self.trend(h_ns, order)
        factor = self.controller.factor(error, order, self.rejected_last, self.accepted_error, trend)
        if accepted:
            self.counters.forced += error > 1.0
            self.counters.steps += steps
            self.counters.convergence_sum += steps * order / (order + 1.0)
            self.rejected_last = False
            self.accepted_h_ns, self.accepted_error, self.accepted_order = h_ns, error, order
            self.h_ns = int(min(max(h_ns * factor, self.min_ns), self.max_ns)) // self.step_granularity \
                * self.step_granularity
            return True
        system.restore(start)
        self.counters.rejected += 1
        self.rejected_last = True
        self.h_ns = max(int(h_ns * factor), self.min_ns) // self.step_granularity * self.step_granularity
        return False


def grazing_crossing(start: Point, end: Point, h: float, margin: float, end_lag: float = 0.0) -> float | None:
    """Slipping one way at both ends of a step of h [s], the fraction of the step at which the
    interpolated relative velocity (the results' dense output, end_lag [m/s^2] the end's
    ``a_lag`` before the step is kept) first crosses 0 by margin [m/s] the other way: a stick
    or a reversal the step would pass over, which the step is to end at (landed on). None where
    it stays within margin (a dip within the tolerance is not worth a step). Located on the
    cubic itself, to 1 ns of the step, not sampled."""
    direction = start.mode.direction
    return hermite_first_below(direction * (start.V - start.v), direction * (end.V - end.v),
                               direction * (start.aX - start.a - start.a_lag),
                               direction * (end.aX - end.a - end_lag), h, -margin,
                               xtol=1.0 / (h * NS))
