"""Run a coupling algorithm over a time span: the loop, what it keeps, and when it gives up.

The loop hands every accepted communication point to a recorder. :class:`PointList` keeps
them all (for studies of the points themselves); :class:`GridRecorder` samples them on the
output grid and audits energy chunk by chunk, so a long run holds only its output, not its
communication points. The loop also watches its own pace (:class:`Pace`): a run that has gone
past ``limits.max_wall``, or whose projected wall time goes past it at its recent pace as well
as at its average one, stops with a message saying where it was and what to change, and one
projected past ``limits.notice_after`` says up front what it will cost.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..errors import NumericalError, RunawayError  # noqa: F401 (RunawayError re-exported)
from ..coupling.algorithms import CouplingAlgorithm, Scales
from ..coupling.interpolation import INPUT_SIGNALS, NS, SIGNALS, sample
from .instance import FMUCallError
from ..coupling.system import CoupledSystem, Point


@dataclass(frozen=True)
class RunProgress:
    """What a progress callback is told after each accepted step."""

    t: float  # simulated time reached [s]
    stop_time: float  # s
    steps: int  # accepted communication steps so far
    rejected: int  # rejected (rolled-back) steps so far
    wall_time: float  # s since the run started
    # the run's per-step tolerance now: tighter than asked once its lead-in tightened it for its
    # window (coupling/lead_in.py); None: a coupling without one
    step_tol: float | None = None
    # whether the run aims at its window (a lead-in: coupling/lead_in.py), and whether by its
    # lead-in's latest mark it can still meet the window's budget (None: not measured yet); a
    # call starts a next run ahead of it only once it cannot (tribofmu/forked_runs.py)
    aims_at_window: bool = False
    window_reachable: bool | None = None

    @property
    def fraction(self) -> float:
        return self.t / self.stop_time if self.stop_time > 0 else 1.0


@dataclass(frozen=True)
class RunLimits:
    """When a run speaks up about its cost, and when it gives up (wall-clock seconds).

    The pace is judged every ``judge_after`` seconds of the run (see :class:`Pace`); a
    projection stops a run only once it has spent ``projection_share`` of max_wall: a slow
    stretch shorter than that (a collapse from rest) is waited out, and the recent pace judged
    after it."""

    max_wall: float | None = 1800.0  # stop past this, or when the projected total exceeds it (None: never)
    notice_after: float = 120.0  # say what the run will cost when its projection exceeds this
    judge_after: float = 3.0  # s, the length of one judged interval
    projection_share: float = 0.1  # of max_wall: before it, only max_wall itself stops a run


class Pace:
    """A run's pace, judged over intervals of ``limits.judge_after`` wall seconds: the recent
    pace is the last whole interval's (wall seconds per simulated second), the average pace
    the whole run's so far. The projected total is the wall time so far plus the span still to
    go at the better (faster) of the two: a run slow at its start (a collapse from rest, then
    normal steps) is judged by what it does now, and one slowed down only lately by what it
    did on average, until it actually goes past max_wall. A projection past max_wall stops
    the run only once it has spent ``limits.projection_share`` of max_wall (at its start the
    recent pace is the slow start's own). (Projected from the average pace alone after 3 s,
    a run whose first seconds crawled was stopped although it would have finished in time:
    fig6_boundary at gamma = -0.85, K = 2000, tol 1e-4, issue 36.) The notice is told once two
    judged intervals in a row project past ``limits.notice_after``."""

    def __init__(self, stop_ns: int, limits: RunLimits, notice: Callable[[str], None] | None = None):
        self.stop_ns, self.limits, self.notice = stop_ns, limits, notice
        self.mark_wall, self.mark_ns = 0.0, 0  # where the interval being timed began
        self.recent: float | None = None  # wall s per simulated s over the last whole interval
        self.judged: list[float] = []  # the projections [s] at the ends of the last two intervals
        self.noticed = False

    def projected(self, wall: float, t_ns: int) -> float | None:
        """The projected total wall time [s] at wall [s] and simulated t_ns, or None before a
        whole interval has been timed (or at the stop)."""
        timed = wall - self.mark_wall >= self.limits.judge_after and t_ns > self.mark_ns
        if timed:
            self.recent = (wall - self.mark_wall) / (t_ns - self.mark_ns)
            self.mark_wall, self.mark_ns = wall, t_ns
        if self.recent is None or t_ns <= 0 or t_ns >= self.stop_ns:
            return None
        projected = wall + (self.stop_ns - t_ns) * min(self.recent, wall / t_ns)
        if timed:
            self.judged = self.judged[-1:] + [projected]
        return projected

    def judge(self, wall: float, t_ns: int, where: Callable[[], str]) -> None:
        """Raise RunawayError when the run at wall [s] and t_ns is past max_wall or projected
        past it; tell notice once when it is projected past notice_after. where(): the
        run's state for the message (the step, the steps and rejections so far)."""
        max_wall = self.limits.max_wall
        projected = self.projected(wall, t_ns)
        over = max_wall is not None and t_ns < self.stop_ns and wall > max_wall
        if projected is None and not over:
            return
        if projected is None:  # past max_wall before a whole interval was timed: the average
            projected = wall * self.stop_ns / t_ns
        projected = max(projected, wall)
        judged = max_wall is not None and wall >= self.limits.projection_share * max_wall
        if over or (judged and projected > max_wall):
            # (a checked call's later runs get what its earlier ones left of --max-wall)
            past = " (past --max-wall, counted from the call's start)" if over else ""
            raise RunawayError(
                f"stopped at t = {t_ns / NS:.6g} s of {self.stop_ns / NS:.6g} s after "
                f"{_duration(wall)}{past}: at this pace the run would take "
                f"{_duration(projected)} ({where()}); loosen --tol, shorten time.periods, or allow "
                f"more with --max-wall")
        # told when two intervals in a row project past notice_after: not on one slow stretch
        if (self.notice is not None and not self.noticed and len(self.judged) == 2
                and min(self.judged) > self.limits.notice_after):
            self.noticed = True
            self.notice(f"this run will take about {_duration(projected)} at its present pace "
                        f"({where()}); to shorten it, loosen --tol or reduce time.periods")


