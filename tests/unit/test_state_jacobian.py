"""A friction law's slopes for the variational equations of its force and its state
(``FrictionLaw.state_jacobian``): the base by central differences, the boundary law's exact,
each against a derivative known in closed form."""
from __future__ import annotations

import math

import pytest

from tribofmu.physics.friction import Effects, FrictionLaw
from tribofmu.physics.laws.boundary import BoundaryLaw
from tribofmu.physics.laws.dry import DryLaw


class CubicStateLaw(FrictionLaw):
    """A made-up law with state whose slopes are known: F = 3 dv^3 + 2 f^2 dv, g = -5 f^3 + 7 dv^2 n."""

    has_state = True

    def force(self, dv, n, f=0.0):
        return 3.0 * dv ** 3 + 2.0 * f * f * dv

    def kinetics_rate(self, f, dv, n, T):
        return -5.0 * f ** 3 + 7.0 * dv * dv * n

    @staticmethod
    def exact(dv, f, n, T):
        return 9.0 * dv * dv + 2.0 * f * f, 4.0 * f * dv, 14.0 * dv * n, -15.0 * f * f


@pytest.mark.parametrize("dv,f", [(0.3, 0.7), (-2.0, 1.5), (0.05, -0.2), (0.5, 0.4)])
def test_the_base_differences_meet_the_exact_slopes(dv, f):
    """To about eps^(2/3) ~ 4e-11 of the function's size over its step (truncation and
    round-off balanced): 1e-7 relative here, where no slope is far below its function's size."""
    law = CubicStateLaw()
    got, exact = law.state_jacobian(dv, f, -3.0, 290.0), CubicStateLaw.exact(dv, f, -3.0, 290.0)
    for a, b in zip(got, exact):
        assert a == pytest.approx(b, rel=1e-7)


def test_a_law_without_state_has_no_state_slopes():
    law = DryLaw(mu_friction=0.5, S=1.0)
    F_dv, F_f, g_dv, g_f = law.state_jacobian(0.2, 0.0, -20.0, 290.0)
    assert (F_dv, F_f, g_dv, g_f) == (0.0, 0.0, 0.0, 0.0)  # slipping, mu L is flat in dv


LUBRICANT_POINTS = [(1e-3, 0.3), (-2e-3, 0.9), (4e-4, 1.02), (-1e-5, -0.1)]


@pytest.mark.parametrize("gamma", [-0.5, 0.0, 1.0])
@pytest.mark.parametrize("dv,f", LUBRICANT_POINTS)
def test_the_boundary_laws_exact_slopes_are_its_force_and_rate_differenced(gamma, dv, f):
    """Against the force's own closed form (eq. 23: 2 mu_eff tau_e/h dv S + m |dv|^(gamma+1))
    and the rate's differences: in f at dv = 0 (the strain's dv^2 term only adds to the rate,
    and would swamp a difference in f with its round-off), in dv at a thousandth of dv."""
    law = BoundaryLaw(m=0.05, gamma=gamma, S=3e-9)
    n, T = -1e6, 290.0
    F_dv, F_f, g_dv, g_f = law.state_jacobian(dv, f, n, T)
    lub = law.lubricant
    k = 2.0 * lub.tau_e / lub.h * law.S
    mu_eff = lub.mu_shear - lub.mu_shear_bar * f
    assert F_dv == pytest.approx(k * mu_eff + law.m * (gamma + 1) * abs(dv) ** gamma, rel=1e-12)
    assert F_f == pytest.approx(-k * lub.mu_shear_bar * dv, rel=1e-12)
    step = 1e-6
    rate = lambda f_, dv_: law.kinetics_rate(f_, dv_, n, T)  # noqa: E731
    assert g_f == pytest.approx((rate(f + step, 0.0) - rate(f - step, 0.0)) / (2 * step), rel=1e-6)
    dstep = 1e-3 * abs(dv)
    assert g_dv == pytest.approx((rate(f, dv + dstep) - rate(f, dv - dstep)) / (2 * dstep), rel=1e-6)


def test_past_the_melt_threshold_the_elastic_term_has_no_slope():
    """mu_eff is floored at 0 (eq. 19): molten, only the viscous term moves with dv, none with f."""
    law = BoundaryLaw(m=0.05, gamma=0.0, S=3e-9)
    f = law.melt_threshold() + 0.1
    F_dv, F_f, _, _ = law.state_jacobian(2e-3, f, -1e6, 290.0)
    assert (F_dv, F_f) == (0.05, 0.0)


def test_a_shear_thinning_slope_at_rest_is_infinite_and_without_melting_f_stands():
    law = BoundaryLaw(m=0.05, gamma=-0.5, S=3e-9)
    assert law.state_jacobian(0.0, 0.2, -1e6, 290.0)[0] == math.inf
    from tribofmu.physics.friction import Effects
    frozen = BoundaryLaw(m=0.05, gamma=0.0, S=3e-9, effects=Effects(melting=False))
    assert frozen.state_jacobian(1e-3, 0.2, -1e6, 290.0)[2:] == (0.0, 0.0)


# steps of Fig. 6's lubricant (n = -1 MPa, T = 290 K, melt threshold f = 1.025) as a run takes them:
# (f0, dv0, dv1 [m/s], h [s]): re-solidifying across the melt, molten and stiff, solid and slow, reversing
STEPS = [(3.5335, -2.7696e-05, -1.4346e-05, 2.3e-3), (8.08, 1.2e-3, 1.1e-3, 2.5e-3),
         (0.63, 2.0e-5, 2.6e-5, 1.2e-4), (0.85, -3.0e-5, -2.2e-5, 1.1e-5), (0.97, 4.0e-6, -3.0e-6, 2.1e-5)]


