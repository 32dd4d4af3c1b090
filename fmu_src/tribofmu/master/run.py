"""Run a coupling algorithm over a time span and sample the result on a uniform grid."""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np

from .algorithms import NS, CouplingAlgorithm, Scales, velocity_slopes
from .slave import FMUCallError
from .system import CoupledSystem, Point

COLUMNS = ("X", "V", "x", "v", "F", "f", "stuck")


@dataclass(frozen=True)
class RunProgress:
    """What a progress callback is told after each accepted step."""

    t: float  # simulated time reached [s]
    stop_time: float  # s
    steps: int  # accepted communication steps so far
    rejected: int  # rejected (rolled-back) steps so far
    wall_time: float  # s since the run started

    @property
    def fraction(self) -> float:
        return self.t / self.stop_time if self.stop_time > 0 else 1.0


@dataclass
class RunOutcome:
    """Communication points of a run, how it ended, and what it cost."""

    points: list[Point]
    ok: bool
    message: str
    wall_time: float  # s
    counters: dict = field(default_factory=dict)
    calls: dict = field(default_factory=dict)


def run(system: CoupledSystem, algorithm: CouplingAlgorithm, stop_time: float, scales: Scales,
        progress=None) -> RunOutcome:
    """Advance from t = 0 to stop_time [s] in integer nanoseconds.

    A numerical failure (an FMU discarding a step that no smaller step fixes, a NaN) ends
    the run with ok=False and a message naming the instance; the points so far are kept.
    """
    stop_ns = int(round(stop_time * NS))
    algorithm.prepare(system, scales)
    begin = _time.perf_counter()
    points = [system.start_point()]
    ok, message = True, "completed"
    try:
        while points[-1].t_ns < stop_ns:
            new = algorithm.advance(system, points[-1], stop_ns)
            for p in new:
                if not all(np.isfinite((p.x, p.v, p.F, p.f))):
                    raise FloatingPointError(f"non-finite state at t = {p.t_ns / NS:.9g} s: "
                                             f"x={p.x}, v={p.v}, F={p.F}, f={p.f}")
            points.extend(new)
            if progress is not None and new:
                c = algorithm.counters
                progress(RunProgress(new[-1].t_ns / NS, stop_ns / NS, c.steps, c.rejected,
                                     _time.perf_counter() - begin))
    except FMUCallError as exc:
        ok, message = False, f"stopped at t = {points[-1].t_ns / NS:.9g} s: {exc}"
    except FloatingPointError as exc:
        ok, message = False, str(exc)
    wall = _time.perf_counter() - begin
    c = algorithm.counters
    return RunOutcome(points, ok, message, wall,
                      counters=dict(steps=c.steps, rejected=c.rejected, iterations=c.iterations,
                                    forced=c.forced, stick_steps=c.stick_steps),
                      calls=system.calls)


def sample(points: list[Point], grid: np.ndarray) -> dict[str, np.ndarray]:
    """The run's signals on the time grid [s].

    Positions and velocities are cubic Hermite interpolants between communication points
    (each has its derivative at both ends: V for X, v for x, the accelerations for V and v;
    over a step that ends stuck, v follows V, so its slope is the drive's acceleration);
    F and f, which may jump, are interpolated linearly. ``stuck`` is 1.0 where the coupling
    held the blocks together over the step containing the sample (its own state, exact, not
    a velocity threshold), else 0.0.
    """
    t = np.array([p.t_ns for p in points], dtype=np.int64) / NS
    get = lambda name: np.array([getattr(p, name) for p in points])
    X, V, aX, x, v, a = (get(k) for k in ("X", "V", "aX", "x", "v", "a"))
    slopes = np.array([velocity_slopes(p0, p1) for p0, p1 in zip(points, points[1:])])
    v_left, v_right = slopes[:, 0], slopes[:, 1]
    return {"X": _hermite(t, X, V[:-1], V[1:], grid), "V": _hermite(t, V, aX[:-1], aX[1:], grid),
            "x": _hermite(t, x, v[:-1], v[1:], grid), "v": _hermite(t, v, v_left, v_right, grid),
            "F": np.interp(grid, t, get("F")), "f": np.interp(grid, t, get("f")),
            "stuck": _stuck(t, get("mode"), grid)}


def _stuck(t: np.ndarray, mode: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """1.0 where the step (t[i], t[i+1]] holding the sample ended stuck (mode 0)."""
    i = np.clip(np.searchsorted(t, grid, side="left"), 1, len(t) - 1)
    return (mode[i] == 0).astype(float)


def _hermite(t: np.ndarray, y: np.ndarray, dy_left: np.ndarray, dy_right: np.ndarray,
             grid: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation; dy_left[i], dy_right[i]: slopes at the ends of step i."""
    i = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
    h = t[i + 1] - t[i]
    s = (grid - t[i]) / h
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    return h00 * y[i] + h10 * h * dy_left[i] + h01 * y[i + 1] + h11 * h * dy_right[i]
