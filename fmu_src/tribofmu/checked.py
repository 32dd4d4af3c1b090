"""Global error control: a run's error is checked, not only estimated (Shampine's rule).

``--tol`` is the error the user gets: the nRMS of the error in v over the scene's shown
window, relative to the largest |v| there. A per-step tolerance cannot promise that: events
(stick, breakaway, the lubricant melting and re-solidifying) that a step passes over, or
shifts, move the whole rest of the run, and a linearised estimate of the error carried from
step to step cannot see them. So a run is repeated at a per-step tolerance CHECK_RATIO times
tighter and the two are compared on the window, as Shampine advises for assessing the global
error of an ODE code. The tighter run is the one reported; its error is the pair's difference
over r^p - 1 (r = CHECK_RATIO) at the slowest convergence order allowed for, MIN_ORDER.

When that checked error is past tol, the next pair follows: the tighter run and its own
partner when one or two more factors will do (a chain of three runs shows the order, at most
MAX_ORDER), or else a new pair planned where the checked error asks. The sequence ends when a
pair meets tol, or the budget (``--max-wall``), MAX_RUNS or MIN_STEP_TOL is reached; then the
result is kept but not ``ok``. Every run of the sequence counts in the reported ``wall_time``.

One run where one is enough: where a run's own carried estimate vouches for it (its derivation
holds for the scene: coupling/estimate.py ``carry_problem``), the run is reported alone with
ESTIMATE_SAFETY times that estimate as its error when that meets tol, and otherwise the next run
is planned from it (:meth:`CheckSequence._own_tightening`) and stands on its own estimate in turn.
The first such run aims at the window: some drive periods before it (as many as cost the fewest
steps), its per-step tolerance may tighten once, as its own carried error asks
(coupling/lead_in.py); the next run is planned from the tolerance it ended at.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Any, Callable

import numpy as np

from .check_report import advice, method_text
from .coupling.passages import undecided
from .coupling.settings import CHECK_SETTINGS, LIMITS, MAX_ORDER, RESOLUTION, STEP_CONTROL
from .forked_runs import ForkedRuns, InlineRuns, check_workers, cpu_seconds
from .progress import run_started
from .run_folder import Spool

# The check's tuning, each value with its reason, is coupling/settings.py's CheckSettings (its
# floor and limits Resolution's and Limits'); the names below are what this module (and a test
# that sets one) reads.
CHECK_RATIO = CHECK_SETTINGS.check_ratio
MIN_ORDER = CHECK_SETTINGS.min_order
CHAIN_TIGHTENING_MAX = CHECK_SETTINGS.chain_tightening_max
MAX_JUMP = CHECK_SETTINGS.max_jump
ESTIMATE_SAFETY = CHECK_SETTINGS.estimate_safety
MIN_STEP_TOL = RESOLUTION.min_step_tol
MAX_RUNS = LIMITS.max_runs
MIN_BUDGET = LIMITS.min_budget  # s


def vouched_error(result) -> float | None:
    """ESTIMATE_SAFETY times the run's own carried estimate of its error where that estimate
    vouches for the run (``stats["estimated_error"]["vouches"]``: its derivation holds for
    the scene, coupling/estimate.py carry_problem); None where it cannot, or has no value."""
    own = result.stats.get("estimated_error") or {}
    value = own.get("nrms_v")
    if not own.get("vouches") or value is None or not math.isfinite(value):
        return None
    return ESTIMATE_SAFETY * value


def near_melt(result) -> float:
    """``near_melt`` where undecided (coupling/passages.py), else 0: no call ends on such a run, alone or
    paired (runs that turned back agree whichever way the motion went: two hot films, 0.12, 0.47 off)."""
    ratio = (result.stats.get("estimated_error") or {}).get("near_melt")
    return ratio if undecided(ratio) else 0.0


def checked_error(difference: float, previous: float | None = None) -> float:
    """The tighter run's error from its pair's difference on the window (see CHECK_RATIO);
    previous: the difference of the pair before it in its chain, if any (see MAX_ORDER)."""
    two_runs = difference / (CHECK_RATIO ** MIN_ORDER - 1.0)
    order = observed_order(difference, previous)
    if order is None:
        return two_runs
    return min(two_runs, ESTIMATE_SAFETY * difference / (CHECK_RATIO ** order - 1.0))


def observed_order(difference: float, previous: float | None) -> float | None:
    """The convergence order two successive differences of one chain show, within
    [MIN_ORDER, MAX_ORDER]; None when there is no previous difference or the
    differences do not shrink (no convergence to credit)."""
    if previous is None or not 0.0 < difference < previous or not math.isfinite(previous):
        return None
    order = math.log(previous / difference) / math.log(CHECK_RATIO)
    return min(max(order, MIN_ORDER), MAX_ORDER)


def wanted_tightening(error: float, tol: float) -> float:
    """The factor of per-step tolerance a run checked as ``error`` is expected to need to meet
    tol (the error assumed to fall in proportion to the per-step tolerance: MAX_ORDER)."""
    return error / tol


def next_tightening(error: float, tol: float) -> float:
    """How much tighter than the last run (whose error was checked as ``error``) the next run
    is: CHECK_RATIO when one or two more factors are expected to meet tol (the last run and
    the next form the next pair, and the chain shows its order), else the factor planned for
    a new pair (at most MAX_JUMP)."""
    wanted = wanted_tightening(error, tol)
    return CHECK_RATIO if wanted <= CHAIN_TIGHTENING_MAX else min(MAX_JUMP, wanted)


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


@dataclass(frozen=True)
class RunRecord:
    """One run of the sequence, for stats.json."""

    step_tol: float
    wall_time: float  # s
    communication_steps: int
    completed: bool
    fmu_calls_total: int
    window_step_tol: float | None = None  # the per-step tolerance it ended at (coupling/lead_in.py)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


class CheckSequence:
    """The decisions of the check over its runs as they come (it makes no run itself): which
    per-step tolerance comes next, which run is reported and with what error, when to stop."""

    def __init__(self, tol: float, step_tol: float, vouches: bool = False, verify: bool = False):
        self.tol, self.step_tol = tol, step_tol  # the global tol; the next run's per-step tolerance
        self.records: list[RunRecord] = []
        self.base = None  # the looser run of the pair being formed (None: a new pair starts)
        self.best = None  # the last run checked (before any check: the first run)
        self.best_error = math.nan
        self.chain_difference = None  # the last pair's difference, while the next run continues its chain
        self.order = None  # the order the reported pair's chain showed (None: two runs only)
        self.limit = "the time budget ran out"  # why a sequence short of tol ended
        self.own = vouches  # the runs stand on their own estimates: no pairs (a run without one overrules)
        self.own_last = None  # (per-step tolerance, own error) of the last run that vouched for itself
        # the pair being formed is expected to meet tol: nothing runs ahead of it. A first run that
        # vouches is (dry friction lands at 0.2-0.3 tol at a per-step tol of tol: checked_simulation)
        self.expected_to_meet = vouches
        # the per-step tolerance of the run started ahead of a first run that vouches: where the plan
        # sends its successor if its reported error (ESTIMATE_SAFETY x its estimate) is its per-step
        # tolerance, at the order of ramped slip steps (p = 2: 2/3); taken as _plan_from_own says.
        # None: none (a scene whose runs do not vouch, or once passed)
        self.ahead = max(step_tol / (ESTIMATE_SAFETY / STEP_CONTROL.safety) ** 1.5, MIN_STEP_TOL) if vouches else None
        # (result, own error, per-step tolerance) of the last run that vouched, the next one's checked
        # against it. verify: a vouching run ends the call once a second agrees (carry_needs_verification)
        self.own_previous = None
        self.verify = verify

    def planned(self) -> int:
        """Runs planned so far, the next one's pair included (for the progress bar)."""
        return len(self.records) + (2 if self.base is None and not self.own else 1)

    def then(self) -> float | None:
        """The per-step tolerance the sequence asks for after the next run if it goes on as a
        chain (a second worker starts it meanwhile); None when it cannot go on, or when the next
        run completes a pair its plan expects to meet tol (a run started ahead of it would most
        likely be stopped unused: Fig. 6 spent half again its CPU time on one)."""
        if len(self.records) + 1 >= MAX_RUNS or self.step_tol <= MIN_STEP_TOL:
            return None
        if self.own and not self.records:  # a first run that vouches: the run ahead of it
            return self.ahead
        if self.expected_to_meet and (self.base is not None or self.own):
            return None
        return max(self.step_tol / CHECK_RATIO, MIN_STEP_TOL)

    def _agreement(self, own: float | None, result) -> tuple[float | None, tuple | None, bool]:
        """The run's own error (None: no vouching), the last run that vouched (None: none to agree
        with) and whether this one, meeting tol, is to be verified by the next. Two vouching runs
        apart by more than their errors (with the margin): one reads short, and the two are a
        pair, checked as pairs are (at a ratio above CHECK_RATIO it reads high). No pair where they are
        further apart than MAX_JUMP: they differ by about the looser one's error, which that rule
        charges to the tighter (a boundary point planned 1660x tighter: 0.72 reported, 2.2e-4
        true, the call said not met): the tighter run is verified by the next one, a check ratio
        tighter. Nor do two runs agree where this one's error reads below the least their
        difference allows (falling at most as the per-step tolerance, MAX_ORDER): the looser
        one's error covered it (a hot film's read 0.1x, and the call said ok)."""
        previous = self.own_previous
        if own is None or previous is None:
            return own, previous, self.verify
        difference, ratio = window_difference(previous[0], result), previous[2] / self.step_tol
        short = ratio > 1.0 and own * (ratio ** MAX_ORDER - 1.0) < difference  # (reads short)
        if difference <= own + previous[1] and not short:
            return own, previous, self.verify
        if ratio > MAX_JUMP:
            return own, None, True
        self.base, self.chain_difference, self.own_previous = previous[0], None, None
        return None, previous, self.verify

    def add(self, result) -> bool:
        """Take the next run's (completed) result; True when the sequence ends with it."""
        window = result.stats.get("window_step_tol")
        if window is not None and window < self.step_tol:  # it tightened for its window: planned from there on
            self.step_tol = window
        own, previous, verify = self._agreement(vouched_error(result), result)
        error = self._error(result, own, previous, verify)
        undecided = near_melt(result)
        if undecided:  # no checked error, whatever its pair says (near_melt)
            error, self.best_error = math.nan, math.nan
        if error <= self.tol:
            return True
        if self.step_tol <= MIN_STEP_TOL or len(self.records) >= MAX_RUNS:
            near = "; the last passed near a melt by less than its own error" if undecided else ""
            self.limit = (f"the per-step tolerance reached its floor {MIN_STEP_TOL:g}{near}" if self.step_tol <= MIN_STEP_TOL
                          else f"{MAX_RUNS} runs, the most one sequence makes{near}")
            return True
        if own is not None:  # the next run, planned from this one's error, vouches for itself too
            self._plan_from_own(own, result)
            return False
        # (after a run undecided near a melt: its error there to fall below the rise, at MIN_ORDER)
        factor = (min(MAX_JUMP, max(CHECK_RATIO, undecided ** (1.0 / MIN_ORDER))) if undecided
                  else CHECK_RATIO if math.isnan(error) else next_tightening(error, self.tol))
        self.expected_to_meet = self._expects_to_meet(result, error, factor)
        self.base = result if factor == CHECK_RATIO else None  # else a new pair, planned tighter
        if self.base is None:
            self.chain_difference = None
        self.step_tol = max(self.step_tol / factor, MIN_STEP_TOL)
        return False

    def _error(self, result, own: float | None, previous, verify: bool) -> float:
        """This run's error as the sequence counts it (nan: none), its own or its pair's."""
        error = math.nan
        if own is not None:  # the run vouches for itself: its own estimate is its error
            self.own, self.best, self.best_error = True, result, own
            self.own_previous = (result, own, self.step_tol)
            error = own
            if verify and previous is None and error <= self.tol:
                # verified by the next run; unverified, no checked error (a sequence ending here says no ok)
                error, self.best_error = math.inf, math.nan
        elif self.base is not None:
            self.own = False
            difference = window_difference(self.base, result)
            self.order = observed_order(difference, self.chain_difference)
            self.best, self.best_error = result, checked_error(difference, self.chain_difference)
            error = self.best_error
            self.chain_difference = difference
        elif self.best is None:
            self.best, self.own = result, False
        return error

    def _plan_from_own(self, own: float, result) -> None:
        """The next run's per-step tolerance after a run that vouched and missed tol (or awaits
        its verification): planned from its own error, or the run started ahead where it fits."""
        planned = max(self.step_tol / self._own_tightening(own, result), MIN_STEP_TOL)
        # the run started ahead, where it is tighter than planned by less than a check ratio,
        # or looser but still expected to meet tol (the plan aims at the rule's safety x
        # tol, as for a run yet to start; one running is taken where the same model says
        # it meets tol, and its own estimate says whether it did)
        loosest = self.step_tol / self._own_tightening(own, result, aim=1.0)
        self.own_last = (self.step_tol, own)
        self.expected_to_meet, self.base = True, None
        ahead, self.ahead = self.ahead, None
        self.step_tol = ahead if ahead is not None and planned / CHECK_RATIO <= ahead <= loosest else planned

    def _own_tightening(self, own: float, result, aim: float = STEP_CONTROL.safety) -> float:
        """How much tighter the run after ``result`` (own error ``own``, past tol) is: aimed at
        aim x tol (the step rule's safety: the next error is predicted, not known), at least
        CHECK_RATIO, at the order the last two runs' own errors showed or else the run's own
        (``estimated_error.order``, coupling/controlled.py; MAX_ORDER where it has none). A
        first plan is not capped (capped at MAX_JUMP, a first run 30x off tol took five runs:
        mixed friction at 1e-4); one from an observed order is, as a pair's: two estimates'
        ratio at loose tolerances is a guess (one jumped 1600x, to 60x below tol). (Aimed one
        CHECK_RATIO below tol at MAX_ORDER, a dilatant point at order 0.66 took three runs.)"""
        expected = (result.stats.get("estimated_error") or {}).get("order")
        order, cap = (expected if expected is not None and 0.0 < expected <= MAX_ORDER else MAX_ORDER), math.inf
        if self.own_last is not None and self.own_last[0] > self.step_tol:
            previous_tol, previous = self.own_last
            # (an error that did not fall: the slowest order allowed for, the longest jump)
            shown = math.log(previous / own) / math.log(previous_tol / self.step_tol) if own < previous else 0.0
            order, cap = min(max(shown, MIN_ORDER), MAX_ORDER), MAX_JUMP
        wanted = (own / (aim * self.tol)) ** (1.0 / order)
        return min(cap, max(CHECK_RATIO, wanted))

    def _expects_to_meet(self, result, error: float, factor: float) -> bool:
        """Whether the pair the next run forms or starts is expected to meet tol: a chain one
        factor from it, a planned pair, or for a pair's first run what its own estimate says the
        checked error will be (at MAX_ORDER). Only what runs ahead follows from this."""
        if not math.isnan(error):
            return factor != CHECK_RATIO or wanted_tightening(error, self.tol) <= CHECK_RATIO
        own = (result.stats.get("estimated_error") or {}).get("nrms_v")
        if own is None or not math.isfinite(own):
            return False
        falls = 1.0 - CHECK_RATIO ** -MAX_ORDER  # the pair's difference, as a share of this run's error
        return own * falls / (CHECK_RATIO ** MIN_ORDER - 1.0) <= self.tol

    def kept(self) -> tuple:
        """The runs whose samples may still be reported."""
        return id(self.base), id(self.best)


