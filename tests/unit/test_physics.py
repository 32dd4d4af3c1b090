"""Tier 1: the physics modules against exact solutions and invariants (no FMI)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from tribofmu.physics import (BlockState, BoundaryLaw, DryLaw, Effects, FluidLaw, MixedLaw, make_law,
                              advance_block, drive, energy)
from tribofmu.physics.roots import illinois

FIG6 = dict(m=0.05, gamma=-2 / 3, S=3e-9)
LAWS = [DryLaw(mu_friction=0.5, S=1.0),
        FluidLaw(m=25.0, gamma=-2 / 3),
        FluidLaw(m=25.0, gamma=0.0),
        FluidLaw(m=25.0, gamma=2 / 3),
        BoundaryLaw(**FIG6),
        MixedLaw(mu_friction=0.3, mu_static=0.5, v_stribeck=0.02, m=3.0)]
DVS = [0.0, 1e-12, 3e-7, 1e-4, 0.05, 2.0]


@pytest.mark.parametrize("law", LAWS, ids=lambda l: f"{l.name}-g{l.gamma:.2f}")
@pytest.mark.parametrize("f", [0.0, 0.2, 1.0, 5.0])
def test_friction_never_adds_energy_and_is_odd(law, f):
    for dv in DVS:
        F = law.force(dv, -1e6, f)
        assert F * dv >= 0.0
        assert law.force(-dv, -1e6, f) == pytest.approx(-F, rel=1e-15, abs=0.0)


def test_dry_friction_is_amontons():
    law = DryLaw(mu_friction=0.5, S=2.0)
    assert law.force(0.3, -20.0) == 0.5 * 40.0
    assert law.force(-1e-9, -20.0) == -20.0
    assert law.force(0.0, -20.0) == 0.0  # the single-valued choice; stick is the master's job


def test_power_law_exponents():
    for gamma in (-2 / 3, 0.0, 2 / 3):
        law = FluidLaw(m=25.0, gamma=gamma)
        assert law.force(0.01, 0.0) == pytest.approx(25.0 * 0.01 ** (gamma + 1))


def test_parameter_problems_name_the_culprit():
    assert DryLaw(gamma=-1.0).problems() == ["gamma must be > -1 (force must vanish at rest), got -1.0"]
    assert "S must be > 0, got 0.0" in DryLaw(S=0.0).problems()
    with pytest.raises(KeyError, match="regime must be|must be 0 \\(dry\\)"):
        make_law(7)
    assert DryLaw().problems() == []
    assert MixedLaw(mu_static=0.4).problems() == [
        "mu_static must be >= mu_friction (0.5: static friction is not below kinetic), got 0.4"]
    assert "v_stribeck must be > 0, got 0.0" in MixedLaw(v_stribeck=0.0).problems()


def test_illinois_agrees_with_brentq():
    fun = lambda x: x ** 3 - 2 * x - 5
    assert illinois(fun, 2.0, 3.0) == pytest.approx(brentq(fun, 2.0, 3.0, xtol=1e-15), abs=1e-13)


def test_boundary_elastic_term_vanishes_when_melted():
    law = BoundaryLaw(**FIG6)
    mu_over_mub = law.lubricant.mu_shear / law.lubricant.mu_shear_bar
    assert law.mu_eff(mu_over_mub + 0.1) == 0.0
    assert law.force(1e-5, -1e6, mu_over_mub + 0.1) == pytest.approx(law.viscous_force(1e-5))


def test_boundary_effects_switch_terms_off():
    only_elastic = BoundaryLaw(**FIG6, effects=Effects(viscous=False))
    assert only_elastic.force(1e-5, -1e6, 0.2) == pytest.approx(
        2 * only_elastic.mu_eff(0.2) * only_elastic.shear_strain(1e-5) * 3e-9)
    frozen = BoundaryLaw(**FIG6, effects=Effects(melting=False))
    assert frozen.advance_f(0.3, 1e-5, -1e6, 290.0, 1e-3) == 0.3


def _equilibria(law, dv, n, T):
    grid = np.linspace(-0.5, 10, 20001)
    rate = np.array([law.kinetics_rate(f, dv, n, T) for f in grid])
    idx = np.nonzero(np.sign(rate[:-1]) != np.sign(rate[1:]))[0]
    return [brentq(law.kinetics_rate, grid[i], grid[i + 1], args=(dv, n, T)) for i in idx]


def test_kinetics_fixed_points_and_bistability_at_rest():
    law = BoundaryLaw(**FIG6)
    roots = _equilibria(law, 0.0, -1e6, 290.0)
    # phi0 - phi1 f + phi2 f^2 - phi3 f^3 - pressure: three roots, the outer two stable
    assert len(roots) == 3
    solid = roots[0]
    assert 0.2 < solid < law.lubricant.mu_shear / law.lubricant.mu_shear_bar
    for f_start in (0.0, solid - 0.05, solid + 0.05):
        assert law.advance_f(f_start, 0.0, -1e6, 290.0, 0.05) == pytest.approx(solid, abs=1e-6)
    assert law.advance_f(solid, 0.0, -1e6, 290.0, 1.0) == pytest.approx(solid, abs=1e-9)


def test_kinetics_step_matches_radau_and_never_crosses_equilibrium():
    law = BoundaryLaw(**FIG6)
    for dv in (0.0, 1e-6, 3e-6, 4e-5):
        for h in (1e-6, 1e-4, 1e-2):
            f = law.advance_f(0.0, dv, -1e6, 290.0, h)
            ref = solve_ivp(lambda t, y: [law.kinetics_rate(y[0], dv, -1e6, 290.0)], (0, h), [0.0],
                            method="Radau", rtol=1e-11, atol=1e-13).y[0, -1]
            assert f == pytest.approx(ref, abs=5e-6, rel=5e-6)
            target = _equilibria(law, dv, -1e6, 290.0)[0]
            assert f <= target + 1e-12


def test_kinetics_stays_finite_for_huge_steps():
    law = BoundaryLaw(**FIG6)
    f = 0.0
    for dv in (1e-3, -1e-6, 0.0, 5.0):
        f = law.advance_f(f, dv, -1e6, 290.0, 10.0)
        assert math.isfinite(f)


def test_block_free_oscillator_is_exact():
    M, K, x0 = 0.6, 7000.0, 1e-3
    w0 = math.sqrt(2 * K / M)
    state = BlockState(x0, 0.0)
    t = 0.0
    for h in (1e-3, 0.37, 1e-5, 2.0):
        state = advance_block(state, 0.0, 0.0, h, M, K)
        t += h
        assert state.x == pytest.approx(x0 * math.cos(w0 * t), abs=1e-15)
        assert state.v == pytest.approx(-x0 * w0 * math.sin(w0 * t), abs=1e-13)
        assert energy(state, M, K) == pytest.approx(K * x0 ** 2, rel=1e-12)


@pytest.mark.parametrize("K", [0.0, 7000.0, 1e7])
def test_block_under_ramp_force_matches_ode(K):
    M, F0, rate, h = 0.6, 3.0, -40.0, 0.02
    state = advance_block(BlockState(1e-4, -0.02), F0, rate, h, M, K)
    sol = solve_ivp(lambda t, y: [y[1], (F0 + rate * t - 2 * K * y[0]) / M], (0, h), [1e-4, -0.02],
                    method="DOP853", rtol=1e-12, atol=1e-15)
    assert state.x == pytest.approx(sol.y[0, -1], abs=1e-12)
    assert state.v == pytest.approx(sol.y[1, -1], abs=1e-9)


def test_drive_is_harmonic():
    X, V, acc = drive(0.1, 2e-3, 30.0)
    assert (X, V, acc) == pytest.approx((2e-3 * math.cos(3.0), -2e-3 * 30 * math.sin(3.0),
                                         -2e-3 * 900 * math.cos(3.0)))


def test_the_melt_margin_changes_sign_where_the_elastic_term_switches_off():
    """mu/mu_bar - f: > 0 while eq. (19)'s shear modulus acts, <= 0 once it is floored at 0;
    laws without a lubricant report 1 (nothing melts)."""
    law = BoundaryLaw()
    lub = law.lubricant
    melt = lub.mu_shear / lub.mu_shear_bar
    for f in (0.0, 0.5 * melt, 0.999 * melt, 1.001 * melt, 2.0 * melt):
        assert (law.melt_margin(f) > 0) == (law.mu_eff(f) > 0), f
    assert law.melt_margin(melt) == pytest.approx(0.0, abs=1e-12)
    assert DryLaw().melt_margin(5.0) == 1.0 == FluidLaw().melt_margin(5.0)


def test_mixed_friction_is_the_stribeck_curve_with_a_static_limit():
    """F = [mu_c + (mu_s - mu_c) exp(-(|dv|/v_s)^delta)] L sgn(dv) + m dv; it holds up to
    mu_s L at dv = 0 and its mean over a linear dv path is the path's integral (quadrature)."""
    from scipy.integrate import quad

    law = MixedLaw(mu_friction=0.3, mu_static=0.5, v_stribeck=0.02, stribeck_exponent=1.7, m=3.0, S=2.0)
    L = 40.0  # N at n = -20 Pa
    for dv in (1e-9, 0.005, 0.02, 0.3):
        expected = (0.3 + 0.2 * math.exp(-(dv / 0.02) ** 1.7)) * L + 3.0 * dv
        assert law.force(dv, -20.0) == pytest.approx(expected, rel=1e-14)
        assert law.slip_force(dv, -20.0, 1.0) == law.force(dv, -20.0)
    assert law.force(0.0, -20.0) == 0.0 and law.slip_force(0.0, -20.0, -1.0) == -0.5 * L
    assert law.static_limit(-20.0) == 0.5 * L and law.sticks and not DryLaw().has_state
    for a, b in ((-0.03, 0.05), (0.001, 0.2), (-0.4, -0.002), (0.02, 0.02 + 1e-9)):
        exact = quad(lambda x: law.force(x, -20.0), a, b, points=[0.0] if a < 0 < b else None,
                     epsabs=0.0, epsrel=1e-13, limit=200)[0] / (b - a)
        assert law.mean_force(a, b, -20.0) == pytest.approx(exact, rel=1e-9), (a, b)
    assert law.input_problems(0.0, 5.0, 290.0) == ["n must be <= 0 (compression) for mixed friction, got 5.0"]


