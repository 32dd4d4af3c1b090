"""The measure ``--tol`` bounds, estimated from a run's own carried error (:class:`WindowError`):
the RMS of the error in v over the scene's shown window, divided by the largest |v| there
(docs/coupling.md). The carried error itself is coupling/estimate.py's."""
from __future__ import annotations

import math

from .interpolation import NS, velocity_slopes


def interpolant_jerk(start, end) -> float:
    """The third derivative [m/s^4] of the cubic Hermite interpolant of v over the step from
    point start to point end (constant on the step), as results are interpolated."""
    h = (end.t_ns - start.t_ns) / NS
    slope_start, slope_end = velocity_slopes(start, end)
    return 6.0 * (h * (slope_start + slope_end) - 2.0 * (end.v - start.v)) / h ** 3


def step_kind(start, end) -> int | None:
    """Steps whose interpolants may be compared: stuck all through (0), slipping one way all
    through (its direction), else None (the contact changed: a kink no cubic follows)."""
    if start.mode.stuck and end.mode.stuck:
        return 0
    return int(end.mode) if end.mode.slipping and start.mode == end.mode else None


def fourth_derivative(jerk: float, h: float, other_jerk: float, other_h: float) -> float:
    """|v''''| [m/s^5] from two adjacent steps' interpolant third derivatives (each that at its
    step's middle, to second order) and the steps' lengths h [s]."""
    return abs(jerk - other_jerk) / (0.5 * (h + other_h))


def linear_square_integral(a: float, b: float, length: float) -> float:
    """The integral of the square of a quantity moving linearly from a to b over length: the
    exact length (a^2 + a b + b^2) / 3."""
    return length * (a * a + a * b + b * b) / 3.0


def bubble_square(u: float) -> float:
    """The integral of (u (1 - u))^2 from 0 to u (1/30 at u = 1)."""
    return u ** 3 / 3.0 - u ** 4 / 2.0 + u ** 5 / 5.0


def hermite_miss_square(u: float) -> float:
    """The integral of (u^2 (1 - u)^2)^2 from 0 to u: the cubic Hermite interpolant's miss,
    v''''/24 h^4 u^2 (1 - u)^2, squared (1/630 at u = 1: the Beta function B(5, 5))."""
    return u ** 5 / 5.0 - 2.0 * u ** 6 / 3.0 + 6.0 * u ** 7 / 7.0 - u ** 8 / 2.0 + u ** 9 / 9.0


class WindowError:
    """Audit of the estimated global error in v over a window [start, end] [s]: fed the
    points in chunks (``add``), it gives RMS(error in v) / max |v| on the window.

    Three parts add as squares (the carried error's sign is not known well enough to let them
    cancel): the carried error (``global_error`` of the points, linear between them); the
    interpolants' own miss inside each step, v''''/24 s^2 (h - s)^2, v'''' the divided
    difference of the interpolants' third derivatives over the step and the one before it of
    the same kind (:func:`step_kind`; for the first of its kind, the one after); and, for a
    friction with state, the error inside a slip step beyond the line of its ends' carried
    errors, 4 e u (1 - u) with e the path's at the middle (``inside_error``,
    coupling/path_error.py: where a stiff loop's ramp rings, the points' forces alternate
    about the true one, the ends agree and the middle does not; a solid lubricant's runs read
    0.14-0.25x their true error without it, 1.4-1.8x with it). A step across a change of
    contact mode has no interpolation term: its kink is the event's, whose timing the local
    errors carry."""

    def __init__(self, window: tuple[float, float]):
        self.start, self.end = window
        self.square_integral = 0.0  # (m/s)^2 s
        self.covered = 0.0  # s
        self.v_max = 0.0  # m/s
        self.previous = None  # the last point seen
        self.last_step = None  # (kind, jerk [m/s^4], h [s]) of the last step
        self.waiting = None  # the last step if none before it was of its kind: (p0, p1, kind, jerk, h)

    def add(self, points) -> None:
        for p in points:
            if self.previous is not None and self.previous.t_ns < p.t_ns:
                self._step(self.previous, p)
            if self.start <= p.t_ns / NS <= self.end:
                self.v_max = max(self.v_max, abs(p.v))
            self.previous = p

    def _step(self, p0, p1) -> None:
        kind = step_kind(p0, p1)
        jerk = interpolant_jerk(p0, p1) if kind is not None else 0.0
        h = (p1.t_ns - p0.t_ns) / NS
        if self.waiting is not None:  # this step is the one after it, if of its kind
            w0, w1, w_kind, w_jerk, w_h = self.waiting
            self._add_step(w0, w1, fourth_derivative(w_jerk, w_h, jerk, h) if w_kind == kind else 0.0)
            self.waiting = None
        last = self.last_step
        if kind is None:
            self._add_step(p0, p1, 0.0)
        elif last is not None and last[0] == kind:
            self._add_step(p0, p1, fourth_derivative(jerk, h, last[1], last[2]))
        else:
            self.waiting = (p0, p1, kind, jerk, h)
        self.last_step = (kind, jerk, h)

    def _add_step(self, p0, p1, fourth: float) -> None:
        square, covered = self._step_square(p0, p1, fourth)
        self.square_integral += square
        self.covered += covered

    def _step_square(self, p0, p1, fourth: float) -> tuple[float, float]:
        """The integral [(m/s)^2 s] of the squared error over the part of the step p0 -> p1
        inside the window, with v'''' = fourth [m/s^5]; and that part's length [s]."""
        t0, t1 = p0.t_ns / NS, p1.t_ns / NS
        lo, hi = max(t0, self.start), min(t1, self.end)
        if hi <= lo:
            return 0.0, 0.0
        e0, e1 = p0.global_error, p1.global_error
        # the carried error moves linearly between points: the exact integral of its square
        a = e0 + (e1 - e0) * (lo - t0) / (t1 - t0)
        b = e0 + (e1 - e0) * (hi - t0) / (t1 - t0)
        square = linear_square_integral(a, b, hi - lo)
        h = t1 - t0
        if fourth:
            peak = fourth * h ** 4 / 24.0  # the interpolant misses by peak u^2 (1 - u)^2, u = s / h
            square += peak * peak * h * (hermite_miss_square((hi - t0) / h) - hermite_miss_square((lo - t0) / h))
        if p1.inside_error:  # the error inside the step, 4 e u (1 - u) (e at the middle)
            peak = 4.0 * p1.inside_error
            square += peak * peak * h * (bubble_square((hi - t0) / h) - bubble_square((lo - t0) / h))
        return square, hi - lo

    def nrms(self) -> float:
        """The estimate (nan when the run did not cover the window or v is 0 there)."""
        square, covered = self.square_integral, self.covered
        if self.waiting is not None:  # the last step, none of its kind around it: its carried part
            more = self._step_square(self.waiting[0], self.waiting[1], 0.0)
            square, covered = square + more[0], covered + more[1]
        if covered <= 0.0 or self.v_max == 0.0:
            return math.nan
        return math.sqrt(square / covered) / self.v_max
