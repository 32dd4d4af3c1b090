"""The one step-size rule (physics/stepsize.py) and how the adaptive coupling uses it."""
import math

import pytest

from tribofmu.coupling.settings import STEP_CONTROL as COUPLING_STEPS
from tribofmu.physics.stepsize import KINETICS_SUBSTEPS, StepSizeController

PLAIN = StepSizeController()  # the coupling's rule without its PI term


@pytest.mark.parametrize("error, order", [(0.5, 2), (0.5, 1), (2.0, 2), (2.0, 1), (0.9, 3)])
def test_factor_is_safety_times_the_error_to_the_minus_one_over_order_plus_one(error, order):
    expected = 0.9 * error ** (-1.0 / (order + 1))
    assert PLAIN.factor(error, order) == pytest.approx(expected, rel=1e-15)


def test_the_order_sets_how_hard_an_error_shrinks_the_step():
    """Error 8: a second-order step (local error ~ h^3) halves, a first-order one (h^2)
    shrinks by sqrt(8): with the safety factor 0.45 and 0.318."""
    assert PLAIN.factor(8.0, 2) == pytest.approx(0.45, rel=1e-15)
    assert PLAIN.factor(8.0, 1) == pytest.approx(0.9 / math.sqrt(8.0), rel=1e-15)
    # and a step that hit its tolerance exactly is retried at the safety factor whatever the order
    assert PLAIN.factor(1.0, 1) == PLAIN.factor(1.0, 2) == 0.9
    assert COUPLING_STEPS.factor(1.0, 1, previous_error=1.0) == COUPLING_STEPS.factor(1.0, 2) == 0.9


def test_factor_is_clipped_to_its_growth_and_shrink_limits():
    assert COUPLING_STEPS.factor(1e-12, 2) == 4.0
    assert COUPLING_STEPS.factor(0.0, 1) == 4.0  # no division by a zero error
    assert COUPLING_STEPS.factor(1e6, 2) == 0.1
    assert COUPLING_STEPS.factor(math.inf, 1) == 0.1
    assert KINETICS_SUBSTEPS.factor(1e-12, 1) == 10.0


def test_growth_is_capped_right_after_a_rejection():
    """No step grows just after a rejection, whatever the rule's values (scipy's rk.py's rule:
    the step just failed at a larger size); shrinking is not affected. (The kinetics' sub-steps
    never ask after a rejection: their factor_function is the rule outside one.)"""
    assert COUPLING_STEPS.factor(1e-3, 2, after_reject=True) == 1.0
    assert PLAIN.factor(8.0, 2, after_reject=True) == pytest.approx(0.45, rel=1e-15)
    assert KINETICS_SUBSTEPS.factor(0.01, 1, after_reject=True) == 1.0
    assert KINETICS_SUBSTEPS.factor(0.01, 1) == pytest.approx(9.0, rel=1e-15)
    custom = StepSizeController(safety=0.8, min_factor=0.2, max_factor=5.0)
    assert custom.factor(1e-6, 1, after_reject=True) == 1.0
    assert StepSizeController(max_factor=0.5).factor(1e-6, 1, after_reject=True) == 0.5
    assert custom.factor(1e-6, 1) == 5.0
    assert custom.factor(1e6, 1) == 0.2
    assert custom.factor(0.25, 1) == pytest.approx(1.6, rel=1e-15)


