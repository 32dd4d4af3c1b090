"""Physics of the Thermal and Load models against exact solutions, their scenario tables, and
the extended reference solver (n(t), T as a state). No FMI here."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from tribofmu.physics.load import PROGRAMS, LoadProgram
from tribofmu.physics.thermal import ThermalParams, advance_thermal, temperature_rate
from tribofmu.scene.scenario import LoadTable, ScenarioError, ThermalTable, load_scenario
from tribofmu.scene.wiring import constant_inputs, fmu_parameters
from tribofmu.studies.reference import reference_solution

from scenes import SCENARIOS
# A parameter point no scene uses: C [J/K], q [1], G [W/K], T_ambient [K]
PARAMS = ThermalParams(C=3.7e-9, q=0.3, G=2.9e-9, T_ambient=305.0)


# -- thermal -----------------------------------------------------------------------------------
def test_constant_power_follows_the_closed_form_whatever_the_steps():
    P, T0 = 4.1e-6, 350.0  # W, K
    T_inf = PARAMS.T_ambient + PARAMS.q * P / PARAMS.G
    tau = PARAMS.C / PARAMS.G
    rng = np.random.default_rng(7)
    steps = rng.uniform(1e-4, 0.2, 40)  # s, irregular
    T, t, received, lost = T0, 0.0, 0.0, 0.0
    for h in steps:
        out = advance_thermal(T, P, h, PARAMS)
        T, t = out.T, t + h
        received += out.received
        lost += out.lost
        assert T == pytest.approx(T_inf + (T0 - T_inf) * math.exp(-t / tau), rel=1e-13)
    assert received == pytest.approx(PARAMS.q * P * t, rel=1e-13)
    # energy: C dT = heat received - heat conducted away, and the lost heat is G int (T - Ta)
    assert PARAMS.C * (T - T0) == pytest.approx(received - lost, rel=1e-12)
    exact_lost = PARAMS.G * ((T_inf - PARAMS.T_ambient) * t + (T0 - T_inf) * tau * (1 - math.exp(-t / tau)))
    assert lost == pytest.approx(exact_lost, rel=1e-11)


def test_without_conduction_the_film_warms_linearly_and_keeps_its_heat():
    params = dataclasses.replace(PARAMS, G=0.0)
    out = advance_thermal(300.0, 2e-6, 0.25, params)
    assert out.T == pytest.approx(300.0 + 0.3 * 2e-6 * 0.25 / 3.7e-9, rel=1e-15)
    assert out.lost == 0.0
    assert math.isinf(params.time_constant) and params.steady_temperature(1e-6) == math.inf


def test_rate_matches_the_step_for_a_short_step():
    T, P, h = 420.0, 7e-7, 1e-9
    out = advance_thermal(T, P, h, PARAMS)
    assert (out.T - T) / h == pytest.approx(temperature_rate(T, P, PARAMS), rel=1e-6)
    assert advance_thermal(PARAMS.steady_temperature(P), P, 10.0, PARAMS).T == \
        pytest.approx(PARAMS.steady_temperature(P), rel=1e-14)


@pytest.mark.parametrize("field, value, text", [
    ("C", 0.0, "C must be > 0, got 0.0"), ("C", -1e-12, "C must be > 0"),
    ("q", 1.01, "q must be in [0, 1], got 1.01"), ("q", -0.5, "q must be in [0, 1]"),
    ("G", -1.0, "G must be >= 0"), ("T_ambient", -3.0, "T_ambient must be >= 0 K"),
    ("C", math.nan, "C must be finite"),
])
def test_thermal_parameters_out_of_range_are_named(field, value, text):
    problems = dataclasses.replace(PARAMS, **{field: value}).problems()
    assert any(text in p for p in problems), problems


# -- load programs ----------------------------------------------------------------------------
def test_programs_are_the_exact_functions_of_time():
    ramp = LoadProgram(program=PROGRAMS["ramp"], n0=-10.0, n1=-70.0, t_start=0.3, t_end=1.1)
    assert [ramp.n(t) for t in (0.0, 0.3, 0.5, 1.1, 9.0)] == pytest.approx([-10, -10, -25, -70, -70], rel=1e-15)
    step = LoadProgram(program=PROGRAMS["step"], n0=-5.0, n1=-8.0, t_start=0.25)
    assert (step.n(0.2499999), step.n(0.25), step.n(3.0)) == (-5.0, -8.0, -8.0)
    sine = LoadProgram(program=PROGRAMS["sine"], n0=-40.0, amplitude=7.0, period=0.8, phase=0.4)
    for t in (0.0, 0.13, 0.77, 2.5):
        assert sine.n(t) == pytest.approx(-40.0 + 7.0 * math.sin(2 * math.pi * t / 0.8 + 0.4), rel=1e-15)
    assert LoadProgram(n0=-3.5).n(123.0) == -3.5
    assert ramp.breakpoints() == (0.3, 1.1) and step.breakpoints() == (0.25,) and sine.breakpoints() == ()


@pytest.mark.parametrize("t0, t1", [(0.0, 0.1), (0.05, 0.5), (0.0, 3.0), (0.31, 0.33)])
def test_sine_extremes_match_dense_sampling(t0, t1):
    sine = LoadProgram(program=PROGRAMS["sine"], n0=-40.0, amplitude=7.0, period=0.8, phase=0.4)
    values = [sine.n(t) for t in np.linspace(t0, t1, 200001)]
    low, high = sine.extremes(t0, t1)
    assert low == pytest.approx(min(values), abs=1e-8) and high == pytest.approx(max(values), abs=1e-8)


@pytest.mark.parametrize("kwargs, text", [
    (dict(program=9), "program must be 0 (constant), 1 (ramp), 2 (step) or 3 (sine), got 9"),
    (dict(program=PROGRAMS["ramp"], t_start=1.0, t_end=1.0), "t_end must be > t_start"),
    (dict(program=PROGRAMS["sine"], period=0.0), "period must be > 0"),
    (dict(n1=math.inf), "n1 must be finite"),
])
def test_load_parameters_out_of_range_are_named(kwargs, text):
    assert any(text in p for p in LoadProgram(**kwargs).problems())


# -- scenario tables ----------------------------------------------------------------------------
def test_new_tables_parse_and_map_onto_the_fmus():
    sc = load_scenario(SCENARIOS / "boundary_heating.toml")
    assert sc.fmus == ("Drive", "BlockSpring", "Friction", "Thermal")
    params = fmu_parameters(sc)
    assert params["Thermal"] == {"C": 2e-11, "q": 0.5, "G": 8e-11, "T_ambient": 290.0, "T0": 290.0}
    assert constant_inputs(sc) == {"n": -1e6}  # T is fed by the Thermal FMU
    dry = load_scenario(SCENARIOS / "dry_load_oscillation.toml")
    assert params_of(dry)["Load"]["program"] == PROGRAMS["sine"]
    assert constant_inputs(dry) == {"T": 290.0}
    assert dry.normal_stress(0.0) == pytest.approx(-15.0) and dry.load == pytest.approx(15.0)


def params_of(sc):
    return fmu_parameters(sc)


def test_scenes_of_the_paper_instantiate_no_new_fmu():
    for name in ("fig2_dry", "fig6_boundary", "free_oscillator"):
        sc = load_scenario(SCENARIOS / f"{name}.toml")
        assert not {"Thermal", "Load"} & set(fmu_parameters(sc))
    sc = load_scenario(SCENARIOS / "fig2_dry.toml")
    assert constant_inputs(sc) == {"n": -20.0, "T": 290.0}


@pytest.mark.parametrize("override, text", [
    ({"thermal.C": -1.0}, "thermal.C must be > 0, got -1.0"),
    ({"thermal.q": 2}, "thermal.q must be in [0, 1], got 2.0"),
    ({"thermal.G": "x"}, "thermal.G must be a number, got 'x'"),
    ({"load.program": "square"}, "load.program must be one of constant, ramp, step, sine, got 'square'"),
    ({"load.period": 0.0}, "load.period must be > 0, got 0.0"),
    ({"load.n0": 20.0}, "load.n0 = 20.0 with load.program = 'sine' makes n reach 50 Pa > 0"),
    ({"load.bogus": 1.0}, "unknown key load.bogus"),
    ({"scenario.fmus": ["Drive", "BlockSpring", "Load"]}, "must include 'Friction' when it includes 'Load'"),
])
def test_bad_tables_are_one_line_naming_file_key_and_value(override, text):
    with pytest.raises(ScenarioError) as err:
        load_scenario(SCENARIOS / "dry_load_oscillation.toml", override)
    message = str(err.value)
    assert message.startswith("dry_load_oscillation.toml: ") and text in message and "\n" not in message


# -- the extended reference ---------------------------------------------------------------------
def _fig2(**changes):
    return dataclasses.replace(load_scenario(SCENARIOS / "fig2_dry.toml",
                                             {"time.periods": 2.0, "time.window": [1.0, 2.0]}), **changes)


def test_varying_load_solver_reproduces_the_exact_dry_solver_at_constant_load():
    exact = reference_solution(_fig2())
    varying = reference_solution(_fig2(fmus=("Drive", "BlockSpring", "Friction", "Load"),
                                       load_program=LoadTable(n0=-20.0)))
    assert varying.ok and varying.stats["solver"].startswith("exact stick, DOP853")
    assert np.max(np.abs(varying.v - exact.v)) <= 1e-9 * np.max(np.abs(exact.v))
    assert [round(t, 9) for t, _ in varying.stats["event_times"]] == \
        [round(t, 9) for t, _ in exact.stats["event_times"]]


def test_heavy_load_sticks_light_load_slips_under_a_ramp():
    # L from 10 N to 80 N over the first period: following the drive needs 26.9 N = mu L at 53.8 N
    sc = _fig2(fmus=("Drive", "BlockSpring", "Friction", "Load"),
               load_program=LoadTable(program="ramp", n0=-10.0, n1=-80.0, t_start=0.0, t_end=0.2094))
    ref = reference_solution(sc)
    assert ref.ok
    late = ref.time > 0.25
    assert np.max(np.abs(ref.V[late] - ref.v[late])) < 1e-9 * np.max(np.abs(ref.V))  # stuck for good
    assert ref.stats["n_slip"] >= 1
    assert ref.n[0] == -10.0 and ref.n[-1] == -80.0


def test_heating_dry_contact_obeys_the_heat_balance_and_relaxes_exactly_while_stuck():
    thermal = ThermalTable(C=0.05, q=0.8, G=0.02, T_ambient=280.0)  # J/K, W/K: a rig-sized body
    sc = _fig2(fmus=("Drive", "BlockSpring", "Friction", "Thermal"), thermal=thermal)
    ref = reference_solution(sc, t_eval=np.linspace(0.0, sc.stop_time, 40001))
    assert ref.ok
    plain = reference_solution(sc.__class__(**{**sc.__dict__, "fmus": ("Drive", "BlockSpring", "Friction")}),
                               t_eval=ref.time)
    assert np.max(np.abs(ref.v - plain.v)) <= 1e-9 * np.max(np.abs(plain.v))  # dry: T does not act back
    power = ref.F * (ref.V - ref.v)
    assert np.all(power >= -1e-9 * np.max(power))
    # C dT/dt = q P - G (T - Ta), integrated by the trapezoidal rule on the fine grid
    rhs = (thermal.q * power - thermal.G * (ref.T - thermal.T_ambient)) / thermal.C
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rhs[1:] + rhs[:-1]) * np.diff(ref.time))])
    assert np.max(np.abs(ref.T - ref.T[0] - integral)) <= 1e-4 * (ref.T.max() - ref.T.min())
    assert ref.T[0] == 290.0 and ref.T.max() > 290.2


def test_boundary_heating_with_the_temperature_term_off_leaves_the_mechanics_alone():
    sc = load_scenario(SCENARIOS / "boundary_heating.toml",
                       {"time.periods": 0.5, "time.window": [0.0, 0.5], "effects.temperature": False,
                        # phi0 without its alpha T term: the scene's value at 290 K (phi0_star + alpha 290)
                        "friction.phi0_star": 135.5})
    heated = reference_solution(sc, rtol=1e-8)
    plain = reference_solution(dataclasses.replace(sc, fmus=("Drive", "BlockSpring", "Friction")), rtol=1e-8)
    assert heated.ok and plain.ok
    assert np.max(np.abs(heated.v - plain.v)) <= 1e-5 * np.max(np.abs(plain.V))
    assert heated.T[-1] > heated.T[0] + 2.0 and np.all(plain.T == 290.0)
