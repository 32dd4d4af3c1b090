"""The lead-in's decision (coupling/lead_in.py) on error histories made to order, and the
coupling that follows it (its per-step tolerance tightens once, for the rest of the run)."""
import math

import pytest

from tribofmu.coupling.lead_in import LeadIn

PERIOD, WINDOW_START, V_MAX = 1.0, 5.0, 2.0


def feed(lead_in: LeadIn, whole, old_from_mark, end=4.2, dt=1e-3, order=1.0):
    """Points every dt [s] to end: the whole error whole(t) [m/s], and once marked, the old one
    old_from_mark(t - t_mark, whole at the mark) (from the latest mark); |v| peaks at V_MAX each
    stroke; the run's order ``order``. Returns the times lead_in last said "mark" and "decide"."""
    said, marked, t = {}, None, 0.0
    while t <= end + 1e-12:
        old = old_from_mark(t - marked[0], marked[1]) if marked is not None else 0.0
        stage = lead_in.observe(t, whole(t), old, V_MAX * math.sin(math.pi * t), order)
        if stage == "mark":
            marked = (t, whole(t))
        if stage is not None:
            said[stage] = t
        t += dt
    return said


def test_it_marks_two_periods_and_decides_one_period_before_the_window():
    lead_in = LeadIn(WINDOW_START, PERIOD, budget=1e-3)
    said = feed(lead_in, lambda t: 1e-3, lambda s, e: 0.0)
    assert said["mark"] == pytest.approx(WINDOW_START - 2 * PERIOD, abs=2e-3)
    assert said["decide"] == pytest.approx(WINDOW_START - PERIOD, abs=2e-3)
    assert lead_in.observe(4.5, 1.0, 1.0, 1.0) is None  # once decided, it says nothing more


def test_an_error_the_motion_forgets_tightens_the_tolerance_to_what_the_window_leaves_room_for():
    """A steady error 4x the budget (relative to max |v|) whose old part falls to a tenth in a
    period: the steps from the decision get the room the old part leaves, sqrt(b^2 - (d now)^2),
    at the run's order."""
    budget, level = 1e-3, 4e-3 * V_MAX
    lead_in = LeadIn(WINDOW_START, PERIOD, budget)
    feed(lead_in, lambda t: level, lambda s, e: e * 0.1 ** s)
    now, decay = lead_in.now, lead_in.decay
    assert now == pytest.approx(level / V_MAX, rel=1e-2)
    assert 0.1 ** 1.0 * 0.9 < decay < 0.1 ** 0.5  # the old part over [0.5, 1] periods after the mark
    order = 2.0 / 3.0
    expected = (math.sqrt(budget ** 2 - (now * decay) ** 2) / now) ** (1.0 / order)
    assert lead_in.factor(order) == pytest.approx(expected, rel=1e-12) and lead_in.factor(order) < 0.15
    decision = lead_in.decision(order)
    assert decision["factor"] == lead_in.factor(order) and decision["decay_per_period"] == decay
    assert decision["left_over_budget"] == pytest.approx(now * decay / budget)


def test_an_error_kept_for_periods_tightens_as_early_as_costs_the_fewest_steps():
    """A steady error 2x the budget whose old part falls to 0.4 a period: tightened a period
    before the window, what is left (~ the budget) leaves the new steps almost no room; two
    periods before, it leaves most of it, and the longer stretch of tighter steps costs fewer
    steps in all (three periods: more again). The run decides at the second mark before the
    window, tightening for what d^2 leaves, and keeps marking until then."""
    budget, order = 1e-3, 2.0 / 3.0
    lead_in = LeadIn(WINDOW_START, PERIOD, budget, run_end=WINDOW_START + 1.5 * PERIOD)
    assert lead_in.times[0] == pytest.approx(WINDOW_START - 4.5 * PERIOD)  # (three marks fit)
    said = feed(lead_in, lambda t: 2.0 * budget * V_MAX, lambda s, e: e * 0.4 ** s, order=order)
    assert said["decide"] == pytest.approx(WINDOW_START - 2 * PERIOD, abs=2e-3)
    assert said["mark"] == pytest.approx(WINDOW_START - 3 * PERIOD, abs=2e-3)
    assert lead_in.periods == 2
    now, decay = lead_in.now / budget, lead_in.decay  # (now over the budget)
    assert now == pytest.approx(2.0, rel=1e-2) and 0.4 < decay < 0.4 ** 0.5

    def extra(k):  # the module docstring's cost, written out
        left = now * decay ** k
        if left >= 1.0:
            return math.inf
        factor = (math.sqrt(1.0 - left ** 2) / now) ** (1.0 / order)
        return (k + 1.5) * (factor ** (order - 1.0) - 1.0)

    assert extra(2) < min(extra(1), extra(3))
    expected = (math.sqrt(1.0 - (now * decay ** 2) ** 2) / now) ** (1.0 / order)
    assert lead_in.factor(order) == pytest.approx(expected, rel=1e-12)
    decision = lead_in.decision(order)
    assert decision["periods_before_window"] == 2 and decision["left_over_budget"] == pytest.approx(now * decay ** 2)
    assert lead_in.reachable is True


