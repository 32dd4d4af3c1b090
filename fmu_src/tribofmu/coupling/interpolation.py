"""The one time base and the one interpolation of a run's communication points.

Time in the master is integer nanoseconds (``NS`` per second): steps are added as integers,
never ``t += dt``. Between communication points, positions and velocities are cubic
Hermite interpolants (each has its derivative at both ends: V for X, v for x, the
accelerations for V and v); F, f and the friction's inputs, which may jump, are linear.
The sampler, the energy audit and the adaptive algorithm's interpolation check all use
these functions, so what is checked is what is delivered.

numpy is imported only by the functions on arrays: the TriboPair FMU ships this module for
the scalar ones and runs in host processes that need not load numpy.
"""
from __future__ import annotations

import math

from ..physics.roots import illinois

NS = 1_000_000_000  # nanoseconds per second
# The output grid, every T/1000 (T the drive period): results are sampled on it and, by
# default, the references they are compared with, so that both are on the same times.
SAMPLES_PER_PERIOD = 1000


# A cubic Hermite interpolant misses by up to h^4 / 384 of the function's fourth derivative
# (the interpolation's error bound: a number of the method, not a tuning).
HERMITE_ERROR_DIVISOR = 384.0


def hermite_miss(w2: float, a_start: float, a_end: float, h: float, v_allowed: float,
                 x_allowed: float) -> float:
    """How far the cubic Hermite interpolants of v (slopes a) and x (slopes v) over a step of
    h [s] may miss, relative to what is allowed in v [m/s] and x [m], for a motion whose
    acceleration a (a_start to a_end [m/s^2]) answers its position at w2 [1/s^2]: h^4/384 of
    the fourth derivative, d4v/dt4 ~ w2 (a_end - a_start)/h and d4x/dt4 ~ w2 a."""
    scale = h ** 4 / HERMITE_ERROR_DIVISOR * w2
    v_miss = scale * abs(a_end - a_start) / h  # h^4 w2 |jerk| / 384, as the limits plan
    x_miss = scale * max(abs(a_start), abs(a_end))
    return max(v_miss / v_allowed, x_miss / x_allowed)


def velocity_slopes(start, end) -> tuple[float, float]:
    """dv/dt [m/s^2] at both ends of the step start -> end, as results are interpolated:
    where v follows V over the step, the drive's acceleration; else the block's own, plus how
    far that lags the motion's (``a_lag``: a held step's in a stiff loop, local_errors.py).

    v follows V over a step stuck at both ends, and over one that slips into stick with its
    stick onset at its start. The coupling lands a step on its stick onset, so a step that
    slips into stick has its onset (``end.event``, the fraction of the step) within the event
    margin of one of its ends. Where the onset is at its end, the step slipped all along:
    with the drive's slopes there, a dry block's samples missed by 2.9 % of max|v| on a step
    of 0.0056 T (``bench_trust.py --random 2615:12``, tol 1e-4: 1.1e-3 off, said ok)."""
    if end.mode.stuck and (not start.mode.slipping or 1.0 - end.event > end.event):
        return start.aX, end.aX
    return start.a + start.a_lag, end.a + end.a_lag


def hermite_basis(s):
    """The cubic Hermite basis h00, h10, h01, h11 at s in [0, 1] (floats or arrays)."""
    s2, s3 = s * s, s * s * s
    return 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2


def hermite(y0, y1, dy0, dy1, h, s):
    """The cubic through (0, y0) and (h, y1) with slopes dy0, dy1, at s*h (s in [0, 1])."""
    h00, h10, h01, h11 = hermite_basis(s)
    return h00 * y0 + h10 * h * dy0 + h01 * y1 + h11 * h * dy1


def hermite_mid(y0, y1, dy0, dy1, h):
    """:func:`hermite` at the middle of the step (s = 1/2)."""
    return 0.5 * (y0 + y1) + h / 8.0 * (dy0 - dy1)


