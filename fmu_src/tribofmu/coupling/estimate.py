"""A run's own accuracy: the steps' local error estimates carried to a global error in v.

Step doubling tells how wrong each accepted step is (its local error); what a user sees is
the global error, the local errors of all earlier steps carried forward by the motion. The
block is a mass on springs under a friction force that depends on the relative velocity,
so an error (ex [m], ev [m/s]) in its state moves, to first order, as

    ex' = ev,    ev' = -w2 ex - c ev,

w2 = 2K/M [1/s^2] (the springs over the mass) and c = (dF/d(dv)) / M [1/s] (the friction's
slope over the mass: the damping the friction adds to an error). The coupling knows neither
K nor M; it measures both from the block's own answers (its velocity per unit impulse, its
acceleration against its position) and c from the loop gain of each slip step. A stuck
contact holds v = V exactly: no error in v while stuck. Events (breakaway, stick onset, a
lubricant that re-solidifies inside a step) enter through the local errors of the steps that
hold them.

:class:`WindowError` turns the carried error into the measure --tol bounds (docs/coupling.md): the RMS of
the error in v over the scene's shown window, divided by the largest |v| there.
"""
from __future__ import annotations

import cmath
import math

from .interpolation import NS


class GlobalErrorEstimate:
    """The carried error (ex [m], ev [m/s]) and what it needs of the block."""

    def __init__(self):
        self.ex = self.ev = 0.0
        self.w2 = 0.0  # 1/s^2, 2K/M as last measured (0: not yet)

    def observe(self, x: float, a: float, F: float, velocity_per_impulse: float, x_floor: float) -> None:
        """Learn w2 from a point: a = F/M - w2 x, with 1/M the block's velocity per unit impulse
        (x [m] beyond x_floor [m], so that round-off in x does not decide)."""
        if (velocity_per_impulse > 0.0 or F == 0.0) and abs(x) > x_floor:  # (no force: a = -w2 x)
            w2 = (F * velocity_per_impulse - a) / x
            if w2 > 0.0:
                self.w2 = w2

    def advance(self, h: float, damping: float, local_x: float, local_v: float, stuck: bool,
                x_scale: float = math.inf, v_scale: float = math.inf) -> float:
        """Carry the error over a step of h [s] with the friction's damping c [1/s], add the
        step's local errors (x [m], v [m/s]); returns the error in v [m/s] at its end.

        The carried error saturates at the motion's own size (x_scale [m], v_scale [m/s]):
        a linearised carry is meaningless past it (a stiff spring whose 2K/M the block's
        answers give only roughly would otherwise let it grow without bound)."""
        ex, ev = self._flow(h, damping)
        self.ex = max(-x_scale, min(x_scale, ex + local_x))
        self.ev = 0.0 if stuck else max(-v_scale, min(v_scale, ev + local_v))
        return self.ev

    def _flow(self, h: float, c: float) -> tuple[float, float]:
        """exp(A h) (ex, ev) for A = [[0, 1], [-w2, -c]], in closed form."""
        w2, ex, ev = self.w2, self.ex, self.ev
        root = cmath.sqrt(0.25 * c * c - w2)
        l1, l2 = -0.5 * c + root, -0.5 * c - root
        if abs(l1 - l2) <= 1e-9 * (abs(l1) + abs(l2)) or abs(l1 - l2) * h < 1e-9:
            lam = 0.5 * (l1 + l2)  # a double eigenvalue: exp(A h) = e^(lam h) (I + (A - lam) h)
            e = cmath.exp(lam * h)
            nx = e * (ex + h * (-lam * ex + ev))
            nv = e * (ev + h * (-w2 * ex + (-c - lam) * ev))
            return nx.real, nv.real
        # exp(A h) = (e^(l1 h) (A - l2) - e^(l2 h) (A - l1)) / (l1 - l2); a stiff l2 underflows to 0
        e1 = cmath.exp(l1 * h)
        e2 = cmath.exp(l2 * h) if (l2 * h).real > -700.0 else 0.0
        d = l1 - l2
        ax, av = ev, -w2 * ex - c * ev  # A (ex, ev)
        nx = (e1 * (ax - l2 * ex) - e2 * (ax - l1 * ex)) / d
        nv = (e1 * (av - l2 * ev) - e2 * (av - l1 * ev)) / d
        return nx.real, nv.real


class WindowError:
    """Audit of the estimated global error in v over a window [start, end] [s]: fed the
    points in chunks (``add``), it gives RMS(error in v) / max |v| on the window."""

    def __init__(self, window: tuple[float, float]):
        self.start, self.end = window
        self.square_integral = 0.0  # (m/s)^2 s
        self.covered = 0.0  # s
        self.v_max = 0.0  # m/s
        self.previous = None  # (t [s], error [m/s]) of the last point seen

    def add(self, points) -> None:
        for p in points:
            t, e = p.t_ns / NS, p.global_error
            if self.previous is not None and self.previous[0] < t:
                t0, e0 = self.previous
                lo, hi = max(t0, self.start), min(t, self.end)
                if hi > lo:
                    # the error moves linearly between points: the exact mean of its square
                    a = e0 + (e - e0) * (lo - t0) / (t - t0)
                    b = e0 + (e - e0) * (hi - t0) / (t - t0)
                    self.square_integral += (hi - lo) * (a * a + a * b + b * b) / 3.0
                    self.covered += hi - lo
            if self.start <= t <= self.end:
                self.v_max = max(self.v_max, abs(p.v))
            self.previous = (t, e)

    def nrms(self) -> float:
        """The estimate (nan when the run did not cover the window or v is 0 there)."""
        if self.covered <= 0.0 or self.v_max == 0.0:
            return math.nan
        return math.sqrt(self.square_integral / self.covered) / self.v_max