def test_the_registry_resolves_names_and_fmu_codes_to_one_law_each():
    from tribofmu.physics.laws import LAWS, law_class

    assert [(law.name, law.code) for law in LAWS.values()] == [
        ("dry", 0), ("fluid", 1), ("boundary", 2), ("mixed", 3)]  # the FMU's codes never change
    for law in LAWS.values():
        assert law_class(law.name) is law_class(law.code) is law
    assert make_law("mixed", mu_static=0.7, lam=1.0) == MixedLaw(mu_static=0.7)  # others' keys ignored
    with pytest.raises(KeyError, match="must be one of dry, fluid, boundary, mixed, got 'wet'"):
        law_class("wet")


def test_kinetics_made_once_per_inputs_follow_a_change_of_n_and_T():
    """The law keeps the kinetics it made for the last (n, T): a step at other inputs gives
    what a fresh law gives there, and the law still pickles (the closures are not state)."""
    import pickle

    law = BoundaryLaw(**FIG6)
    steps = [(-1e6, 290.0), (-2e6, 290.0), (-2e6, 330.0), (-1e6, 290.0)]
    for n, T in steps:
        fresh = BoundaryLaw(**FIG6)
        got = law.advance(0.1, 2e-5, n, T, 1e-4, 1e-5, 1e-5, dv_start=1e-5)
        assert got == fresh.advance(0.1, 2e-5, n, T, 1e-4, 1e-5, 1e-5, dv_start=1e-5)
    again = pickle.loads(pickle.dumps(law))
    assert again == law
    assert again.advance(0.1, 2e-5, -1e6, 290.0, 1e-4) == law.advance(0.1, 2e-5, -1e6, 290.0, 1e-4)


