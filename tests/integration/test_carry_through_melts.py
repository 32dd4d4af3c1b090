"""The run's carry moves an error as the exact motion does through a lubricant's melts and
re-solidifications (coupling/variational.py step_transition; studies/carry.py), where the
motion keeps its errors: Fig. 6's rig at gamma = 1.5, omega = 15, M = 0.4, whose film melts
and re-solidifies about ten times a period. Carried by the law's slopes at each step's middle,
an error put into x0 kept 0.35 of itself after two periods (2026-11-27)."""
from __future__ import annotations

from pathlib import Path

import pytest

from tribofmu import api
from tribofmu.studies.carry import carried_error

pytestmark = pytest.mark.integration

# (two periods of the scene's 6.5: the run and the two references stop where the test looks)
DRIFT = {"friction.gamma": 1.5, "drive.omega": 15.0, "block.M": 0.4, "time.periods": 2.0, "time.window": [1.0, 2.0]}


def test_an_error_in_x0_is_carried_as_the_exact_motion_carries_it_through_two_periods_of_melts(fmu_dir):
    run = carried_error("fig6_boundary", DRIFT, 3e-3, 1e-5, Path(fmu_dir))
    period = api.load("fig6_boundary", DRIFT).drive.period
    # from the first melt on (before it the difference is at the references' round-off)
    for k in range(2, 8):
        start, end = k * period / 4, (k + 1) * period / 4
        assert run.f_reference[(run.t >= start) & (run.t < end)].max() > 5.0  # (the film melts in every bin)
        for name in ("x", "v", "f"):
            assert 0.8 <= run.ratio(start, end, name) <= 1.25, (k, name, run.ratio(start, end, name))
