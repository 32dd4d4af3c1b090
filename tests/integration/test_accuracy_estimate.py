"""Issue 20: every run reports its own accuracy, and the boundary law with other viscous
exponents is right by default. Checked against the monolithic reference solver at parameter
points no scene uses.

``stats["estimated_error"]["nrms_v"]`` is the run's estimate of its nRMS(v) on the scene's
window (step doubling's local errors carried through the block's linearised motion, see
coupling/estimate.py). Where it holds within a factor 3 it is asserted; where it is known
not to (event timing in dry friction, the re-solidifications of a lubricant that amplify an
error), the test says so with a strict xfail: it fails the day the estimate learns them.
"""
from __future__ import annotations

import pytest

from scenes import scene

pytestmark = pytest.mark.integration


def run_against_reference(fmu_dir, name: str, overrides: dict, tol: float | None = None):
    from tribofmu.api import simulate
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms, reference_solution

    scenario = load_scenario(scene(name), overrides)
    result = simulate(scenario, tol=tol, fmu_dir=fmu_dir, build=False)
    assert result.ok, result.message
    reference = reference_solution(scenario)
    assert reference.ok
    true = nrms(result.time, result.v, reference.time, reference.v, scenario.window)
    return true, result.stats


# Off-scene points: other exponents, consistencies, frequencies, loads and blocks.
HOLDS = [
    ("fig5_pseudoplastic", {"friction.gamma": -0.4, "friction.m": 15.0}),
    ("fig5_dilatant", {"friction.gamma": 1.0, "drive.omega": 40.0}),
    ("fig5_newtonian", {"block.M": 0.3, "friction.m": 40.0}),
    # boundary friction: the melts and re-solidifications inside steps (the friction's own
    # impulse over one step and two halves); 0.32 and below before that term
    ("fig6_boundary", {"friction.gamma": -0.3}),
    ("fig6_boundary", {"drive.omega": 20.0}),
]


@pytest.mark.parametrize("name,overrides", HOLDS, ids=lambda x: str(x))
def test_the_estimate_is_within_3x_of_the_true_error(fmu_dir, name, overrides):
    true, stats = run_against_reference(fmu_dir, name, overrides)
    estimate = stats["estimated_error"]["nrms_v"]
    assert true / 3.0 <= estimate <= 3.0 * true, (estimate, true)


MISSES = [
    # (held within 3x since the embedded estimate, issue 31: 2.2x; it was an xfail before)
    ("fig2_dry", {"drive.omega": 25.0, "block.M": 0.8}),
    # (both held within 3x since the embedded coupling, issue 31; strict xfails before: the
    # light block was 3e-2 wrong estimated 2e-3; gamma = 0.3 is one of the points STATE_CARRY
    # was calibrated on, coupling/embedded.py)
    ("fig2_dry", {"block.M": 0.05, "simulation.tol": 1e-3}),
    ("fig6_boundary", {"friction.gamma": 0.3}),
]


@pytest.mark.parametrize("name,overrides", MISSES, ids=lambda x: str(x))
def test_where_the_estimate_is_known_to_miss(fmu_dir, name, overrides):
    true, stats = run_against_reference(fmu_dir, name, overrides)
    estimate = stats["estimated_error"]["nrms_v"]
    assert true / 3.0 <= estimate <= 3.0 * true, (estimate, true)


@pytest.mark.parametrize("gamma", [-0.95, 0.3, 1.0])
def test_boundary_friction_with_other_viscous_exponents_is_right_by_default(fmu_dir, gamma):
    """Fig. 6's rig with another viscous exponent: before the friction reported its mean
    force over a step (a lubricant re-solidifying inside a step grips the block between
    communication points), the default was 0.5-0.65 wrong with ok = true."""
    true, stats = run_against_reference(fmu_dir, "fig6_boundary", {"friction.gamma": gamma})
    assert true <= 1e-3


@pytest.mark.parametrize("name,overrides,warned", [
    ("fig5_dilatant", {"friction.gamma": 1.0, "drive.omega": 40.0}, True),
    ("fig5_pseudoplastic", {"friction.gamma": -0.4, "friction.m": 15.0}, False)])
def test_a_run_warns_when_its_estimate_passes_three_times_its_tol(fmu_dir, name, overrides, warned):
    """Fluids off the scenes' points at the default tol (their estimates are reliable, see
    above): the dilatant one's error is 4x tol and the run says so (it stays ok: each step
    met tol); the pseudoplastic one's is within tol and it says nothing."""
    true, stats = run_against_reference(fmu_dir, name, overrides)
    tol = stats["tol"]
    estimate = stats["estimated_error"]["nrms_v"]
    assert (estimate > 3 * tol) == warned, (tol, estimate, true)
    assert bool(stats["warnings"]) == warned
    assert (true > 3 * tol) == warned  # the warning tells the truth, not only the estimate
    if warned:
        assert "rerun with --tol" in stats["warnings"][0]


def test_boundary_friction_says_whether_it_is_past_its_tol(fmu_dir):
    """Newtonian viscosity on Fig. 6's rig: the default run was 2e-3 wrong at tol 2e-4 (the
    error a melt's timing leaves in the nearly undamped liquid phase) before the embedded
    coupling held the lubricant's state to tol (issue 31: 5e-4); whichever it is, the run
    says so when its error is past 3x tol, and its estimate is within 3x of the truth."""
    true, stats = run_against_reference(fmu_dir, "fig6_boundary", {"friction.gamma": 0.0})
    estimate = stats["estimated_error"]["nrms_v"]
    assert true / 3.0 <= estimate <= 3.0 * true, (estimate, true)
    assert bool(stats["warnings"]) == (estimate > 3 * stats["tol"])


def test_fixed_step_runs_say_they_estimate_nothing(fmu_dir):
    from tribofmu.api import simulate

    result = simulate(scene("fig2_dry"), {"time.periods": 1.0, "time.window": [0.0, 1.0]},
                      algorithm="implicit", step=1e-4, fmu_dir=fmu_dir, build=False)
    assert result.stats["estimated_error"]["nrms_v"] is None
    assert result.stats["estimated_error"]["method"].startswith("none")
