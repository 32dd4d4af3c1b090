"""The one step-size rule of the project, with its constants named (as scipy's ``rk.py``
names SAFETY, MIN_FACTOR, MAX_FACTOR and libcosim's ECCO keeps its parameters together).

Used by the adaptive coupling (communication steps) and by the lubricant kinetics
(sub-steps inside the Friction FMU). Pure Python: it ships in the FMUs.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StepSizeController:
    """Next step = this step x factor, factor = safety (1 / error)^(1 / (order + 1)) clipped to
    [min_factor, max_factor], and to at most max_factor_after_reject right after a rejection
    (the step just failed at a larger size: growing again at once invites another).

    error: the step's error relative to what is allowed (<= 1: accept); order: the
    method's order, its local error ~ h^(order + 1)."""

    safety: float = 0.9
    min_factor: float = 0.1
    max_factor: float = 4.0
    max_factor_after_reject: float = 1.0

    def factor(self, error: float, order: int, after_reject: bool = False) -> float:
        grow = self.max_factor_after_reject if after_reject else self.max_factor
        raw = self.safety * max(error, 1e-300) ** (-1.0 / (order + 1))
        return min(max(raw, self.min_factor), grow)


# The coupling's: growth of 4 per accepted step (a slip phase after a transition), shrink to
# a tenth at most (a rejected step at an event is landed by the event logic, not by this).
COUPLING_STEPS = StepSizeController()
# The kinetics': sub-steps grow tenfold where f settles on its equilibrium (rates fall from
# 1e7 to nothing within a step), and a rejection does not hold growth back (sub-steps are
# cheap: the next one may grow at once).
KINETICS_SUBSTEPS = StepSizeController(max_factor=10.0, max_factor_after_reject=10.0)
