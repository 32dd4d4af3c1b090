"""What bounds an adaptive step apart from its error estimate (coupling/embedded.py): the
results' interpolants between communication points (the block's and the drive's cubic Hermite
curves, which a step too long for them misses by h^4/384 of the fourth derivative) and a
breakaway the last stick ramp predicts. Planned ahead where they can be (a limit on the next
step), checked on the step taken where they cannot.

A mixin of :class:`~.embedded.EmbeddedCoupling`: it reads the coupling's tol, scales, controller,
estimate (the block's w2), its force history and stick bounds.
"""
from __future__ import annotations

import math

from .interpolation import HERMITE_ERROR_DIVISOR, NS, hermite_miss
from .system import Point


class StepLimits:
    """The interpolants' bounds on a step, and the breakaway a stick ramp predicts."""

    def predicted_breakaway(self, point: Point) -> float | None:
        """Stuck, with the stick force ramping at F_rate: the time [s] at which the ramp
        reaches the friction's bound (the last stuck step's probes), or None."""
        bounds = self.stick_bounds
        if not point.mode.stuck or bounds is None or point.F_rate == 0.0:
            return None
        bound = bounds[1] if point.F_rate > 0.0 else bounds[0]
        reach = (bound - point.F) / point.F_rate
        return reach if reach > 0.0 else None

    def interpolation_limit(self, point: Point) -> float:
        """The longest step [s] whose interpolants should stay within tol (see
        :meth:`interpolation_error`), from the block's jerk over the last step: planned
        ahead, so that the interpolation bound shortens steps instead of rejecting them; and
        in any mode the drive's own interpolants' (:meth:`drive_interpolation_limit`)."""
        drive = self.drive_interpolation_limit(point)
        w2 = self.estimate.w2
        if w2 <= 0.0:
            return drive
        # (planned from the last step's jerk, not this one's: the controller's safety on the step,
        # which is on the error to the bound's h^4)
        room_v = self.controller.safety ** 4 * HERMITE_ERROR_DIVISOR * self.tol * self.velocity_scale(point) / w2
        room_x = self.controller.safety ** 4 * HERMITE_ERROR_DIVISOR * self.tol * self.position_scale(point) / w2
        if not point.mode.slipping:
            breakaway = self.predicted_breakaway(point)
            if breakaway is None or breakaway > self.h_ns / NS:
                return drive  # (stuck: v and x move with the drive)
            # stuck at (or near) the bound: the step will slip from its start, at most a
            # fraction of the block's period (see error_ratio)
            return min(drive, self.errors.block_period_fraction * 2.0 * math.pi / math.sqrt(w2))
        # the ends of a step as long as the block's own period can look alike (a slow dry
        # drive's slip phases: fig2's rig at omega = 10, 6.4e-2 nRMS(v) without this cap)
        limits = [drive, self.errors.block_period_fraction * 2.0 * math.pi / math.sqrt(w2)]
        if self.history.h > 0.0 and self.history.jerk != 0.0:  # a slip step of this mode
            limits.append((room_v / abs(self.history.jerk)) ** 0.25)
        if point.a != 0.0:
            limits.append((room_x / abs(point.a)) ** 0.25)
        return min(limits)

    def drive_w2(self) -> float:
        """The drive's angular frequency squared [1/s^2], from the scene's period."""
        return (2.0 * math.pi / self.scales.period) ** 2

    def drive_interpolation_limit(self, point: Point) -> float:
        """The longest step [s] whose interpolants of the drive's motion (see
        :meth:`stuck_interpolation_error`) stay within tol, planned from the point (a harmonic
        drive's jerk is -w^2 V, the fourth derivative of its X is -w^2 aX): stuck, the block's v
        and x against its motion; slipping, the drive's V and X against the scene's scales."""
        w2 = self.drive_w2()
        room = self.controller.safety ** 4 * HERMITE_ERROR_DIVISOR * self.tol / (w2 * w2)
        v_scale, x_scale = ((self.velocity_scale(point), self.position_scale(point)) if point.mode.stuck
                            else (self.scales.velocity, self.scales.position))
        limits = [math.inf]
        if point.V != 0.0:
            limits.append((room * v_scale / abs(point.V)) ** 0.25)
        if point.aX != 0.0:
            limits.append((room * w2 * x_scale / abs(point.aX)) ** 0.25)
        return min(limits)

    def stuck_interpolation_error(self, point: Point, new: Point, h: float, v_scale: float,
                                  x_scale: float) -> float:
        """Stuck all through, v is the drive's V interpolated with the drive's acceleration and
        x moves with the drive's X (slopes V): the cubic Hermite bound, h^4/384 of the fourth
        derivative (w^2 |d aX/dt| for V, w^2 |aX| for X, w the drive's own frequency),
        relative to tol. (The breakaway's timing, which bounded these steps too, counts only
        near the friction's bound: far from it a stick kept its steps at the longest, then T/20, in
        both runs of a check, which then agreed on 1e-5 of interpolation error and reported 0.)"""
        return hermite_miss(self.drive_w2(), point.aX, new.aX, h, self.tol * v_scale, self.tol * x_scale)

    def interpolation_error(self, point: Point, new: Point, h: float, v_scale: float, x_scale: float) -> float:
        """How far the cubic Hermite interpolants of v (slopes a) and x (slopes v) may miss
        between the two points, relative to tol: results are sampled between communication
        points. A cubic Hermite misses by up to h^4/384 of the fourth derivative; for the
        block (a = F/M - w2 x, w2 = 2K/M as the estimate learned it) with the force changing
        slowly, d4v/dt4 ~ w2 da/dt ~ w2 (a1 - a0)/h and d4x/dt4 ~ w2 a. (Step doubling compared
        the interpolant with its computed midpoint; one solve has no midpoint.)"""
        w2 = self.estimate.w2
        if w2 <= 0.0:
            return 0.0
        return hermite_miss(w2, point.a, new.a, h, self.tol * v_scale, self.tol * x_scale)