def checked_simulation(run_once: Callable[..., Any], tol: float, max_wall: float | None,
                       sink: Callable[[int, dict], None] | None = None,
                       step_tol: float | None = None, *, workers: int | None = None,
                       progress: Callable[[Any], None] | None = None, notice: Callable[[str], None] | None = None,
                       prepare: Callable[[], None] | None = None, vouches: bool = False, verify: bool = False):
    """Run ``run_once(step_tol=..., max_wall=..., sink=...)`` in check pairs from per-step
    tolerance ``step_tol`` (default tol itself) down, until the tighter run of a
    pair is checked to meet ``tol`` on the window, or the budget ``max_wall`` [s] (None:
    none), MAX_RUNS or MIN_STEP_TOL ends the sequence (:class:`CheckSequence`); returns the
    last checked run's result with its stats rewritten: ``tol`` the global tol, ``step_tol``
    the run's own, ``estimated_error`` the checked error, ``ok`` only when it met tol,
    ``wall_time`` the whole sequence's, ``check`` every run.

    A run that fails (an FMU error, a non-finite state) ends the sequence with that run's
    result, as unchecked runs did before.

    The runs go ``workers`` at once (:mod:`tribofmu.forked_runs`: None, the usable cores up to
    two); ``run_once`` then also takes ``progress`` and ``notice``, which a forked run tells
    through its parent to the ones given here. prepare(): what every run does first and can
    share (unzipping the FMUs), done once before the first run is forked. vouches: the scene's
    runs carry an estimate that can vouch for them (api.own_estimate_problem): the first run is
    expected to stand alone and runs in this process; the run its plan most likely asks for next
    (CheckSequence.then) starts ahead in a child once the first has run a while
    (forked_runs.ForkedRuns, ``here``). verify: a run that vouches ends the call only once the
    next run's estimate agrees with it (:class:`CheckSequence`)."""
    begin, cpu_begin = time.perf_counter(), cpu_seconds()
    count = check_workers(workers)
    make_spool = (lambda: Spool()) if sink is not None else (lambda: None)
    runs = (InlineRuns(run_once, make_spool) if count == 1 else
            ForkedRuns(run_once, make_spool, count, progress=progress, notice=notice, prepare=prepare))
    # The first run's per-step tolerance is tol itself: dry friction, Newtonian and shear-thinning fluids land
    # at 0.2-0.46 tol (0.026 at 0.5 tol: accuracy not asked for, paid in steps); a dilatant fluid at 2.6, boundary
    # at up to 2.3, mixed at up to 28 (the next run planned from its estimate; bench_trust.py --one-run, 2026-11-27)
    sequence = CheckSequence(tol, max(step_tol if step_tol is not None else tol, MIN_STEP_TOL), vouches, verify)
    held: dict[int, Spool] = {}  # the spooled samples of the runs that may be reported
    try:
        while True:
            remaining = None if max_wall is None else max_wall - (time.perf_counter() - begin)
            if remaining is not None and remaining < MIN_BUDGET:
                break
            run_started(len(sequence.records) + 1, sequence.planned())  # for the bar
            # (a first run that vouches runs here, its successor ahead in a child)
            first_own = sequence.own and not sequence.records
            result, spool = runs.take(sequence.step_tol, remaining, sequence.then(), here=first_own)
            if spool is not None:
                held[id(result)] = spool  # closed with the rest unless the run is kept
            sequence.records.append(RunRecord(sequence.step_tol, result.stats["wall_time"],
                                              result.stats["communication_steps"], result.ok,
                                              result.stats.get("fmu_calls_total", 0),
                                              result.stats.get("window_step_tol")))
            if not result.ok:
                if sequence.best is None or not result.stats.get("out_of_time"):
                    runs.close()
                    return _finish(result, None, sequence, (begin, cpu_begin, runs), sink, None, failed=True)
                break  # out of budget: report what was checked (or the first run, unchecked)
            if sequence.add(result):
                break
            for key in [k for k in held if k not in sequence.kept()]:
                held.pop(key).close()
        runs.close()  # a run started ahead that the sequence did not ask for
        if sequence.best is None:  # not even one run fitted the budget
            from .errors import ScenarioError
            raise ScenarioError(f"max_wall {max_wall:g} s leaves no time for a run (at least {MIN_BUDGET:g} s)")
        best = sequence.best
        checked = sequence.best_error if math.isfinite(sequence.best_error) else None
        return _finish(best, checked, sequence, (begin, cpu_begin, runs), sink, held.get(id(best)))
    finally:
        runs.close()
        for spool in held.values():
            spool.close()


