"""The per-step tolerance the shown window needs, taken from the run's own carried error.

``--tol`` bounds the error on the scene's shown window. A first run at a per-step tolerance of
tol lands there at 0.2-0.5 tol for dry friction and at 1-3 tol for a lubricated film, and
where its estimate misses, the call runs again, tighter (tribofmu/checked.py). Which steps
made the window's error depends on the motion. Where the motion forgets an error (a damped
block), the last periods before the window made it. Where it keeps one (a film whose error
drifts), every step since the start did. The run can tell which from its own carry, so it
decides once, a drive period T before the window:

- it marks its carried error two periods before the window
  (:meth:`~.estimate.GlobalErrorEstimate.mark`) and carries that error on without the local
  errors made since;
- d is that old error's RMS over the half period before the decision, over the whole error's
  RMS over the half period before the mark: how much of an error is left one period on;
- the error left from before the decision is taken as d times the error's RMS now: what is
  left of it as the window opens, a period later. It falls further inside the window, but the
  decision is made once, and a shortfall costs a whole second run where a margin costs a share
  of one. (Its RMS over the window, taken as d per period in closed form, sent Fig. 6's run to
  1.17 x budget; this, to 0.78.);
- the error the steps from the decision on make is taken as that RMS times the factor on the
  per-step tolerance, raised to the run's convergence order (the error adds up over as many
  periods as the old one lasts);
- the two are taken as independent (they add as squares), and the factor is the largest that
  meets the budget.

Where d times the error now reaches the budget, or the error now is already within it, the
tolerance stays. Then the steps before the decision made the window's error (a drift), or the
window meets tol as it is, and the call's next run is planned from this run's estimate. The
tolerance only ever tightens. Half periods are measured because one stroke of the drive holds
a whole swing of the motion: the same phase, a period apart, compares like with like.

Measured (``benchmarks/bench_lead_in.py``, the trust list at the default tol, 2026-11-28): Fig. 6's
rig d = 0.40, what is left 0.75 of the budget, the tolerance tightened 0.21x. Boundary films at
other viscous exponents give d = 0.66-0.82 and a dilatant fluid 0.72, with what is left 2.9-5.8
budgets: their tolerance stays. Dry, Newtonian and shear-thinning rigs are within budget as
they are.
"""
from __future__ import annotations

import math

from .window_error import linear_square_integral

# the stages, in drive periods T before the window: measure the whole error for half a period
# up to the mark, mark, then measure the whole and the old error for the half period up to the
# decision
_STAGES = (2.5, 2.0, 1.5, 1.0)


class LeadIn:
    """One run's decision, fed its accepted points in order (:meth:`observe`); applies only
    where the window opens at least 2.5 drive periods after the start."""

    def __init__(self, window_start: float, period: float, budget: float):
        """window_start, period [s]; budget: the nRMS(v) on the window the run is to meet."""
        self.times = tuple(window_start - k * period for k in _STAGES)
        self.applies = self.times[0] >= 0.0
        self.budget = budget
        self.stage = 0  # the next of times to reach
        self.last = None  # (t, whole, old) of the last point observed (a measured half period integrates from it)
        self.squares = [0.0, 0.0]  # [(m/s)^2 s] the whole and old error's squares over it
        self.v_max = 0.0  # [m/s] over the measured half period
        self.before = math.nan  # [m/s] the whole error's RMS over the half period up to the mark
        self.now = math.nan  # [1] the whole error's RMS over the half period up to the decision / v_max
        self.decay = math.nan  # [1] d: the old error's RMS up to the decision over ``before``

    def observe(self, t: float, whole: float, old: float, v: float) -> str | None:
        """The accepted point at t [s] with the carried error in v, whole and old [m/s] (the
        latter from the mark on), and its v [m/s]: "mark" when the carry is to be marked now,
        "decide" when :meth:`factor` is ready, else None."""
        if not self.applies or self.stage >= len(self.times):
            return None
        if self.stage in (1, 3):  # inside a measured half period
            self._add(t, whole, old, v)
        self.last = (t, whole, old)
        if t < self.times[self.stage]:
            return None
        span = t - self.times[self.stage - 1] if self.stage else 0.0
        self.stage += 1
        whole_rms, old_rms = (math.sqrt(square / span) if span > 0.0 else math.nan for square in self.squares)
        v_max, self.squares, self.v_max = self.v_max, [0.0, 0.0], 0.0
        if self.stage == 2:
            self.before = whole_rms
            return "mark"
        if self.stage == 4:
            self.now = whole_rms / v_max if v_max > 0.0 else math.nan
            self.decay = old_rms / self.before if self.before > 0.0 else math.nan
            return "decide"
        return None

    def _add(self, t: float, whole: float, old: float, v: float) -> None:
        """The squares' integrals from the last point to this one (linear between points)."""
        if self.last is not None:
            t0, w0, o0 = self.last
            self.squares[0] += linear_square_integral(w0, whole, t - t0)
            self.squares[1] += linear_square_integral(o0, old, t - t0)
        self.v_max = max(self.v_max, abs(v))

    def factor(self, order: float) -> float:
        """The factor (<= 1) on the per-step tolerance for the steps from the decision on, the
        run's error expected to fall as the per-step tolerance to the power order; 1 where the
        measure is not finite, the window meets the budget as it is, or what is left of the
        steps before reaches it (see the module's docstring)."""
        now, left = self.now, self.left
        if not (math.isfinite(now) and math.isfinite(left)) or now <= self.budget or left >= self.budget \
                or order <= 0.0:
            return 1.0
        return (math.sqrt(self.budget ** 2 - left ** 2) / now) ** (1.0 / order)

    @property
    def left(self) -> float:
        """[1] What the steps before the decision leave as the window opens: d times the error now."""
        return self.now * self.decay

    def decision(self, order: float) -> dict:
        """What was measured and decided, for stats.json: the error now and what is left of it as
        the window opens, each over the budget, d, the run's order and the factor (None where a
        measure is not finite: stats.json is JSON)."""
        values = {"error_now_over_budget": self.now / self.budget, "decay_per_period": self.decay,
                  "left_over_budget": self.left / self.budget, "order": order,
                  "factor": self.factor(order)}
        return {key: value if math.isfinite(value) else None for key, value in values.items()}
