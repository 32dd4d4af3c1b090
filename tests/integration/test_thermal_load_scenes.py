"""The new scenes through the real FMUs and the master, against the extended reference: the
Load FMU feeding Friction.n, the Thermal FMU fed the friction power and feeding Friction.T."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tribofmu.coupling.algorithms import Scales, make_algorithm
from tribofmu.coupling.interpolation import sample
from tribofmu.master import FMUInstance, run
from tribofmu.scene.scenario import LoadTable, ThermalTable, load_scenario, scales
from tribofmu.api import build_system
from tribofmu.scene.wiring import fmu_parameters, input_signals
from tribofmu.coupling.quadrature import step_dissipation
from tribofmu.master.energy import energy_audit, heat_audit, step_integrals
from tribofmu.studies.reference import nrms, reference_solution

from scenes import SCENARIOS
pytestmark = pytest.mark.integration


def cosimulate(fmu_dir, scenario, tol=None):
    """Run the scene's FMUs under its coupling; returns the run's outcome."""
    slaves = {name: FMUInstance(fmu_dir / f"{name}.fmu", instance=name.lower(), parameters=params)
              for name, params in fmu_parameters(scenario).items()}
    try:
        system = build_system(scenario, slaves)
        sim = scenario.simulation
        algorithm = make_algorithm(sim.algorithm, step=sim.step, tol=tol or sim.tol)
        outcome = run(system, algorithm, scenario.stop_time, Scales(*scales(scenario)))
        outcome.calls_by_instance = dict(system.calls)
    finally:
        for slave in slaves.values():
            slave.close()
    assert outcome.ok, outcome.message
    return outcome


def test_dry_load_oscillation_stops_and_restarts_stick_slip_like_the_reference(fmu_dir):
    sc = load_scenario(SCENARIOS / "dry_load_oscillation.toml")
    outcome = cosimulate(fmu_dir, sc)
    ref = reference_solution(sc)
    signals = sample(outcome.points, ref.time)
    assert nrms(ref.time, signals["v"], ref.time, ref.v, sc.window) <= 1e-3
    # the load rises through 53.8 N: stuck from then until it falls back through it
    (start, end), = [(a, b) for a, b in ref.stats["stick_intervals"] if b - a > 0.5]
    stuck = signals["stuck"] > 0.5
    inside = (ref.time > start + 0.01) & (ref.time < end - 0.01)
    assert np.all(stuck[inside])
    assert not np.all(stuck[ref.time < start]) and not np.all(stuck[ref.time > end])
    program = sc.load_program.program_()
    assert max(abs(p.n - program.n(p.t_ns / 1e9)) for p in outcome.points) <= 1e-12 * 75.0
    n = input_signals(outcome.points, ref.time)["n"]  # linear between points
    assert np.max(np.abs(n - ref.n)) <= 1e-3 * 75.0
    assert abs(energy_audit(outcome.points, sc)["residual_rel"]) <= 1e-3
    assert "thermal" not in outcome.calls_by_instance


def test_boundary_heating_feeds_the_film_exactly_the_audited_dissipation(fmu_dir):
    # shortened: the first half period, where the film first melts and heats fastest
    sc = load_scenario(SCENARIOS / "boundary_heating.toml", {"time.periods": 0.5, "time.window": [0.0, 0.5]})
    outcome = cosimulate(fmu_dir, sc, tol=2e-3)
    heat = heat_audit(outcome.points, sc)
    assert heat["q"] == 0.5 and heat["D"] > 0
    assert abs(heat["relative_mismatch"]) <= 1e-3
    ref = reference_solution(sc, rtol=1e-8)
    T = input_signals(outcome.points, ref.time)["T"]
    rise = ref.T[-1] - ref.T[0]
    assert rise > 40.0  # 56 K (C = 2e-11 J/K; a film heating by 0.2 % of it would say nothing)
    assert np.max(np.abs(T - ref.T)) <= 2e-2 * rise
    assert outcome.calls_by_instance["thermal"] > 0


def test_step_dissipation_is_the_audits_quadrature(fmu_dir):
    sc = load_scenario(SCENARIOS / "dry_load_oscillation.toml", {"time.periods": 1.0, "time.window": [0.0, 1.0]})
    points = cosimulate(fmu_dir, sc).points
    _, WV, Wv = step_integrals(points)
    each = np.array([step_dissipation(a, b) for a, b in zip(points, points[1:])])
    assert np.allclose(each, WV - Wv, rtol=1e-9, atol=1e-12 * np.max(np.abs(WV)))


def test_a_constant_load_program_and_a_heated_dry_film_change_nothing_mechanical(fmu_dir):
    base = load_scenario(SCENARIOS / "fig2_dry.toml", {"time.periods": 1.0, "time.window": [0.0, 1.0]})
    plain = cosimulate(fmu_dir, base).points
    loaded = cosimulate(fmu_dir, dataclasses.replace(
        base, fmus=base.fmus + ("Load",), load_program=LoadTable(n0=base.conditions.n))).points
    heated = cosimulate(fmu_dir, dataclasses.replace(
        base, fmus=base.fmus + ("Thermal",), thermal=ThermalTable(C=0.05, q=1.0, G=0.01))).points
    key = lambda pts: [(p.t_ns, p.x, p.v, p.F) for p in pts]
    assert key(loaded) == key(plain)  # bit-identical: n is set to the same value every step
    assert key(heated) == key(plain)  # dry friction does not depend on T
    assert heated[-1].T > 290.0 and heated[-1].Q > 0
