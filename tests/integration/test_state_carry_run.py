"""A boundary-friction run's own carried estimate (coupling/estimate.py: the error of the block
and of the lubricant's state carried by the law's slopes from each slip step's path error,
coupling/path_error.py) against the independent reference, at points no scene uses: it vouches
for the run, which is then reported alone where its estimate meets tol (checked.py)."""
from __future__ import annotations

import pytest

from test_accuracy_estimate import assert_honest, run_against_reference

pytestmark = pytest.mark.integration


def test_a_boundary_runs_propagated_estimate_is_of_its_true_errors_size(fmu_dir):
    """Fig. 6's rig at gamma = 0.5, omega = 25 rad/s, tol 1e-2 (2 runs and the reference: 6 s
    at load 1, 2026-11-27): the reported run's propagated estimate read 0.88x its true error with
    the slip steps' path errors; 0.37x with their force's divided differences (then checked by
    pairs, 4 runs), and with the calibrated state impulse (ErrorSettings.state_carry, gone) one run
    had read 1.8x and 2.5x at per-step tolerances 1e-3 and 1e-2."""
    true, result = run_against_reference(fmu_dir, "fig6_boundary", {"friction.gamma": 0.5, "drive.omega": 25.0},
                                         tol=1e-2)
    error = result.stats["estimated_error"]
    assert error["vouches"] and error["method"].startswith("own"), error
    assert 0.7 <= error["propagated"] / true <= 1.5, (error["propagated"], true)
    assert_honest(true, result)


def test_a_grip_passed_over_at_a_reversal_is_not_taken(fmu_dir):
    """Fig. 6's rig at gamma = -0.3, tol 1e-2: at per-step 1e-2 a 1.4 ms step across a reversal
    held a re-solidifying lubricant's grip inside (its mean force 11x its end forces); the run
    lost the drive's phase, 46 % off where it estimated 2e-4, and the pair check took 6 runs.
    Halved where the grip is (coupling/path_error.py passed_phase_change), its run at per-step
    1e-2 keeps the phase, and its own estimate is of its true error's size or above it: with the
    step-size rule of session 16, 4.6e-3 true and 5.2e-3 estimated, vouching; with the trend on
    rejected tries (session 17) 1.2e-2 true and 2.4e-2 estimated, and it cannot vouch: it passed
    near a melt it did not take by 1.2x its own error in f (coupling/passages.py). Either way the
    call is honest and within tol."""
    from test_near_melt import one_run, true_error

    scenario, run = one_run({"friction.gamma": -0.3}, 1e-2, fmu_dir)
    run_true = true_error(scenario, run)
    own = run.stats["estimated_error"]
    assert run_true < 5e-2  # (the phase kept: with the grip taken it was 46 % off)
    assert own["nrms_v"] >= 0.5 * run_true, (own["nrms_v"], run_true)  # (where it vouches or not)
    assert not own["vouches"] or own["nrms_v"] <= 2.0 * run_true, (own["nrms_v"], run_true)
    true, result = run_against_reference(fmu_dir, "fig6_boundary", {"friction.gamma": -0.3}, tol=1e-2)
    assert result.ok and true <= 1e-2, (true, result.stats["check"])
    assert_honest(true, result)


def test_a_drifting_rigs_runs_stand_on_their_own_estimates(fmu_dir):
    """Fig. 6's rig at gamma = 1.5, omega = 15, M = 0.4, tol 1e-2: its run at per-step 1e-2 drifts
    by about 1 % of max|v| each half period, 11 % off on the window. Carried by the law's slopes
    at each step's middle its estimate read 3.9e-3 and the call said ok with that one run
    (2026-11-27), so a second run verified every boundary run. Carried by each step's own map
    (coupling/variational.py) the first run's estimate reads 0.8x its true error, the call goes
    on to runs planned from it and ends on one whose own estimate meets tol: honest, within tol,
    no second run to verify it (4 runs, 4.5e-3 true, 7.0e-3 reported, 2026-11-28)."""
    true, result = run_against_reference(fmu_dir, "fig6_boundary",
                                         {"friction.gamma": 1.5, "drive.omega": 15.0, "block.M": 0.4}, tol=1e-2)
    assert result.ok and true <= 1e-2, (true, result.stats["check"])
    assert result.stats["estimated_error"]["method"].startswith("own"), result.stats["estimated_error"]
    assert len(result.stats["check"]["runs"]) >= 2  # (the first run's own estimate said it missed tol)
    assert_honest(true, result)