@pytest.mark.parametrize("whole, old, reachable, why", [
    (lambda t: 4e-3 * V_MAX, lambda s, e: e, False, "an error that does not fall: the steps before made the window's"),
    (lambda t: 1e-3 * (1.0 + t) * V_MAX, lambda s, e: e, False, "a drift: every step since the start made it"),
    (lambda t: 0.5e-3 * V_MAX, lambda s, e: e * 0.1 ** s, True, "within the budget as it is"),
])
def test_the_tolerance_stays_where_tightening_cannot_help_or_is_not_needed(whole, old, reachable, why):
    lead_in = LeadIn(WINDOW_START, PERIOD, budget=1e-3)
    assert lead_in.reachable is None  # (nothing measured yet)
    feed(lead_in, whole, old)
    assert lead_in.factor(2.0 / 3.0) == 1.0, why
    assert lead_in.reachable is reachable, why  # (False: the call's next run may start ahead)


def test_a_window_that_opens_within_two_and_a_half_periods_has_no_lead_in():
    lead_in = LeadIn(2.0, PERIOD, budget=1e-3)
    assert not lead_in.applies
    assert feed(lead_in, lambda t: 1.0, lambda s, e: 0.0) == {}
    assert lead_in.factor(1.0) == 1.0
    assert lead_in.decision(1.0)["decay_per_period"] is None  # (nothing measured: stats.json takes no nan)


def fluid_run(omega, aim_budget=None, tol=1e-3, periods=5.0, window_start=3.5):
    """A Newtonian fluid's rig on fakes (m = 20, M = 0.3, K = 4000) run for ``periods``: the run's
    points, its final per-step tolerance and the true nRMS(v) over [window_start, periods] periods
    against an rtol-1e-12 solve of the same ODE; aiming at aim_budget where given."""
    import numpy as np
    from scipy.integrate import solve_ivp

    from tribofmu.coupling.algorithms import AdaptiveCoupling
    from tribofmu.master import run
    from tribofmu.physics import FluidLaw

    from fakes import drive_scales, fig2_system

    A, M, K = 2e-3, 0.3, 4000.0
    law = FluidLaw(m=20.0, gamma=0.0)
    scales = drive_scales(omega, A)
    coupling = AdaptiveCoupling(tol=tol)
    if aim_budget is not None:
        coupling.aim_window(window_start * scales.period, aim_budget)
    out = run(fig2_system(law, omega, A, M, K), coupling, periods * scales.period, scales)
    t = np.array([p.t_ns for p in out.points]) * 1e-9

    def rhs(s, y):
        return [y[1], (law.force(-A * omega * math.sin(omega * s) - y[1], -20.0) - 2 * K * y[0]) / M]

    exact = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-15, t_eval=t).y[1]
    inside = t >= window_start * scales.period
    v = np.array([p.v for p in out.points])
    true = math.sqrt(np.mean((exact - v)[inside] ** 2)) / np.abs(exact[inside]).max()
    return out, coupling.tol, true


def test_a_run_aiming_at_a_tight_window_tightens_once_and_its_window_error_falls_with_it():
    """At omega = 17 (a point no scene uses), a run asked for a budget 20x below what its first
    per-step tolerance gives tightens a period before the window; its true error there falls
    at least by the share the decision expected of the new steps (budget / now ~ factor^order),
    and no step before the decision is shorter than in the run that did not aim."""
    plain, plain_tol, plain_true = fluid_run(17.0)
    aimed, aimed_tol, aimed_true = fluid_run(17.0, aim_budget=plain_true / 20.0)
    assert plain_tol == 1e-3 and aimed_tol < 1e-3 / 5.0
    assert aimed_true < plain_true / 5.0
    decided = (3.5 - 1.0) * 2 * math.pi / 17.0
    before = [p.t_ns for p in aimed.points if p.t_ns * 1e-9 < decided]
    assert before == [p.t_ns for p in plain.points if p.t_ns * 1e-9 < decided]
