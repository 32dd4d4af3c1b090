"""The fixed-step implicit coupling (``implicit``): each step iterates with rollback until the
force the block felt and the friction at the resulting relative velocity agree (one
:class:`~.contact.ImplicitStep`); what it carries from step to step (the loop gain, the block's
response) and its exported state."""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

from .base import Counters, CouplingAlgorithm, Scales
from .blocks import ReuseCache
from .contact import RetryHeld, RetryUnpredicted, StepSettings, slip_mode, solve_step
from .evaluations import KnownTrials
from .interpolation import NS
from .settings import RESOLUTION, SETTINGS, SWITCHES
from .system import Contact, CoupledSystem, Point, States


@dataclass(frozen=True)
class LoopState:
    """What the implicit coupling carries from one step to the next, besides its settings (tol,
    step), what prepare() derives from the scales, its counters and what it reuses: what its
    solves measured of the loop. Its exported state (a pair FMU's FMU state) is these fields;
    the coupling keeps their live values as attributes of the same names."""

    loop_gain: float = 0.0  # |d(block dv)/dF * dF/d(dv)| of the last slip step ...
    loop_gain_step: float = 1.0  # ... whose length this was [s]
    # [1] how far that gain was from the one expected of that step (expected_gain), relative:
    # how far the next is likely off (the slip root aims its first iterate that far beyond)
    gain_miss: float = 0.0
    velocity_per_impulse: float = 0.0  # [m/s / (N s)] the block's, last measured (0: not yet)
    # [N] (low, high): the friction's force range at the last stick (None: no stick yet)
    stick_bounds: tuple[float, float] | None = None