@pytest.mark.parametrize("gamma", [-2.0 / 3.0, 0.5, 1.5])
@pytest.mark.parametrize("f0,dv0,dv1,h", STEPS)
def test_a_steps_sensitivities_are_its_own_map_differenced(gamma, f0, dv0, dv1, h):
    """BoundaryLaw.step_sensitivities (the tangent followed along the sub-steps) against central
    differences of advance itself, both at kinetics tolerance 1e-11, inputs moved by 1e-4 of
    themselves. Each row within 1e-3 of its largest entry: both converge as the sub-steps
    shrink (at 1e-9 they differ by up to 1 % on a step that starts off its equilibrium; at
    1e-12 the differences are round-off, 5.6 to 26.6 for a slope of 10.3)."""
    law = BoundaryLaw(m=0.05, gamma=gamma, S=3e-9)
    n, T, tol = -1e6, 290.0, 1e-11
    f1, (f_row, F_row) = law.step_sensitivities(f0, dv1, n, T, h, tol, tol, dv_start=dv0)
    assert f1 == law.advance(f0, dv1, n, T, h, tol, tol, dv_start=dv0)[0]  # (the same path)
    for got, expected in zip((f_row, F_row), differenced(law, (f0, dv0, dv1), n, T, h, tol, 1e-4)):
        for j in range(3):
            assert got[j] == pytest.approx(expected[j], abs=1e-3 * max(map(abs, got)))


def differenced(law, inputs, n: float, T: float, h: float, tol: float, relative: float):
    """The rows (d f1, d F_mean) against (f0, dv0, dv1) of BoundaryLaw.advance at kinetics
    tolerance tol, by central differences, each input moved by relative of itself (of 1e-3 for
    f0 and 1e-6 m/s for dv at least)."""
    rows = ([], [])
    for j in range(3):
        step = relative * max(abs(inputs[j]), 1e-3 if j == 0 else 1e-6)
        up, down = list(inputs), list(inputs)
        up[j] += step
        down[j] -= step
        a = law.advance(up[0], up[2], n, T, h, tol, tol, dv_start=up[1])
        b = law.advance(down[0], down[2], n, T, h, tol, tol, dv_start=down[1])
        for k in (0, 1):
            rows[k].append((a[k] - b[k]) / (2.0 * step))
    return rows


# Fig. 6's steps across the melt threshold f = 1.025 (f0, dv0, dv1 [m/s], h [s]): melting, re-solidifying
CROSSING = [(1.0247397495283714, 2.2397193194669568e-06, 2.244063826983867e-06, 5.64e-07),
            (1.0251026190446524, -2.183183177691766e-06, -2.1819477234249893e-06, 2.46e-07),
            (1.0237121735528074, 2.2333871503355503e-06, 2.245390355763538e-06, 1.559e-06)]


@pytest.mark.parametrize("f0,dv0,dv1,h", CROSSING)
def test_a_step_across_the_melt_has_its_sensitivities_at_the_fmus_tolerance(f0, dv0, dv1, h):
    """Across the melt threshold the elastic modulus and the rate's slope have a kink; the tangent
    follows the sub-step that crosses it in two parts that meet there (StepTangent.substep). At the
    FMUs' kinetics tolerance (1e-5), where one sub-step spans the crossing, the mean force's row
    and f's row are within 2 % of their largest entries of central differences of advance at
    1e-13 (with the sub-step's middle slopes, the whole crossing sub-step was taken on one side:
    30-80 % off)."""
    law = BoundaryLaw(m=0.05, gamma=-2.0 / 3.0, S=3e-9)
    n, T = -1e6, 290.0
    f1, (f_row, F_row) = law.step_sensitivities(f0, dv1, n, T, h, 1e-5, 1e-5, dv_start=dv0)
    melt = law.melt_threshold()
    assert (f0 - melt) * (f1 - melt) < 0.0  # (the step does cross)
    for got, expected in zip((f_row, F_row), differenced(law, (f0, dv0, dv1), n, T, h, 1e-13, 1e-5)):
        for j in range(3):
            assert got[j] == pytest.approx(expected[j], abs=2e-2 * max(map(abs, got)))


def test_a_lubricant_that_cannot_melt_has_no_step_sensitivities():
    """Melting off, f does not move: no step map to follow (the carry takes the law's slopes)."""
    law = BoundaryLaw(m=0.05, gamma=0.5, S=3e-9, effects=Effects(melting=False))
    assert law.step_sensitivities(0.5, 1e-3, -1e6, 290.0, 1e-3, dv_start=2e-3) is None
    assert BoundaryLaw(m=0.05, gamma=0.5, S=3e-9).step_sensitivities(0.5, 1e-3, -1e6, 290.0, 1e-3) is not None


def test_a_law_that_gives_a_step_map_has_state_and_the_map():
    """FrictionLaw.gives_step_map: the coupling carries such a law's steps by step_sensitivities
    and does not verify its runs (coupling/estimate.py carry_needs_verification); a law that
    says so has state and the method, and the boundary law is one."""
    from tribofmu.physics.laws import LAWS

    giving = [law for law in LAWS.values() if law.gives_step_map]
    assert [law.name for law in giving] == ["boundary"]
    for law in giving:
        assert law.has_state and callable(getattr(law, "step_sensitivities", None))
