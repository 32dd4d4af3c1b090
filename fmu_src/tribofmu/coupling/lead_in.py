"""The per-step tolerance the shown window needs, taken from the run's own carried error.

``--tol`` bounds the error on the scene's shown window. A first run at a per-step tolerance of
tol lands there at 0.2-0.5 tol for dry friction and at 1-3 tol for a lubricated film, and
where its estimate misses, the call runs again, tighter (tribofmu/checked.py). Which steps
made the window's error depends on the motion. Where the motion forgets an error (a damped
block), the last periods before the window made it. Where it keeps one for several periods (a
film whose error decays slowly), the steps of those periods did; where it keeps one for good (a
drift), every step since the start did. The run can tell which from its own carry, and decides
once, at one of the period marks k drive periods T before the window (k = K ... 1, K the most
that fit after the start):

- at each mark it marks its carried error (:meth:`~.estimate.GlobalErrorEstimate.mark`) and
  carries that error on without the local errors made since, its spread with it (read as the
  whole error is, :meth:`~.estimate.GlobalErrorEstimate.old_v`);
- a period on, d is that old error's RMS over the half period before this mark, over the whole
  error's RMS over the half period before the last: how much of an error is left one period
  on; and the error now is the whole error's RMS over that half period, over max |v| there;
- the error left from before a tightening k periods before the window is taken as d^k times the
  error now: what is left of it as the window opens. It falls further inside the window, but the
  decision is made once, and a shortfall costs a whole second run where a margin costs a share
  of one. (Its RMS over the window, taken as d per period in closed form, sent Fig. 6's run to
  1.17 x budget; this, to 0.78.);
- the error the steps from the tightening on make is taken as the error now times the factor on
  the per-step tolerance, raised to the run's convergence order (the error adds up over as many
  periods as the old one lasts); the two are taken as independent (they add as squares), and
  the factor is the largest that meets the budget;
- the run's steps grow as the per-step tolerance to the power order - 1 (a step of order p is
  ~tol^(1/(p + 1)) long, the run's order p/(p + 1)), so tightening k periods before the window
  costs (k T + the run after the window opens) (factor^(order - 1) - 1) more steps, in loose
  steps' lengths: the earlier, the less tightening and the longer it lasts. At each mark the run
  takes the k of 1 up to the present one that costs the fewest extra steps, and tightens now
  where that is now; else it waits for a later mark, measured again (an error still growing
  toward its level reads low early, so a choice for later is made again when later comes). At
  the last mark, a period before the window, it decides whatever the numbers.

Where d^k times the error now reaches the budget at every k, or the error now is already within
it, the tolerance stays. Then the steps before the last mark made the window's error (a drift),
or the window meets tol as it is, and the call's next run is planned from this run's estimate.
The tolerance only ever tightens. Half periods are measured because one stroke of the drive
holds a whole swing of the motion: the same phase, a period apart, compares like with like.

Measured (``benchmarks/bench_lead_in.py``, the trust list at the default tol): see
docs/coupling-record.md, "A first run that aims at its window".
"""
from __future__ import annotations

import math

from .window_error import linear_square_integral


