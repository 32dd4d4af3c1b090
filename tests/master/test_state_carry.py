"""The carried error of a friction with an internal state (coupling/estimate.py): the error
(ex, ev, ef) moves by the variational equations of the block and the law's state, their
coefficients the law's own slopes (``FrictionLaw.state_jacobian``), over each step by the
(1,2) Pade approximant of the exponential (``state_flow``); without a law with state, the
block's 2x2 carry of before."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from tribofmu.coupling.estimate import GlobalErrorEstimate
from tribofmu.coupling.variational import state_flow
from tribofmu.coupling.system import Contact, Point
from tribofmu.physics.friction import FrictionLaw
from tribofmu.physics.laws.dry import DryLaw


def matrix(w2, c, p, q, r):
    return np.array([[0.0, 1.0, 0.0], [-w2, -c, p], [0.0, q, r]])


def pade(B):
    """The (1,2) Pade approximant in its matrix form, (I - 2B/3 + B^2/6)^-1 (I + B/3)."""
    identity = np.eye(3)
    return np.linalg.solve(identity - 2.0 * B / 3.0 + B @ B / 6.0, identity + B / 3.0)


NON_STIFF = [  # (h, w2, c, p, q, r): |A h| at most ~0.3
    (1e-4, 4e6, 50.0, 3e3, -2e2, -4e2),
    (2e-3, 1e4, 10.0, 20.0, -5.0, 60.0),  # a growing f-mode (melting): r h = 0.12
    (1e-3, 0.0, 0.0, 0.0, 0.0, 0.0),  # no spring, no friction: x drifts with v
]


@pytest.mark.parametrize("h,w2,c,p,q,r", NON_STIFF)
def test_the_propagator_is_the_exponential_to_third_order_where_the_step_is_short(h, w2, c, p, q, r):
    A = matrix(w2, c, p, q, r)
    e = np.array([1e-6, 1e-4, 1e-3])
    got = np.array(state_flow(h, w2, c, p, q, r, *e))
    exact = expm(A * h) @ e
    # in units where x is measured by how far v moves it in a step (x / h), A h is of size
    # |A h| and the approximant misses e^(A h) by about |A h|^4 / 72 of the vector
    units = np.array([h, 1.0, 1.0])
    size = max(np.abs(exact / units).max(), np.abs(e / units).max())
    miss = np.abs(got - exact) / units
    z = max(np.linalg.norm(A * h, 2), 1e-3)
    assert miss.max() <= z ** 4 / 24.0 * size, (got, exact)
    assert got == pytest.approx(pade(A * h) @ e, rel=1e-10, abs=1e-22)  # the approximant, exactly


STIFF = [  # (h, w2, c, p, q, r)
    (1e-3, 1e4, 1e8, 1e2, -1e-3, -1e7),  # a solid lubricant's viscous slope: c h = 1e5
    (1e-3, 2.9e4, 20.0, -2.4e-5 / 0.7, -1.6e7 * 1e-3, -1e7),  # f relaxing at |r| h = 1e4
    (5e-4, 2.9e4, 2e6, -40.0, -8e9 * 1e-3, -3.5e6),  # both stiff (c h = 1e3), coupled through p q > 0
]


@pytest.mark.parametrize("h,w2,c,p,q,r", STIFF)
def test_the_propagator_damps_a_stiff_mode_as_the_exponential_does(h, w2, c, p, q, r):
    """L-stable: a mode with z far in the left half-plane is all but gone at the step's end
    (R(z) ~ 2/z: 2e-3 of it at z = -1e3, what the approximant leaves), as e^z is: what is
    left is the slow mode, which both carry alike; an A-stable rule without L-stability (the
    trapezoid's (1 + z/2)/(1 - z/2) -> -1) would hand the stiff mode on, flipped, every step."""
    A = matrix(w2, c, p, q, r)
    e = np.array([1e-6, 1e-4, 1e-3])
    got = np.array(state_flow(h, w2, c, p, q, r, *e))
    exact = expm(A * h) @ e
    assert got == pytest.approx(pade(A * h) @ e, rel=1e-8, abs=1e-12 * np.abs(e).max())
    scale = np.abs(e) + np.abs(exact)
    assert np.all(np.abs(got - exact) <= 0.05 * scale + 1e-9 * np.abs(e).max()), (got, exact)
    # the stiff components are damped, not rung back
    assert abs(got[2]) < 0.05 * abs(e[2]) and abs(exact[2]) < 0.05 * abs(e[2])


class LinearStateLaw(FrictionLaw):
    """A law with state whose coupled problem is linear: F = k dv + b f, df/dt = -a f + s dv
    (its slopes by the base's central differences, exact for a linear law up to round-off)."""

    has_state = True
    k, b, a, s = 3.0, -2.0, 40.0, 5.0

    def force(self, dv, n, f=0.0):
        return self.k * dv + self.b * f

    def kinetics_rate(self, f, dv, n, T):
        return -self.a * f + self.s * dv


def test_the_carry_of_a_law_with_state_is_the_linear_problems_exact_error():
    """Block M between springs 2K, drive at rest, friction of :class:`LinearStateLaw`: the
    coupled problem M x'' = -2K x + F(-x', f), f' = g(-x', f) is linear, so the difference
    of two solutions is carried exactly by its variational equations. An error put in at the
    first step (as a step's local error) and carried by the estimate over 400 steps of
    varied length is that difference, to the approximant's third order."""
    M, K = 0.5, 200.0
    law = LinearStateLaw()
    estimate = GlobalErrorEstimate(law)
    estimate.w2 = 2.0 * K / M
    vpi = 1.0 / M
    rng = np.random.default_rng(7)
    steps = rng.uniform(0.5e-3, 1.5e-3, 400)
    x0, v0, f0 = 1e-3, -2e-2, 0.1  # (the unperturbed solution's start: the slopes don't depend on it)
    e0 = np.array([2e-7, -3e-6, 4e-5])

    def rhs(t, y):
        x, v, f = y
        dv = -v
        return [v, (-2.0 * K * x + law.force(dv, 0.0, f)) / M, law.kinetics_rate(f, dv, 0.0, 0.0)]

    t_end = float(steps.sum())
    base = solve_ivp(rhs, (0.0, t_end), [x0, v0, f0], method="DOP853", rtol=1e-12, atol=1e-16)
    perturbed = solve_ivp(rhs, (0.0, t_end), [x0, v0, f0] + e0, method="DOP853", rtol=1e-12, atol=1e-16)
    exact = perturbed.y[:, -1] - base.y[:, -1]

    estimate.ex, estimate.ev, estimate.ef = e0  # the error at t = 0, carried by every step from there
    point, t_ns = Point(0, v=v0, f=f0, n=-20.0, T=290.0, mode=Contact.FORWARD), 0
    for h in steps:
        t_ns += int(round(h * 1e9))
        new = Point(t_ns, v=v0, f=f0, n=-20.0, T=290.0, mode=Contact.FORWARD)
        slopes = estimate.state_slopes(point, new, vpi, 1e-12)
        assert slopes == pytest.approx((law.k * vpi, law.b * vpi, -law.s, -law.a), rel=1e-7)
        estimate.advance(h, 0.0, 0.0, 0.0, False, slopes=slopes)
        point = new
    got = np.array([estimate.ex, estimate.ev, estimate.ef])
    assert got == pytest.approx(exact, rel=1e-3), (got, exact)
    assert np.abs(exact).min() > 1e-3 * np.abs(e0).min()  # (an error that did not vanish on the way)


def test_without_a_law_with_state_the_block_carries_alone():
    """A law without state, or none given (a user's own Friction FMU): no slopes, the block's
    2x2 carry (ex' = ev, ev' = -w2 ex - c ev) in closed form, ef untouched; a law with state
    before the block's mass is known: no slopes either."""
    a, b = Point(0, v=0.1, mode=Contact.FORWARD), Point(1000, v=0.1, mode=Contact.FORWARD)
    dry = GlobalErrorEstimate(DryLaw(mu_friction=0.5, S=1.0))
    assert dry.law is None and dry.state_slopes(a, b, 2.0, 1e-12) is None
    assert GlobalErrorEstimate(LinearStateLaw()).state_slopes(a, b, 0.0, 1e-12) is None
    plain = GlobalErrorEstimate()
    assert plain.state_slopes(a, b, 2.0, 1e-12) is None
    plain.w2, plain.ex, plain.ev, plain.ef = 1e4, 1e-6, 1e-4, 0.0
    h, c = 1e-3, 50.0
    plain.advance(h, c, 0.0, 0.0, False)
    exact = expm(np.array([[0.0, 1.0], [-1e4, -c]]) * h) @ np.array([1e-6, 1e-4])
    assert (plain.ex, plain.ev) == pytest.approx(tuple(exact), rel=1e-10) and plain.ef == 0.0


def test_the_state_error_travels_with_a_snapshot():
    estimate = GlobalErrorEstimate(LinearStateLaw())
    estimate.ex, estimate.ev, estimate.ef, estimate.w2 = 1e-6, 2e-5, 3e-4, 1e4
    copy = GlobalErrorEstimate(LinearStateLaw())
    copy.restore(json.loads(json.dumps(estimate.export())))
    assert (copy.ex, copy.ev, copy.ef, copy.w2) == (1e-6, 2e-5, 3e-4, 1e4)
    old = GlobalErrorEstimate()
    old.restore([1e-6, 2e-5, 1e4, None])  # a snapshot from before the state's error
    assert old.ef == 0.0


def test_a_slope_infinite_at_rest_is_taken_at_the_solves_resolution():
    """A shear-thinning lubricant's viscous slope is infinite at dv = 0: the step's middle dv is
    taken no nearer 0 than the resolution the caller gives, and the slopes stay finite."""
    from tribofmu.physics.laws.boundary import BoundaryLaw

    estimate = GlobalErrorEstimate(BoundaryLaw(m=0.05, gamma=-0.85, S=3e-9))
    a = Point(0, V=1e-3, v=1e-3, f=0.1, n=-1e6, T=290.0, mode=Contact.FORWARD)
    b = Point(1000, V=1e-3, v=1e-3, f=0.1, n=-1e6, T=290.0, mode=Contact.FORWARD)
    slopes = estimate.state_slopes(a, b, 1.0 / 0.7, 1e-13)
    assert slopes is not None and all(map(math.isfinite, slopes))
    assert slopes[0] == estimate.law.state_jacobian(1e-13, 0.1, -1e6, 290.0)[0] / 0.7
    assert slopes[0] > 1e8  # (the viscous slope at 1e-13 m/s: 0.05 x 0.15 x 1e-13^-0.85 / 0.7)


def test_the_propagated_method_says_the_lubricants_motion_is_carried_where_the_law_is_known():
    from types import SimpleNamespace

    from tribofmu import api
    from tribofmu.coupling.estimate import GlobalErrorEstimate
    from tribofmu.coupling.window_error import WindowError
    from tribofmu.physics.laws import law_class

    def method(law) -> str:
        coupling = SimpleNamespace(name="adaptive", estimate=GlobalErrorEstimate(law))
        return api.estimated_error(coupling, WindowError((0.0, 1.0)), "not here")["method"]

    assert "the block's and the lubricant's linearised motion" in method(law_class("boundary")())
    assert "carried through the block's linearised motion" in method(law_class("dry")())  # no state
    assert "carried through the block's linearised motion" in method(None)  # a Friction FMU of unknown make


@pytest.mark.parametrize("h", [1e-4, 3e-4, 1e-3])
def test_a_step_map_of_constant_slopes_is_the_variational_flow_to_third_order(h):
    """step_transition with the sensitivities of a linear law (f relaxing at rate r toward
    -q/r dv, F = c M dv + p M f, dv linear over the step, the mean force's slopes a step's
    trapezoid and the f row the exact flow of that model) against e^(A h) of the variational
    equations: the map is their midpoint-implicit step, off by O(h^3) per step."""
    from tribofmu.coupling.variational import step_transition

    w2, c, p, q, r, M = 4.0e4, 30.0, 2.0, 50.0, -400.0, 0.5
    e = np.array([1e-6, 2e-5, 3e-3])
    exact = expm(matrix(w2, c, p, q, r) * h) @ e
    # f1 of the model over the step differentiated by hand (dv linear); F_mean's slopes by the
    # trapezoid (its f term from f's ends: second order, as the map is)
    z = r * h
    f_f, f_0, f_1 = math.exp(z), q / r * (math.exp(z) - (math.exp(z) - 1.0) / z), q / r * ((math.exp(z) - 1.0) / z - 1.0)
    m_f, m_0, m_1 = p * M * (1.0 + f_f) / 2.0, c * M / 2.0 + p * M * f_0 / 2.0, c * M / 2.0 + p * M * f_1 / 2.0
    carried = np.array(step_transition(h, w2, 1.0 / M, ((f_f, f_0, f_1), (m_f, m_0, m_1)), *e))
    scale = np.abs(exact)
    # (with the implicit share of the end's dv dropped, v is off 1.5e-3 at h = 1e-4: caught)
    assert np.all(np.abs(carried - exact) <= 0.01 * (h / 1e-3) ** 2 * scale + 1e-12), (carried, exact)


def test_the_viscous_means_slopes_meet_the_middles_where_the_span_cancels():
    """BoundaryLaw._viscous_mean_slopes: a span of dv below eps^(1/3) of it takes the middle's
    slope, half each; just above it the closed form gives the same to its own accuracy."""
    from tribofmu.physics.laws.boundary import BoundaryLaw

    law = BoundaryLaw(m=0.05, gamma=0.5, S=3e-9)
    dv = 2e-3
    middle = 0.05 * 1.5 * dv ** 0.5
    for span in (1e-9, 1e-5, 1e-3):
        a, b = law._viscous_mean_slopes(dv, dv * (1.0 + span))
        assert a + b == pytest.approx(middle, rel=max(2.0 * span, 1e-9)), span
        assert a == pytest.approx(b, rel=max(2.0 * span, 1e-9))