def _finish(result, difference: float | None, sequence: CheckSequence, began: tuple, sink, spool: Spool | None,
            failed: bool = False):
    begin, cpu_begin, runs = began
    records, tol, limit = sequence.records, sequence.tol, sequence.limit
    stats = result.stats
    own = stats.get("estimated_error", {})
    checked = difference is not None and math.isfinite(difference)
    met = checked and difference <= tol
    stats["tol"] = tol
    # (the run's own per-step tolerance, as _run_once recorded it, stays in stats["step_tol"])
    stats["wall_time"] = time.perf_counter() - begin
    # every run's CPU, the ones started ahead and stopped unused included
    stats["cpu_time"] = cpu_seconds() - cpu_begin
    stats["check"] = {"runs": [r.as_dict() for r in records], "check_ratio": CHECK_RATIO,
                      "min_order": MIN_ORDER, "observed_order": sequence.order,
                      "workers": runs.workers, "runs_stopped_unused": runs.stopped}
    if failed:
        stats["tolerance_met"] = False
        stats["completed"] = False
        return result
    stats["estimated_error"] = {
        "nrms_v": difference if checked else None,
        "method": method_text(checked, sequence, stats),
        "propagated": own.get("nrms_v"),  # the run's own linearised estimate, for comparison
        "vouches": bool(own.get("vouches")), "near_melt": own.get("near_melt"),  # (coupling/passages.py)
        "order": own.get("order"),  # the power of the per-step tol its error is expected to fall at
    }
    stats["tolerance_met"] = bool(met)
    stats["warnings"] = [] if met else [advice(difference if checked else None, tol, records, limit,
                                                      "estimated" if sequence.own else "checked")]
    result.ok = bool(met)
    stats["ok"] = result.ok
    stats["completed"] = True
    if not met:
        stats["message"] = stats["warnings"][0]
        result.message = stats["message"]
    if sink is not None and spool is not None:
        spool.replay(sink)
    return result
