"""Does a run's carry move an error as the exact motion does? (coupling/estimate.py, issue 36)

An error put into the block's position at the start is carried by one run's linearised carry
alone (its local errors withheld, its saturation at the motion's own size lifted), and compared
with the exact difference it makes: the reference from the moved start less the reference from
the start, both sampled at the run's points (``benchmarks/bench_carry_sensitivity.py`` prints it
per bin of the drive's period; a test holds it near 1 through a film's melts).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class CarriedError:
    """t [s] the run's accepted points; carried (x [m], v [m/s], f [1]) there, one row each;
    exact the references' differences there, by name; f_reference the reference's f."""

    t: np.ndarray
    carried: np.ndarray
    exact: dict
    f_reference: np.ndarray

    def ratio(self, start: float, end: float, name: str = "v") -> float:
        """RMS of the carried over RMS of the exact difference in name over t in [start, end) [s]
        (nan where the exact one is 0 or no point falls there)."""
        inside = (self.t >= start) & (self.t < end)
        column = {"x": 0, "v": 1, "f": 2}[name]
        exact = float(np.sqrt(np.mean(self.exact[name][inside] ** 2))) if inside.any() else 0.0
        if not exact > 0.0:
            return math.nan
        return float(np.sqrt(np.mean(self.carried[inside, column] ** 2))) / exact


def carried_error(scene: str, overrides: dict, step_tol: float, delta: float, fmu_dir: Path) -> CarriedError:
    """The carry of an error of delta [drive amplitudes] in x0 along one run of ``scene`` with
    ``overrides`` at per-step tolerance step_tol, and the exact difference (references at rtol
    1e-10); FMUs from fmu_dir."""
    from .. import api
    from ..coupling import embedded, estimate
    from .reference import reference_solution

    scenario = api.load(scene, overrides)
    moved_by = delta * scenario.drive.A
    carry = estimate.GlobalErrorEstimate.advance
    started, rows = [], []

    def carry_alone(self, h, damping, local_x, local_v, stuck, x_scale=math.inf, v_scale=math.inf,
                    stuck_through=False, slopes=None, f_scale=math.inf, local_f=0.0, transition=None):
        if not started:  # exact less computed: the computed run is the one from x0
            self.ex = moved_by
            started.append(True)
        return carry(self, h, damping, 0.0, 0.0, stuck, math.inf, math.inf, stuck_through, slopes, math.inf, 0.0,
                     transition)

    carry_error = embedded.EmbeddedCoupling._carry_error

    def logged(self, point, new, local, h):
        carry_error(self, point, new, local, h)
        rows.append((new.t_ns / 1e9, self.estimate.ex, self.estimate.ev, self.estimate.ef))

    estimate.GlobalErrorEstimate.advance = carry_alone
    embedded.EmbeddedCoupling._carry_error = logged
    try:
        api.one_run(scenario, step_tol, fmu_dir)
    finally:
        estimate.GlobalErrorEstimate.advance = carry
        embedded.EmbeddedCoupling._carry_error = carry_error
    log = np.array(rows)
    t = log[:, 0]
    base = reference_solution(scenario, t_eval=t)
    moved = reference_solution(api.load(scene, {**overrides, "block.x0": scenario.block.x0 + moved_by}), t_eval=t)
    exact = {"x": moved.x - base.x, "v": moved.v - base.v, "f": moved.f - base.f}
    return CarriedError(t, log[:, 1:], exact, base.f)