class LeadIn:
    """One run's decision, fed its accepted points in order (:meth:`observe`); applies only
    where the window opens at least 2.5 drive periods after the start."""

    def __init__(self, window_start: float, period: float, budget: float, run_end: float | None = None):
        """window_start, period [s]; budget: the nRMS(v) on the window the run is to meet;
        run_end [s]: where the run's steps end (None: as the window opens)."""
        # the most marks k periods before the window that fit: the first measures the half
        # period before its own mark, (K + 1.5) T before the window, at t >= 0 (tested as the
        # times are computed, so that a quotient's round-off does not decide)
        marks = math.floor(window_start / period - 1.5)
        while window_start - (marks + 2.5) * period >= 0.0:
            marks += 1
        while marks >= 1 and window_start - (marks + 1.5) * period < 0.0:
            marks -= 1
        # measured half periods [times[2i], times[2i + 1]], the first (K + 1.5) T before the window
        self.times = tuple(window_start - (k + offset) * period for k in range(marks, -1, -1)
                           for offset in (1.5, 1.0))
        self.applies = marks >= 1
        self.budget, self.period = budget, period
        self.from_opening = max(0.0, run_end - window_start) if run_end is not None else 0.0  # [s] the run from the window on
        self.stage = 0  # the next of times to reach
        self.last = None  # (t, whole, old) of the last point observed (a measured half period integrates from it)
        self.squares = [0.0, 0.0]  # [(m/s)^2 s] the whole and old error's squares over it
        self.v_max = 0.0  # [m/s] over the measured half period
        self.before = math.nan  # [m/s] the whole error's RMS over the half period up to the last mark
        self.now = math.nan  # [1] the whole error's RMS over the half period up to this mark / v_max
        self.decay = math.nan  # [1] d: the old error's RMS up to this mark over ``before``
        self.periods = 1  # k: this mark's periods before the window
        # whether a tightening at some k of this mark's or later meets the budget by what the
        # latest mark measured (None: no mark measured yet): False says a next run will be needed
        self.reachable: bool | None = None

    def observe(self, t: float, whole: float, old: float, v: float, order: float = 1.0) -> str | None:
        """The accepted point at t [s] with the carried error in v, whole and old [m/s] (the
        latter from the mark on), and its v [m/s], the run's convergence order so far: "mark"
        when the carry is to be marked now, "decide" when :meth:`factor` is ready, else None."""
        if not self.applies or self.stage >= len(self.times):
            return None
        if self.stage % 2:  # inside a measured half period
            self._add(t, whole, old, v)
        self.last = (t, whole, old)
        if t < self.times[self.stage]:
            return None
        span = t - self.times[self.stage - 1] if self.stage else 0.0
        self.stage += 1
        whole_rms, old_rms = (math.sqrt(square / span) if span > 0.0 else math.nan for square in self.squares)
        v_max, self.squares, self.v_max = self.v_max, [0.0, 0.0], 0.0
        if self.stage % 2:  # a measured half period begins
            return None
        if self.stage > 2:  # a period after a mark
            self.now = whole_rms / v_max if v_max > 0.0 else math.nan
            self.decay = old_rms / self.before if self.before > 0.0 else math.nan
            self.periods = (len(self.times) - self.stage) // 2 + 1
            cheapest = self.cheapest(order)
            self.reachable = cheapest != 0
            if self.periods == 1 or cheapest == self.periods:
                self.stage = len(self.times)
                return "decide"
        self.before = whole_rms
        return "mark"

    def _add(self, t: float, whole: float, old: float, v: float) -> None:
        """The squares' integrals from the last point to this one (linear between points)."""
        if self.last is not None:
            t0, w0, o0 = self.last
            self.squares[0] += linear_square_integral(w0, whole, t - t0)
            self.squares[1] += linear_square_integral(o0, old, t - t0)
        self.v_max = max(self.v_max, abs(v))

    def cheapest(self, order: float) -> int:
        """The k of 1 up to this mark's at which tightening costs the fewest extra steps by what
        this mark measured (ties: the later; 0: tightening helps at none)."""
        costs = [(self.extra_steps(k, order), k) for k in range(1, self.periods + 1)]
        feasible = [(cost, k) for cost, k in costs if cost is not None]
        return min(feasible)[1] if feasible else 0

    def extra_steps(self, k: int, order: float) -> float | None:
        """The steps [in loose steps' lengths, s] that tightening k periods before the window
        adds (see the module's docstring); None where what is left reaches the budget then or
        nothing is measured."""
        factor = self._factor(self.now * self.decay ** k, order)
        if factor is None:
            return None
        return (k * self.period + self.from_opening) * (factor ** (order - 1.0) - 1.0)

    def _factor(self, left: float, order: float) -> float | None:
        """The factor that meets the budget with left [1] what the steps before leave; 1 where
        the error now is within it (the window meets it as it is); None where nothing is
        measured, or left is not finite or reaches it."""
        now = self.now
        if not math.isfinite(now):
            return None
        if now <= self.budget:
            return 1.0
        if not math.isfinite(left) or left >= self.budget:
            return None
        if order <= 0.0:
            return 1.0
        return (math.sqrt(self.budget ** 2 - left ** 2) / now) ** (1.0 / order)

    def factor(self, order: float) -> float:
        """The factor (<= 1) on the per-step tolerance for the steps from the decision on, the
        run's error expected to fall as the per-step tolerance to the power order; 1 where the
        measure is not finite, the window meets the budget as it is, or what is left of the
        steps before reaches it (see the module's docstring)."""
        factor = self._factor(self.left, order)
        return 1.0 if factor is None else factor

    @property
    def left(self) -> float:
        """[1] What the steps before the decision leave as the window opens: d^k times the error now."""
        return self.now * self.decay ** self.periods

    def decision(self, order: float) -> dict:
        """What was measured and decided, for stats.json: the error now and what is left of it as
        the window opens, each over the budget, d, the periods before the window it was made at,
        the run's order and the factor (None where a measure is not finite: stats.json is JSON)."""
        values = {"error_now_over_budget": self.now / self.budget, "decay_per_period": self.decay,
                  "left_over_budget": self.left / self.budget, "periods_before_window": self.periods,
                  "order": order, "factor": self.factor(order)}
        return {key: value if math.isfinite(value) else None for key, value in values.items()}
