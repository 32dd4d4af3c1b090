"""The sweep's expected cost of a point, which orders the Dask tasks longest first."""
from __future__ import annotations

import pytest

from tribofmu.scene.scenario import load_scenario
from tribofmu.studies.sweep.runner import expected_cost, longest_first

from scenes import FIG2, NEWTONIAN


def cost(path, overrides=(), algorithm=None, step=None, tol=None):
    return expected_cost(load_scenario(path, list(overrides)), algorithm, step, tol)


def test_fig4_omega_sweep_puts_the_slowest_drive_first_with_its_measured_share():
    omegas = [130, 80, 50, 30, 20, 10]
    scenarios = [load_scenario(FIG2, [f"drive.omega={w}"]) for w in omegas]
    order = longest_first(scenarios, list(range(6)), None, None, None)
    assert [omegas[i] for i in order] == [10, 20, 30, 50, 80, 130]
    costs = [expected_cost(sc, None, None, None) for sc in scenarios]
    assert costs[-1] / sum(costs) == pytest.approx(0.46, abs=0.03)  # measured: 46 % of the work


def test_stiffer_laws_tighter_tolerances_and_smaller_steps_cost_more():
    assert cost(NEWTONIAN, ["friction.gamma=-0.9"]) > cost(NEWTONIAN, ["friction.gamma=-0.5"]) > cost(NEWTONIAN)
    assert cost(FIG2, ["friction.regime=boundary"]) > cost(FIG2, ["friction.regime=fluid", "friction.gamma=-0.9"])
    assert cost(FIG2, tol=1e-4) > cost(FIG2, tol=1e-3)
    assert cost(FIG2, algorithm="implicit", step=2e-5) == pytest.approx(5 * cost(FIG2, algorithm="implicit", step=1e-4))
    assert cost(FIG2, ["time.periods=13", "time.window=[5, 6.5]"]) == pytest.approx(2 * cost(FIG2))


def test_ties_keep_grid_order():
    scenarios = [load_scenario(FIG2)] * 3
    assert longest_first(scenarios, [2, 0, 1], None, None, None) == [2, 0, 1]
