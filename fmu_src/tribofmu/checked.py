"""Global error control: a run's error is checked, not only estimated (Shampine's rule).

``--tol`` is the error the user gets: the nRMS of the error in v over the scene's shown
window, relative to the largest |v| there. A per-step tolerance cannot promise that: events
(stick, breakaway, the lubricant melting and re-solidifying) that a step passes over, or
shifts, move the whole rest of the run, and a linearised estimate of the error carried from
step to step cannot see them. So the run is repeated at a tighter per-step tolerance and
the two are compared on the window, as Shampine advises for assessing the global error of
an ODE code. The tighter run is the one reported; its reported error is the difference
over r^p - 1 (r the ratio of the two per-step tolerances) at the slowest convergence order
allowed for, MIN_ORDER. When the difference
is past tol, the next pair is the tighter run and one tighter still, until it meets tol or
the time budget (``--max-wall``) is spent; then the result is kept but not ``ok``.

Every run of the sequence counts in the reported ``wall_time``.
"""
from __future__ import annotations

import math
import os
import pickle
import tempfile
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

# The per-step tolerance of each run is this many times tighter than its predecessor's:
# the pair's difference is then mostly the looser run's error (it falls like tol^0.7-1 on
# every law measured: 2.6-4x a ratio of 4), and the tighter run costs 1.6x the looser
# (steps grow like tol^-1/3 for a second-order step).
TIGHTENING = 4.0
# The first run's per-step tolerance, as a multiple of the global tol asked for: the reported
# run is then 4x tighter, and its true nRMS(v) lands at 0.05-0.25 tol on fig2, fig6 and an
# off-scene dry point (0.026 at 0.5: more accuracy than asked, paid in steps).
FIRST_STEP_TOL = 1.0
# No per-step tolerance below this: past it the steps reach the coupling's round-off.
MIN_STEP_TOL = 1e-9
# At most this many runs in one sequence (from FIRST_STEP_TOL x tol, each at least
# TIGHTENING tighter: the last at 3e-5 x tol or below): a sequence always ends.
MAX_RUNS = 8
# A run whose budget is this small is not started (it could not reach the window).
MIN_BUDGET = 1e-3  # s


# At most this much tighter in one go: a pair further apart reports the looser run's error
# for the tighter one, which is then overstated by ratio^p - 1 (4-9x at 10; measured 73x
# after a 75x jump on a light dry block).
MAX_TIGHTENING = 8.0
# The slowest convergence the reported error allows for: with errors e ~ tol^p, two runs r
# apart differ by e_tight (r^p - 1), so the tighter run's error is the difference over
# r^p - 1, at most that at p = MIN_ORDER. Boundary friction near gamma = -0.3 converges that
# slowly between per-step tolerances 5e-4 and 1.25e-4 (the difference was 0.54x the tighter
# run's true error); at p = 1 the report is then 3/(4^0.3 - 1) = 5.8x the true error.
MIN_ORDER = 0.3
# How the error falls with the per-step tolerance, assumed when the next run is planned: the
# slowest order measured (boundary friction, tol^0.7), so a plan errs toward the tighter run.
ASSUMED_ORDER = 0.7
# The next run aims at this fraction of tol, so that it and its check both pass.
SAFETY = 0.5


def next_tightening(last_error: float, tol: float) -> float:
    """How much tighter the next run's per-step tolerance is than the last one's, whose error
    was checked as ``last_error``: at least TIGHTENING; more when that error is still far
    from tol, so that the next run lands near SAFETY x tol instead of creeping there one
    factor at a time; at most MAX_TIGHTENING."""
    if not math.isfinite(last_error):  # the first run: nothing checked yet
        return TIGHTENING
    wanted = (last_error / (SAFETY * tol)) ** (1.0 / ASSUMED_ORDER)
    return min(MAX_TIGHTENING, max(TIGHTENING, wanted))


