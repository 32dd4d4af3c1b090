"""The one step-size rule of the project, with its constants named (as scipy's ``rk.py``
names SAFETY, MIN_FACTOR, MAX_FACTOR and libcosim's ECCO keeps its parameters together).

Used by the adaptive coupling (communication steps: its values are coupling/settings.py's
``STEP_CONTROL``, with the coupling's other tuning) and by the lubricant kinetics (sub-steps
inside the Friction FMU: ``KINETICS_SUBSTEPS`` below). Pure Python: it ships in the FMUs.
"""
from __future__ import annotations

from dataclasses import dataclass

# A step far within its tolerance does not grow the next by more through the PI term (the
# default of StepSizeController.min_previous_error).
MIN_PREVIOUS_ERROR = 1e-4


@dataclass(frozen=True)
class StepSizeController:
    """Next step = this step x factor, factor = safety (1 / error)^(1 / (order + 1)) clipped to
    [min_factor, max_factor], and to at most 1 right after a rejection (the step just failed
    at a larger size: growing again at once invites another; scipy's rk.py's rule).

    error: the step's error relative to what is allowed (<= 1: accept); order: the
    method's order, its local error ~ h^(order + 1).

    With beta > 0 the rule is PI (Gustafsson's controller, in the form of the "Lund
    stabilisation" of Hairer's DOPRI5, whose beta defaults to 0.04): factor = safety
    error^-(1/(order + 1) - 0.75 beta) previous^beta, previous the last accepted step's
    error (floored at min_previous_error). An error that grew since the last step is answered
    harder, one that fell more gently, so the steps stop rocking between growth and
    rejection.

    Given the last accepted step's length ratio and error (``trend``: this step's h over that
    step's, and its error), the factor is also Gustafsson's predictive one's (Hairer & Wanner,
    Solving ODEs II, IV.8; scipy's radau.py ``predict_factor``): times min(1, (h / h_old)
    (error_old / error)^(1 / (order + 1))). It reads the error's constant (error / h^(order +
    1)) as moving on as it moved over the last step: an error rising from step to step (a
    force curving ever faster toward an event) shortens the next step before it fails, where
    the rule sized it from this step's constant and it was rejected; a falling one grows the
    next no more than the rule does."""

    safety: float = 0.9
    min_factor: float = 0.1
    max_factor: float = 4.0
    beta: float = 0.0
    min_previous_error: float = MIN_PREVIOUS_ERROR

    def factor(self, error: float, order: int, after_reject: bool = False,
               previous_error: float = 1.0, trend: tuple[float, float] | None = None) -> float:
        grow = min(1.0, self.max_factor) if after_reject else self.max_factor
        exponent = 1.0 / (order + 1) - 0.75 * self.beta
        raw = self.safety * max(error, 1e-300) ** -exponent
        if self.beta:
            raw *= max(previous_error, self.min_previous_error) ** self.beta
        if trend is not None and error > 0.0 and trend[1] > 0.0:
            raw *= min(1.0, trend[0] * (trend[1] / error) ** (1.0 / (order + 1)))
        return min(max(raw, self.min_factor), grow)

    def factor_function(self, order: int):
        """:meth:`factor` for one order, not after a rejection, with the previous error at its
        default and no trend, as a function of the error alone: the same numbers (the same operations,
        the builtins' max and min written as the comparisons they make), its constants bound
        once, for an inner loop that asks on every sub-step (the lubricant kinetics)."""
        exponent = -(1.0 / (order + 1) - 0.75 * self.beta)
        safety, low, high = self.safety, self.min_factor, self.max_factor
        # the PI term at previous error 1.0 (factor's default): a factor of exactly 1.0 at beta 0
        previous = max(1.0, self.min_previous_error) ** self.beta if self.beta else None

        def factor(error: float) -> float:
            raw = safety * (1e-300 if 1e-300 > error else error) ** exponent
            if previous is not None:
                raw *= previous
            raw = low if low > raw else raw
            return high if high < raw else raw

        return factor


# The kinetics': sub-steps grow tenfold where f settles on its equilibrium (rates fall from
# 1e7 to nothing within a step), and a rejection does not hold growth back (sub-steps are
# cheap: the next one may grow at once).
KINETICS_SUBSTEPS = StepSizeController(max_factor=10.0)