class ImplicitCoupling(CouplingAlgorithm):
    """Fixed-step implicit coupling.

    A step is accepted when the force the block felt at its end equals the friction at the
    end-of-step relative velocity (or, stuck, lies within the jump). Over the step the
    force is ramped (slipping the same way, loop gain below settings.max_ramp_gain), held (at
    transitions and where the loop is stiff: backward Euler), or, stuck throughout, the
    ramp that keeps both v = V and x - X. One step's solve is a :class:`ImplicitStep`.
    """

    name = "implicit"
    settings = SETTINGS  # the tuning (coupling/settings.py); an instance may be given others
    switches = SWITCHES  # (what a comparison turns off)

    carried = LoopState  # what it carries from step to step
    state_names = tuple(field.name for field in fields(LoopState))

    def __init__(self, step=None, tol=None):
        super().__init__(step, tol)
        self.set_carried(self.carried())
        # the solves' own measurements that save the next steps FMU calls (blocks.ReuseCache),
        # and the friction's probe trials, read again only where it moved (evaluations.KnownTrials)
        self.reuse = ReuseCache()
        self.trials = KnownTrials()
        self.pending_commit = None  # the last step's deferred block step (solve_step's defer)

    def expected_gain(self, h: float) -> float:
        """The loop gain a slip step of h [s] should meet: the last one's, scaled by the
        step (the block's response to a force change grows with the step)."""
        return self.loop_gain * h / self.loop_gain_step

    def root_tolerance(self) -> float:
        """How far [m/s] the coupling loop may miss its root while slipping."""
        return self.settings.root_tol_fraction * self.tol * self.scales.velocity

    def carried_state(self) -> LoopState:
        """What it carries to the next step, as one frozen value (:attr:`carried`)."""
        return self.carried(**{name: getattr(self, name) for name in self.state_names})

    def set_carried(self, state: LoopState) -> None:
        for field in fields(state):
            setattr(self, field.name, getattr(state, field.name))

    def export_state(self) -> dict:
        """The algorithm's state as plain values (JSON-able; floats round-trip exactly)."""
        state = asdict(self.carried_state())
        state["scales"] = [self.scales.position, self.scales.velocity, self.scales.period]
        state["counters"] = asdict(self.counters)
        # (they seed the next solve's first guesses: its root lands within its tolerance
        # elsewhere without them, so a continued run would differ in the last digits)
        state.update(self.reuse.export())
        return state

    def import_state(self, state: dict) -> None:
        """Continue from :meth:`export_state`'s values (call after prepare(), which it
        overrides); a state without one of the names is refused (another format)."""
        missing = {*self.state_names, "scales", "counters", "block_slopes", "stick_jacobian"} - set(state)
        if missing:
            raise ValueError(f"{self.name} state lacks {', '.join(sorted(missing))}")
        self.set_carried(self.carried(**{name: state[name] for name in self.state_names}))
        self.scales = Scales(*state["scales"])
        self.counters = Counters(**state["counters"])
        self.reuse = ReuseCache.from_export(state)

    def _solve(self, system, point, saved, h_ns, drive, ramp, predict: bool = True,
               defer: bool = False) -> Point | RetryHeld:
        """One ImplicitStep; keeps what it measured (the loop gain, the block's response).
        predict: the block's answers may be predicted by its learned model (blocks.BlockModel);
        defer: its real step at the answer is then left to :attr:`pending_commit`."""
        h = h_ns / NS
        tuning = self.settings
        reuse = self.reuse
        settings = StepSettings(self.expected_gain(h), self.root_tolerance(), RESOLUTION.zero_velocity * self.scales.velocity,
                                self.scales.position, stepped_trials=self.switches.stepped_trials and self.stick_bounds is None,
                                tuning=tuning, dv_slope_fit=reuse.slope_fit(point.t_ns, int(point.mode), point.aX - point.a),
                                gain_miss=self.gain_miss)
        model = reuse.block.model() if predict else None
        known = self.trials.at((system.friction_n, point.T, point.f))  # (where the friction stands)
        new, report = solve_step(settings, system, point, saved, h_ns, drive, ramp, reuse.block_slopes.get(ramp),
                                 reuse.stick_jacobian, model, known, defer)
        # (taken off the report: commit closes over the step, which holds the report; the
        # step's objects are then freed as soon as the commit is, not by the cycle collector)
        self.pending_commit, report.commit = report.commit, None
        self.counters.iterations += report.iterations
        for answer in report.block_answers:
            reuse.block.observe(*answer)
        if report.guess_miss is not None:
            reuse.guess_miss = (point.t_ns, int(point.mode), report.guess_miss)
        if isinstance(new, RetryUnpredicted):
            # the learned block missed its real step: forget it, and solve the step as if there
            # were none (its measurements, made on the prediction, are dropped)
            reuse.block.forget()
            system.restore_in_step(saved.handles.values())
            return self._solve(system, point, saved, h_ns, drive, ramp, predict=False, defer=defer)
        self.counters.stick_steps += report.stuck and not isinstance(new, RetryHeld)
        if report.loop_gain is not None:
            expected = settings.expected_gain
            self.gain_miss = abs(report.loop_gain / expected - 1.0) if expected > 0.0 else 0.0
            self.loop_gain, self.loop_gain_step = report.loop_gain, h
        if report.velocity_per_impulse is not None:
            self.velocity_per_impulse = report.velocity_per_impulse
        if report.bounds is not None:
            self.stick_bounds = report.bounds
        if report.block_slope is not None:  # (of the family the step ended in: it may go on held)
            reuse.block_slopes[report.block_slope.ramp] = report.block_slope
        if report.stick_jacobian is not None:
            reuse.stick_jacobian = report.stick_jacobian
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
                   saved: States | None = None, defer: bool = False) -> Point:
        """One implicit step of h_ns from point; leaves every slave at the new point.

        ramp_allowed=False holds the force over the step even where a ramp would do. saved:
        the slaves' states at point when the caller holds them already (the step restores the
        block and friction from them and frees nothing); else the step saves and frees its own.
        defer (with saved): where the block's answer was predicted, its real step is left to
        :attr:`pending_commit` (None: it stands at the new point already), which the caller
        calls before it keeps the point, or never where it rolls the step back."""
        self.pending_commit = None
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
                ramp = (ramp_allowed and Contact(point.mode).slipping
                        and self.expected_gain(h) < self.settings.max_ramp_gain)
                defer = defer and not own
                new = self._solve(system, point, saved, h_ns, drive, ramp, defer=defer)
                if isinstance(new, RetryHeld):  # the ramp met stiffness or a transition (rolled back)
                    new = self._solve(system, point, saved, h_ns, drive, False, defer=defer)
            finally:
                if own:
                    system.free(saved)
        system.finish_step(point, new, t, h)
        return new