def window_difference(a, b) -> float:
    """nRMS over the shown window of v_a - v_b, relative to the largest |v_b| there (the
    measure ``--tol`` bounds); nan when either did not reach the window."""
    va, vb = _window_v(a), _window_v(b)
    if va is None or vb is None or len(va) != len(vb) or len(vb) == 0:
        return math.nan
    scale = float(np.max(np.abs(vb)))
    if not scale > 0.0:  # the block at rest all through the window: agreeing means exactly
        return 0.0 if np.array_equal(va, vb) else math.inf
    return float(np.sqrt(np.mean((va - vb) ** 2)) / scale)


def _window_v(result) -> np.ndarray | None:
    start, end = result.scenario.window
    t = result.time
    if len(t) == 0 or t[-1] < end - 1e-9 * max(1.0, end):
        return None
    mask = (t >= start - 1e-12) & (t <= end + 1e-12)
    return np.asarray(result.v[mask], dtype=float)


class Spool:
    """Output samples of one run held on disk until the run is chosen (memory stays bounded
    whatever the span); :meth:`replay` hands them to the real sink in order."""

    def __init__(self):
        fd, self.path = tempfile.mkstemp(prefix="tribofmu-spool-", suffix=".pickle")
        self._file = os.fdopen(fd, "wb")

    def __call__(self, start: int, signals: dict) -> None:
        pickle.dump((start, {k: np.array(v) for k, v in signals.items()}), self._file,
                    protocol=pickle.HIGHEST_PROTOCOL)

    def replay(self, sink: Callable[[int, dict], None]) -> None:
        self._file.flush()
        with open(self.path, "rb") as fh:
            while True:
                try:
                    start, signals = pickle.load(fh)
                except EOFError:
                    return
                sink(start, signals)

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()
        try:
            os.unlink(self.path)
        except OSError:
            pass


@dataclass(frozen=True)
class RunRecord:
    """One run of the sequence, for stats.json."""

    step_tol: float
    wall_time: float  # s
    communication_steps: int
    completed: bool
    fmu_calls_total: int

    def as_dict(self) -> dict[str, Any]:
        return {"step_tol": self.step_tol, "wall_time": self.wall_time,
                "communication_steps": self.communication_steps, "completed": self.completed,
                "fmu_calls_total": self.fmu_calls_total}


def checked_simulation(run_once: Callable[..., Any], tol: float, max_wall: float | None,
                       sink: Callable[[int, dict], None] | None = None,
                       step_tol: float | None = None):
    """Run ``run_once(step_tol=..., max_wall=..., sink=...)`` at per-step tolerances from
    ``step_tol`` (default FIRST_STEP_TOL x tol) down, each TIGHTENING to MAX_TIGHTENING times
    the last, until the tighter run of the last two is checked to meet ``tol`` on the window,
    or the budget ``max_wall`` [s] (None: none) is spent; returns that run's result with its
    stats rewritten: ``tol`` the global tol, ``step_tol`` the run's own, ``estimated_error``
    the checked error, ``ok`` only when it met tol, ``wall_time`` the whole sequence's,
    ``check`` every run.

    A run that fails (an FMU error, a non-finite state) ends the sequence with that run's
    result, as unchecked runs did before."""
    begin = time.perf_counter()
    step_tol = max(step_tol if step_tol is not None else FIRST_STEP_TOL * tol, MIN_STEP_TOL)
    records: list[RunRecord] = []
    previous = previous_spool = None
    difference = math.nan
    limit = "the time budget ran out; raise --max-wall"  # why a sequence short of tol ended
    try:
        while True:
            remaining = None if max_wall is None else max_wall - (time.perf_counter() - begin)
            if remaining is not None and remaining < MIN_BUDGET:
                break
            spool = Spool() if sink is not None else None
            try:
                result = run_once(step_tol=step_tol, max_wall=remaining, sink=spool)
            except BaseException:
                if spool is not None:
                    spool.close()
                raise
            records.append(RunRecord(step_tol, result.stats["wall_time"], result.stats["communication_steps"],
                                     result.ok, result.stats.get("fmu_calls_total", 0)))
            if not result.ok:
                if spool is not None:
                    spool.close()
                if previous is None or not result.stats.get("out_of_time"):
                    return _finish(result, None, records, tol, begin, sink, None, failed=True)
                break  # the tighter run ran out of budget: report the looser one, unchecked
            if previous is not None:
                ratio = records[-2].step_tol / step_tol
                difference = window_difference(previous, result) / (ratio ** MIN_ORDER - 1.0)
            if previous_spool is not None:
                previous_spool.close()
            previous, previous_spool = result, spool
            if difference <= tol:
                break
            if step_tol <= MIN_STEP_TOL or len(records) >= MAX_RUNS:
                limit = (f"the per-step tolerance reached its floor {MIN_STEP_TOL:g}" if step_tol <= MIN_STEP_TOL
                         else f"{MAX_RUNS} runs, the most one sequence makes")
                break
            step_tol = max(step_tol / next_tightening(difference, tol), MIN_STEP_TOL)
        if previous is None:  # not even one run fitted the budget
            from .errors import ScenarioError
            raise ScenarioError(f"max_wall {max_wall:g} s leaves no time for a run (at least {MIN_BUDGET:g} s)")
        return _finish(previous, difference, records, tol, begin, sink, previous_spool, limit)
    finally:
        if previous_spool is not None:
            previous_spool.close()


