"""Issue 14: TriboPair.fmu, the block and friction law with their loop closed inside.

The built FMU is stepped at fixed steps by a plain host loop (fmpy's FMU2Slave) with the
drive given as V and a_drive at each step's start; the model underneath
(:class:`tribofmu.coupling.pair.PairModel`) is also checked on its own at parameter points no
scene uses.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fmi_harness import OK, Instance

pytestmark = pytest.mark.integration


def drive(t: float, A: float, w: float) -> dict:
    return dict(V=-A * w * math.sin(w * t), a_drive=-A * w * w * math.cos(w * t))


def run_pair(path, times, A, w, **parameters) -> dict:
    """Step the pair from times[0] through times (host steps between them); outputs after each."""
    inst = Instance(path, name="pair")
    try:
        inst.start(**parameters)
        out = {k: [v] for k, v in inst.get_outputs().items()}
        for t0, t1 in zip(times[:-1], times[1:]):
            inst.set(**drive(t0, A, w))
            assert inst.step(t0, t1 - t0) == OK, inst.messages[-3:]
            for k, v in inst.get_outputs().items():
                out[k].append(v)
    finally:
        inst.free()
    return {k: np.array(v) for k, v in out.items()}


def test_pair_in_a_fixed_step_loop_matches_the_three_fmu_adaptive_run(fmu_dir):
    """On Fig. 2's output grid (T/1000 steps) the pair agrees with the three FMUs in our
    adaptive master (tol 1e-4, whose own error is below that) to <= 1e-4 nRMS of v."""
    from tribofmu.api import simulate
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms, reference_solution

    from scenes import scene
    scenario = load_scenario(scene("fig2_dry"))
    three = simulate(scenario, tol=1e-4, fmu_dir=fmu_dir, build=False)
    assert three.ok, three.message
    grid, window = three.time, three.window_mask()
    pair = run_pair(fmu_dir / "TriboPair.fmu", grid, scenario.drive.A, scenario.drive.omega, n=scenario.conditions.n,
                    M=scenario.block.M, K=scenario.block.K, mu_friction=scenario.friction.mu_friction)
    assert nrms(grid, pair["v"], grid[window], three.v[window], scenario.window) <= 1e-4
    reference = np.asarray(reference_solution(scenario, grid[window]).v)
    assert nrms(grid, pair["v"], grid[window], reference, scenario.window) <= 1e-4
    # Stuck, dv is held at zero (to the coupling's "zero", 1e-10 of the velocity scale, plus
    # the stick ramp's residual), the force inside the bounds; four sticks a period.
    stuck = pair["stuck"][window] == 1.0
    assert np.all(np.abs(pair["dv"][window][stuck]) <= 1e-8 * scenario.drive.A * scenario.drive.omega)
    assert np.all(np.abs(pair["F"][window]) <= 0.5 * 20.0 * (1 + 1e-12))
    starts = np.count_nonzero(np.diff(pair["stuck"][window]) == 1.0)
    assert starts == 6  # 1.5 periods shown


def test_pair_holds_a_contact_stuck_when_the_friction_bound_is_never_reached(fmu_dir):
    """mu L far above the force following the drive needs (|M V' + 2 K x| <= 2.2 N here):
    the block moves with the drive exactly, at a parameter point no scene uses."""
    A, w = 1e-3, 17.0
    times = np.arange(0, 201) * 7e-4
    out = run_pair(fmu_dir / "TriboPair.fmu", times, A, w, M=0.35, K=1100.0, mu_friction=0.9, n=-40.0,
                   v0=0.0)
    V = np.array([drive(t, A, w)["V"] for t in times])
    assert np.all(out["stuck"][1:] == 1.0)
    # V is followed linearly within each host step: O(h^2) from the true drive at its end
    assert np.max(np.abs(out["v"] - V)) <= A * w ** 3 * 7e-4 ** 2
    assert np.all(np.abs(out["F"]) < 0.9 * 40.0)


def test_pair_state_restored_continues_bit_identically(fmu_dir):
    A, w = 2e-3, 45.0
    inst = Instance(fmu_dir / "TriboPair.fmu", name="pair")
    try:
        inst.start(M=0.5, K=3000.0, mu_friction=0.4, n=-15.0, tol=2e-3)
        h = 3e-4
        for k in range(150):
            inst.set(**drive(k * h, A, w))
            assert inst.step(k * h, h) == OK
        state = inst.fmu.getFMUstate()
        runs = []
        for _ in range(2):
            inst.fmu.setFMUstate(state)
            record = []
            for k in range(150, 260):
                inst.set(**drive(k * h, A, w))
                assert inst.step(k * h, h) == OK
                record.append(tuple(inst.get_outputs().values()))
            runs.append(record)
        inst.fmu.freeFMUstate(state)
        assert runs[0] == runs[1]
        assert {r[-1] for r in runs[0]} == {0.0, 1.0}  # the stretch sticks and slips
    finally:
        inst.free()


def test_pair_passes_its_kinetics_tol_to_the_lubricant_kinetics(fmu_dir):
    """TriboPair's kinetics_tol reaches the kinetics, as the Friction FMU's does: the same
    boundary run at two kinetics tolerances gives two excess volumes (they would be equal
    if the pair ran the kinetics at a fixed tolerance of its own)."""
    from scenes import scene
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.scene.wiring import fmu_parameters

    scenario = load_scenario(scene("fig6_boundary"))
    parameters = {k: v for k, v in fmu_parameters(scenario)["Friction"].items() if k != "kinetics_tol"}
    parameters.update(M=scenario.block.M, K=scenario.block.K, n=scenario.conditions.n, T=scenario.conditions.T)
    times = np.linspace(0.0, 0.1, 51)
    loose, tight = (run_pair(fmu_dir / "TriboPair.fmu", times, scenario.drive.A, scenario.drive.omega,
                             kinetics_tol=tol, **parameters)["f"] for tol in (1e-2, 1e-9))
    assert np.max(np.abs(loose - tight)) > 1e-6
    assert np.max(np.abs(loose - tight)) < 0.1 * np.max(np.abs(tight))