@pytest.mark.parametrize("stiffness", [1e-3, 0.05, 1.0, 29.0, 1e3])
def test_a_kinetics_sub_step_reports_the_means_of_f_along_its_own_model(stiffness):
    """For a rate linear in f and in time (df/dt = -k (f - f_eq) + a t) the exponential
    sub-step is exact: its end f and, along it, the means of f and of f s/h (from which the
    mean of the elastic force f dv follows, dv moving linearly) are the exact solution's. A
    stiff sub-step (k h >> 1) sits at its end value nearly all along: the ends' average is not
    its mean. From a slow sub-step to one a thousand relaxation times long."""
    from scipy.integrate import quad

    k, f_eq, a, f0, h = stiffness / 1e-4, 0.4, 2e3, 0.1, 1e-4

    def rate(f, t):  # (the second argument is what moves in time: here time itself)
        return -k * (f - f_eq) + a * t

    def exact(t):
        return f_eq + (f0 - f_eq) * math.exp(-k * t) + a * (t / k - (1.0 - math.exp(-k * t)) / k ** 2)

    f1, _, _, f_mean, f_late = BoundaryLaw._substep(rate, lambda f: -k, f0, rate(f0, 0.0), h, a, h)
    points = [h / stiffness * i for i in (1, 3, 10)] if stiffness > 1 else None
    mean = quad(exact, 0.0, h, epsabs=0.0, epsrel=1e-13, points=points)[0] / h
    late = quad(lambda t: exact(t) * t / h, 0.0, h, epsabs=0.0, epsrel=1e-13, points=points)[0] / h
    assert f1 == pytest.approx(exact(h), rel=1e-10)
    assert f_mean == pytest.approx(mean, rel=1e-9) and f_late == pytest.approx(late, rel=1e-9)
    if stiffness > 10:  # (not the ends' average, nor its weighting)
        assert abs(f_mean - 0.5 * (f0 + f1)) > 0.1 * abs(f1 - f0)