@dataclass
class RunOutcome:
    """How a run ended, what it cost, and what its recorder kept."""

    points: list[Point]  # every point (PointList), or only the first and last (GridRecorder)
    ok: bool
    message: str
    wall_time: float  # s
    counters: dict = field(default_factory=dict)
    calls: dict = field(default_factory=dict)
    out_of_time: bool = False  # stopped past limits.max_wall, or because its pace projected past it
    calls_by_kind: dict = field(default_factory=dict)  # stepping calls summed over the FMUs by kind


class PointList:
    """Keeps every communication point."""

    def __init__(self):
        self.points: list[Point] = []

    def add(self, point: Point) -> None:
        self.points.append(point)

    def finish(self) -> None:
        pass

    def kept(self) -> list[Point]:
        return self.points


class GridRecorder:
    """Samples the points on the time grid [s] as they come and feeds them, in chunks, to
    ``audits`` (objects with ``add(points)``, e.g. the energy audit); memory stays bounded
    by the grid, whatever the number of communication points.

    inputs: also sample T, n, Q (the friction's inputs from other FMUs). keep_points: also
    keep every point (memory then grows with the run). sink(start, signals): told every
    sampled stretch as it is done (``signals[k]`` holds grid samples ``start, start + 1, ...``,
    ``signals["time"]`` their times),
    e.g. to stream rows to a file. keep: the range ``(first, stop)`` of grid indices kept in
    memory (default: all); with a sink and a short range, memory does not grow with the run."""

    CHUNK = 4096  # points held before they are sampled and dropped

    def __init__(self, grid: np.ndarray, audits=(), inputs: bool = False, keep_points: bool = False,
                 sink: Callable[[int, dict], None] | None = None, keep: tuple[int, int] | None = None):
        self.grid = np.asarray(grid, dtype=float)
        self.points: list[Point] | None = [] if keep_points else None
        self.audits, self.inputs, self.sink = list(audits), inputs, sink
        self.keep = (0, len(self.grid)) if keep is None else (max(0, keep[0]), min(len(self.grid), keep[1]))
        names = SIGNALS + (INPUT_SIGNALS if inputs else ())
        size = max(self.keep[1] - self.keep[0], 0)
        self.signals = {k: np.full(size, np.nan) for k in names}
        self.filled = 0  # grid samples done
        self.buffer: list[Point] = []
        self.first: Point | None = None

    def add(self, point: Point) -> None:
        if self.first is None:
            self.first = point
        if self.points is not None:
            self.points.append(point)
        self.buffer.append(point)
        if len(self.buffer) >= self.CHUNK:
            self._flush()

    def _store(self, start: int, part: dict[str, np.ndarray]) -> None:
        """Samples ``start, start + 1, ...``: to the sink, and the kept range into memory."""
        stop = start + len(next(iter(part.values())))
        if self.sink is not None:
            self.sink(start, {"time": self.grid[start:stop], **part})
        lo, hi = max(start, self.keep[0]), min(stop, self.keep[1])
        if lo < hi:
            for k, values in part.items():
                self.signals[k][lo - self.keep[0]:hi - self.keep[0]] = values[lo - start:hi - start]
        self.filled = stop

    def _flush(self) -> None:
        chunk = self.buffer
        if len(chunk) >= 2:
            # the run ends on the whole nanosecond nearest the stop: a grid time within a
            # nanosecond past the last point still belongs to it
            t_end = chunk[-1].t_ns / NS
            stop = int(np.searchsorted(self.grid, t_end + 1e-9, side="right"))
            if stop > self.filled:
                self._store(self.filled, sample(chunk, self.grid[self.filled:stop], self.inputs))
            for audit in self.audits:
                audit.add(chunk)
        self.buffer = chunk[-1:]  # the next chunk starts where this one ended

    def finish(self) -> None:
        if len(self.buffer) >= 2:
            self._flush()
        elif self.first is not None and self.filled == 0 and len(self.grid):  # never stepped
            self._store(0, {k: np.array([float(self.first.mode.stuck) if k == "stuck" else getattr(self.first, k)])
                            for k in self.signals})
            for audit in self.audits:
                audit.add([self.first])

    def sampled(self) -> dict[str, np.ndarray]:
        """The kept signals on the part of the grid the run reached (grid indices
        ``keep[0]`` up to the last sample done)."""
        n = max(0, min(self.filled, self.keep[1]) - self.keep[0])
        return {k: v[:n] for k, v in self.signals.items()}

    def kept(self) -> list[Point]:
        """Every point (keep_points), or the first and the last."""
        if self.points is not None:
            return self.points
        last = self.buffer[-1] if self.buffer else self.first
        if self.first is None:
            return []
        return [self.first] if last is self.first else [self.first, last]


