"""The step-doubling coupling (``doubling``), the adaptive coupling before issue 31: kept out of
the package, for benchmarks that compare it with the embedded estimate (``bench_floor.py
--algorithms adaptive,doubling``, ``fingerprint.py``). Importing this module registers it in
``tribofmu.coupling.algorithms.ALGORITHMS`` for the run in this process (the API, the scene's
check of ``simulation.algorithm``; FMUs and other processes do not know it).

Each step is solved once whole and once in two halves: three implicit solves per two accepted
steps; their difference is the error estimate.
"""
from __future__ import annotations

from tribofmu.coupling.algorithms import ALGORITHMS
from tribofmu.coupling.controlled import W2_POSITION_FLOOR, ErrorControlledCoupling, grazing_crossing
from tribofmu.coupling.interpolation import NS, hermite_mid, velocity_slopes
from tribofmu.coupling.system import Point


class StepDoublingCoupling(ErrorControlledCoupling):
    """Implicit steps under error control by step doubling (the adaptive coupling before
    issue 31; registered as ``doubling`` by importing this module, for comparison with
    coupling/embedded.py's).

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
            crossing = self._grazing(point, mid, end, h_ns)
            if crossing is not None and self._landed_at_crossing(system, start, h_ns, crossing):
                return []  # a stick or a reversal the halves pass over: end the step there
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
        return error

    def _grazing(self, start: Point, mid: Point, end: Point, h_ns: int) -> float | None:
        """The fraction of the step at which either half's interpolated dv first crosses 0 by
        more than tol (a stick or a reversal the halves pass over), or None."""
        if not (start.mode.slipping and start.mode == mid.mode == end.mode):
            return None
        h, margin = 0.5 * h_ns / NS, self.tol * self.velocity_scale(mid, end)
        for offset, (a, b) in ((0.0, (start, mid)), (0.5, (mid, end))):
            crossing = grazing_crossing(a, b, h, margin)
            if crossing is not None:
                return offset + 0.5 * crossing
        return None

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


def register() -> None:
    """Make ``doubling`` a registered algorithm name in this process."""
    ALGORITHMS.setdefault("doubling", StepDoublingCoupling)