def _finish(result, difference: float | None, records: list[RunRecord], tol: float, begin: float,
            sink, spool: Spool | None, limit: str = "", failed: bool = False):
    stats = result.stats
    own = stats.get("estimated_error", {})
    checked = difference is not None and math.isfinite(difference)
    met = checked and difference <= tol
    stats["tol"] = tol
    stats["step_tol"] = records[-1].step_tol if failed else _reported_step_tol(result, records)
    stats["wall_time"] = time.perf_counter() - begin
    stats["check"] = {"runs": [r.as_dict() for r in records], "tightening": TIGHTENING}
    if failed:
        stats["tolerance_met"] = False
        stats["completed"] = False
        return result
    stats["estimated_error"] = {
        "nrms_v": difference if checked else None,
        "method": ("checked: the run was repeated at a tighter per-step tolerance and the two "
                   "compared on the window (Shampine's rule); the tighter run is reported, with their "
                   f"difference over r^p - 1 as its error (r the tolerances' ratio, p = {MIN_ORDER:g} the "
                   "slowest convergence allowed for)") if checked else
                  ("not checked: the time budget ran out before the run could be repeated at a "
                   "tighter tolerance; raise --max-wall"),
        "propagated": own.get("nrms_v"),  # the run's own linearised estimate, for comparison
    }
    stats["tolerance_met"] = bool(met)
    stats["warnings"] = [] if met else [_advice(difference if checked else None, tol, records, limit)]
    result.ok = bool(met)
    stats["ok"] = result.ok
    stats["completed"] = True
    if not met:
        stats["message"] = stats["warnings"][0]
        result.message = stats["message"]
    if sink is not None and spool is not None:
        spool.replay(sink)
    return result


def _reported_step_tol(result, records: list[RunRecord]) -> float:
    # the reported run is the last completed one
    completed = [r for r in records if r.completed]
    return completed[-1].step_tol if completed else records[-1].step_tol


def _advice(difference: float | None, tol: float, records: list[RunRecord], limit: str) -> str:
    spent = sum(r.wall_time for r in records)
    if difference is None:
        return (f"tolerance {tol:g} not checked: {limit} after {len(records)} run(s) ({spent:.0f} s); "
                f"loosen --tol, or raise --max-wall")
    return (f"tolerance {tol:g} not met: the checked nRMS(v) is {difference:.2g} after {len(records)} "
            f"runs ({spent:.0f} s, per-step tolerance down to {records[-1].step_tol:.2g}; {limit}); "
            f"loosen --tol, or raise --max-wall")