def hermite_first_below(y0: float, y1: float, dy0: float, dy1: float, h: float, level: float,
                        xtol: float) -> float | None:
    """The first s in (0, 1] at which :func:`hermite` (y0 to y1, slopes dy0, dy1 over h) falls
    to level (0 if y0 is below it already), to xtol in s; None where it stays at or above
    level all through. Exact, not sampled: the cubic's derivative is a quadratic, so its
    extrema are in closed form; the first extremum below level brackets the crossing with the
    point before it (the start, or the extremum before), on which the cubic is monotone, and
    the bracketed root finder locates it there."""
    if y0 < level:
        return 0.0
    # the cubic in s: y0 + c1 s + c2 s^2 + c3 s^3 (hermite_basis expanded)
    c1 = h * dy0
    c2 = 3.0 * (y1 - y0) - h * (2.0 * dy0 + dy1)
    c3 = 2.0 * (y0 - y1) + h * (dy0 + dy1)
    cubic = lambda s: y0 + s * (c1 + s * (c2 + s * c3)) - level
    lo = 0.0
    for s in _quadratic_roots(3.0 * c3, 2.0 * c2, c1):
        if 0.0 < s < 1.0 and cubic(s) < 0.0:
            return illinois(cubic, lo, s, cubic(lo), cubic(s), xtol=xtol, rtol=0.0)
        lo = max(lo, min(s, 1.0))
    if cubic(1.0) < 0.0:  # (no extremum below level: it falls through level to the end)
        return illinois(cubic, lo, 1.0, cubic(lo), cubic(1.0), xtol=xtol, rtol=0.0)
    return None


def _quadratic_roots(a: float, b: float, c: float) -> list[float]:
    """The real roots of a s^2 + b s + c, ascending (the linear one where a = 0, none where
    the quadratic has none or is constant); the cancellation-free form of the formula."""
    if a == 0.0:
        return [-c / b] if b != 0.0 else []
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return []
    q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
    roots = [q / a, c / q] if q != 0.0 else [0.0]
    return sorted(roots)


SIGNALS = ("X", "V", "x", "v", "F", "f", "stuck")  # what sample() returns
INPUT_SIGNALS = ("T", "n", "Q")  # the friction's inputs from other FMUs, and the heat received


def sample(points, grid: np.ndarray, inputs: bool = False) -> dict[str, np.ndarray]:
    """The run's signals on the time grid [s] (grid inside the points' span).

    ``stuck`` is 1.0 where the coupling held the blocks together over the step containing
    the sample (its own state, exact, not a velocity threshold), else 0.0. With inputs,
    also T [K], n [Pa] and Q [J] (linear).
    """
    import numpy as np

    # float64, not int64: exact below 2**53 ns (104 days), and no OverflowError beyond
    t = np.array([p.t_ns for p in points], dtype=np.float64) / NS
    get = lambda name: np.array([getattr(p, name) for p in points])
    X, V, aX, x, v, a = (get(k) for k in ("X", "V", "aX", "x", "v", "a"))
    slopes = np.array([velocity_slopes(p0, p1) for p0, p1 in zip(points, points[1:])])
    v_left, v_right = slopes[:, 0], slopes[:, 1]
    out = {"X": _hermite_on(t, X, V[:-1], V[1:], grid), "V": _hermite_on(t, V, aX[:-1], aX[1:], grid),
           "x": _hermite_on(t, x, v[:-1], v[1:], grid), "v": _hermite_on(t, v, v_left, v_right, grid),
           "F": np.interp(grid, t, get("F")), "f": np.interp(grid, t, get("f")),
           "stuck": _stuck(t, get("mode"), grid)}
    if inputs:
        out.update({k: np.interp(grid, t, get(k)) for k in INPUT_SIGNALS})
    return out


def _stuck(t: np.ndarray, mode: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """1.0 where the step (t[i], t[i+1]] holding the sample ended stuck (mode 0)."""
    import numpy as np

    i = np.clip(np.searchsorted(t, grid, side="left"), 1, len(t) - 1)
    return (mode[i] == 0).astype(float)


def _hermite_on(t: np.ndarray, y: np.ndarray, dy_left: np.ndarray, dy_right: np.ndarray,
                grid: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite on the grid; dy_left[i], dy_right[i]: slopes of step i."""
    import numpy as np

    i = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
    h = t[i + 1] - t[i]
    return hermite(y[i], y[i + 1], dy_left[i], dy_right[i], h, (grid - t[i]) / h)
