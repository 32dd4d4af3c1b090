"""Issue 36's solid-lubricant point as a user calls it (``fig6_boundary --set friction.gamma=-0.85
--set block.K=2000 --tol 1e-4``): ok, and no step of its reported run below 1e-6 of the drive's
period. Its first step, slipping from rest into the lubricant's creep, was charged as a held
step whose filter took the first solve's secant gain (10.9) for the law's slope (1.7e4): forced
at the 20 ns floor, and the lubricant's relaxation from f = 0 then held the next steps near it
(per-step 3e-5: 166 steps below 1e-6 T, the smallest 9.5e-8 T; coupling/embedded.py
first_step_path_error)."""
from __future__ import annotations

import pytest

from tribofmu import api

pytestmark = pytest.mark.integration


def test_the_solid_lubricants_reported_run_takes_no_step_below_a_millionth_of_the_period(fmu_dir):
    scenario = api.load("fig6_boundary", {"friction.gamma": -0.85, "block.K": 2000.0})
    result = api.simulate(scenario, tol=1e-4, fmu_dir=fmu_dir, build=False, keep_points=True)
    assert result.ok, result.message
    t_ns = [p.t_ns for p in result.points]
    steps = [(b - a) * 1e-9 / scenario.drive.period for a, b in zip(t_ns, t_ns[1:])]
    assert len(steps) > 1000 and min(steps) >= 1e-6, (min(steps), sum(s < 1e-6 for s in steps))
