"""Mixed (Stribeck) friction's runs vouch for themselves (issue 36): a call at a loose tol is
reported from its own carried estimate (doubled), not by a check, and that report is honest
against the independent reference at points no scene uses."""
from __future__ import annotations

import pytest

from test_accuracy_estimate import assert_honest, run_against_reference

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("overrides", [{"drive.omega": 18.0, "friction.mu_static": 0.7},
                                       {"friction.mu_static": 0.9, "block.M": 0.4}], ids=str)
def test_a_stribeck_call_stands_on_its_own_estimate(fmu_dir, overrides):
    true, result = run_against_reference(fmu_dir, "mixed_stribeck", overrides, tol=1e-2)
    error = result.stats["estimated_error"]
    assert error["vouches"] and error["method"].startswith("own"), error
    assert_honest(true, result)
    assert result.ok
