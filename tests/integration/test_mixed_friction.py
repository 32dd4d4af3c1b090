"""Mixed (Stribeck) friction, the fourth law, against its exact reference at three parameter
points no scene uses: through the normal master (fmpy, ``api.simulate`` at the default
tolerance) and through the TriboPair FMU in a fixed-step host loop. The C host runs it in
tests/native/test_native_hosts.py. Each run spans two drive periods (a few seconds).
"""
from __future__ import annotations

import numpy as np
import pytest

from scenes import MIXED_POINTS as POINTS, MIXED_SHORT as SHORT, scene
from test_pair import run_pair

pytestmark = pytest.mark.integration


def mixed_scenario(point: str):
    from tribofmu.scene.scenario import load_scenario
    return load_scenario(scene("mixed_stribeck"), {**POINTS[point], **SHORT})


@pytest.mark.parametrize("point", POINTS)
def test_mixed_friction_in_the_master_matches_its_exact_reference(fmu_dir, point):
    from tribofmu.api import simulate
    from tribofmu.studies.reference import nrms, reference_solution

    scenario = mixed_scenario(point)
    result = simulate(scenario, fmu_dir=fmu_dir, build=False)
    assert result.ok, result.message
    reference = reference_solution(scenario)
    assert reference.ok and reference.stats["n_stick"] >= 2  # it does stick and break away
    error = nrms(result.time, result.v, reference.time, reference.v, scenario.window)
    print(f"\nmixed {point}, fmpy master: nRMS(v) = {error:.2e}")
    assert error <= 1e-3
    # stuck is the coupling's exact stick: the force within the static limit mu_s L
    law = scenario.friction.law()
    stuck = np.asarray(result.stuck, dtype=bool)
    assert stuck.any() and np.all(np.abs(result.F[stuck]) <= law.static_limit(scenario.conditions.n) * (1 + 1e-9))


@pytest.mark.parametrize("point", POINTS)
def test_mixed_friction_in_the_pair_fmu_matches_its_exact_reference(fmu_dir, point):
    from tribofmu.scene.wiring import PAIR
    from tribofmu.studies.reference import nrms, reference_solution

    scenario = mixed_scenario(point)
    period = scenario.drive.period
    grid = np.arange(int(round(scenario.time.periods * 1000)) + 1) * (period / 1000)
    window = (grid >= scenario.window[0] - 1e-12) & (grid <= scenario.window[1] + 1e-12)
    pair = run_pair(fmu_dir / "TriboPair.fmu", grid, scenario.drive.A, scenario.drive.omega,
                    **PAIR.start_values(scenario), **PAIR.constant_inputs(scenario))
    reference = np.asarray(reference_solution(scenario, grid[window]).v)
    error = nrms(grid, pair["v"], grid[window], reference, scenario.window)
    print(f"\nmixed {point}, TriboPair: nRMS(v) = {error:.2e}")
    assert error <= 1e-3
    assert np.any(pair["stuck"][window] == 1.0)
