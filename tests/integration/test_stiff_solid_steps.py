"""A lubricant that stays solid ties the block to the drive through a stiff loop: one run of
such a point (what a checked call runs first) takes the steps its error allows and does not
stall at the solve's own resolution (coupling/embedded.py ``force_resolution``; docs/coupling.md,
"No estimate sees the solver's own resolution")."""
from __future__ import annotations


import pytest

from tribofmu import api

pytestmark = pytest.mark.integration

# issue 36's solid lubricant, creeping at |dv| ~ 1e-12 m/s on a viscous slope of ~6.5e7 N/(m/s)
SOLID = {"friction.gamma": -0.85, "block.K": 2000.0}


def one_run(overrides, step_tol, fmu_dir, max_wall=120.0):
    """One run, unchecked, at per-step tolerance step_tol: what a checked call runs first
    (api.simulate's check repeats runs; the steps of one are what this tests)."""
    scenario = api.load("fig6_boundary", overrides)
    return api.one_run(scenario, step_tol, fmu_dir, max_wall)


def test_a_tight_per_step_tolerance_on_the_solid_lubricant_does_not_stall(fmu_dir):
    """At per-step 1e-5 the force term, widened by the solve's resolution at delta alone, read
    the force's jitter at the root's tolerance as error: the steps stalled at 0.14 us and the run's
    pace stopped it. Widened at the root's tolerance, it takes 12,773 steps (2026-11-27)."""
    result = one_run(SOLID, 1e-5, fmu_dir, max_wall=60.0)
    assert result.ok, result.message
    assert result.stats["communication_steps"] < 20000