def run(system: CoupledSystem, algorithm: CouplingAlgorithm, stop_time: float, scales: Scales,
        progress: Callable[[RunProgress], None] | None = None, recorder=None,
        limits: RunLimits = RunLimits(), notice: Callable[[str], None] | None = None) -> RunOutcome:
    """Advance from t = 0 to stop_time [s] in integer nanoseconds.

    recorder: where accepted points go (default :class:`PointList`). A numerical failure
    (an FMU discarding a step that no smaller step fixes, a NaN) or a pace that would take
    past ``limits.max_wall`` ends the run with ok=False and a message naming the instance
    or the cost; what was recorded so far is kept. notice(text) is told once, up front,
    when the projected wall time exceeds ``limits.notice_after`` (see :class:`Pace`).
    """
    recorder = PointList() if recorder is None else recorder
    stop_ns = int(round(stop_time * NS))
    algorithm.prepare(system, scales)
    begin = _time.perf_counter()
    current = system.start_point()
    recorder.add(current)
    ok, message = True, "completed"
    out_of_time = False
    pace = Pace(stop_ns, limits, notice)
    try:
        while current.t_ns < stop_ns:
            new = algorithm.advance(system, current, stop_ns)
            for p in new:
                if not _finite(p):
                    raise FloatingPointError(f"non-finite state at t = {p.t_ns / NS:.9g} s: "
                                             f"x={p.x}, v={p.v}, F={p.F}, f={p.f}")
                recorder.add(p)
            if not new:
                continue
            algorithm.observe(new)
            h_ns = new[-1].t_ns - current.t_ns if len(new) == 1 else new[-1].t_ns - new[-2].t_ns
            current = new[-1]
            wall = _time.perf_counter() - begin
            c = algorithm.counters
            if progress is not None:
                progress(RunProgress(current.t_ns / NS, stop_ns / NS, c.steps, c.rejected, wall,
                                     getattr(algorithm, "tol", None), getattr(algorithm, "aims_at_window", False),
                                     getattr(algorithm, "window_reachable", None)))
            pace.judge(wall, current.t_ns, lambda: f"step now {h_ns / NS:.3g} s, {c.steps} steps and "
                                                   f"{c.rejected} rejections so far")
    except FMUCallError as exc:
        ok, message = False, f"stopped at t = {current.t_ns / NS:.9g} s: {exc}"
    except (FloatingPointError, RunawayError) as exc:
        ok, message = False, str(exc)
        out_of_time = isinstance(exc, RunawayError)
    finally:
        try:
            algorithm.finish(system)
        except FMUCallError:  # a failed run's slaves may refuse: they are closed next anyway
            pass
    recorder.finish()
    wall = _time.perf_counter() - begin
    c = algorithm.counters
    return RunOutcome(recorder.kept(), ok, message, wall,
                      counters=dict(steps=c.steps, rejected=c.rejected, landed=c.landed, iterations=c.iterations,
                                    forced=c.forced, stick_steps=c.stick_steps),
                      calls=system.calls, out_of_time=out_of_time, calls_by_kind=system.calls_by_kind)


def _finite(point: Point) -> bool:
    """x, v, F and f of the point are finite (math.isfinite: a numpy array a point cost more)."""
    return math.isfinite(point.x) and math.isfinite(point.v) and math.isfinite(point.F) and math.isfinite(point.f)


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "forever"
    for unit, size in (("years", 3.15e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s" if seconds < 10.0 else f"{seconds:.0f} s"  # (1 s after 0.85 s read as none)