def test_pi_term_answers_a_growing_error_harder_and_is_off_at_beta_zero():
    """beta = 0 is the plain rule whatever the last accepted error; with beta the factor is
    safety error^-(1/(order+1) - 0.75 beta) previous^beta (DOPRI5's Lund stabilisation),
    the previous error floored at MIN_PREVIOUS_ERROR."""
    from tribofmu.physics.stepsize import MIN_PREVIOUS_ERROR

    plain, pi = PLAIN, COUPLING_STEPS
    assert pi.beta == 0.06
    assert plain.factor(0.5, 2, previous_error=1e-3) == plain.factor(0.5, 2)
    for error, previous, order in ((0.5, 0.1, 2), (0.2, 0.9, 1), (0.9, 0.05, 3)):
        expected = 0.9 * error ** -(1.0 / (order + 1) - 0.045) * previous ** 0.06
        assert pi.factor(error, order, previous_error=previous) == pytest.approx(expected, rel=1e-14)
    # an error that rose from 0.1 to 0.5 grows the step less than one that fell from 0.9 to 0.5
    assert pi.factor(0.5, 2, previous_error=0.1) < pi.factor(0.5, 2, previous_error=0.9)
    assert pi.factor(0.5, 2, previous_error=0.0) == pi.factor(0.5, 2, previous_error=MIN_PREVIOUS_ERROR)
    assert pi.factor(1e-12, 2, previous_error=0.5) == 4.0  # still clipped


def test_the_predictive_term_shortens_a_step_whose_error_rises_and_never_grows_one():
    """With a trend (this step's h over the last accepted one's, that step's error) the factor
    is also Gustafsson's predictive one's, scipy's radau.py predict_factor: times min(1,
    (h / h_old) (error_old / error)^(1 / (order + 1))), on top of the PI term."""
    rule = COUPLING_STEPS
    for error, ratio, previous, order in ((0.5, 1.0, 0.1, 2), (0.8, 1.3, 0.4, 1), (2.0, 0.7, 0.9, 2)):
        multiplier = ratio * (previous / error) ** (1.0 / (order + 1))
        expected = min(max(rule.factor(error, order, previous_error=previous) * min(1.0, multiplier), 0.1), 4.0)
        assert rule.factor(error, order, previous_error=previous, trend=(ratio, previous)) == pytest.approx(
            expected, rel=1e-14)
    # an error that rose from 0.1 to 0.5 over equal steps: the next step a cube root of 5 shorter
    assert PLAIN.factor(0.5, 2, trend=(1.0, 0.1)) == pytest.approx(PLAIN.factor(0.5, 2) / 5.0 ** (1 / 3), rel=1e-14)
    # one that fell, or a step that grew: no more growth than without the term
    assert PLAIN.factor(0.5, 2, trend=(1.0, 0.9)) == PLAIN.factor(0.5, 2)
    assert PLAIN.factor(0.5, 2, trend=(2.0, 0.5)) == PLAIN.factor(0.5, 2)
    # no trend read from a zero error on either side; still clipped
    assert PLAIN.factor(0.5, 2, trend=(1.0, 0.0)) == PLAIN.factor(0.5, 2)
    assert PLAIN.factor(0.0, 2, trend=(1.0, 0.5)) == 4.0
    assert PLAIN.factor(1e6, 1, trend=(1.0, 1e-6)) == 0.1


@pytest.mark.parametrize("rule", [PLAIN, KINETICS_SUBSTEPS, COUPLING_STEPS,
                                  StepSizeController(beta=0.1, min_previous_error=2.0)],
                         ids=["plain", "kinetics", "coupling", "pi-floored-above-1"])
@pytest.mark.parametrize("order", [1, 2])
def test_factor_function_gives_factors_numbers_bit_for_bit(rule, order):
    """The bound rule of an inner loop (the lubricant's sub-steps) is factor() itself: the
    same float for every error, including the clipped, zero, infinite and NaN ones."""
    bound = rule.factor_function(order)
    errors = [0.0, -0.0, 1e-320, 1e-300, 1e-12, 0.01, 0.5, 0.9, 1.0, 1.0 + 2 ** -52, 8.0, 1e6,
              math.inf, math.nan] + [10.0 ** (k / 7.0) for k in range(-40, 41)]
    for error in errors:
        a, b = rule.factor(error, order), bound(error)
        assert (math.isnan(a) and math.isnan(b)) or a.hex() == b.hex(), (error, a, b)
