"""A slip step's local error for a friction with an internal state (coupling/path_error.py): the
defect of the step's own path (the block's curve under the force it felt, the friction's force
along its line) carried to the step's end by the variational equations, against exact
solutions: the augmented system's matrix exponential, and the reduced equations integrated
from the step's start."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from tribofmu.coupling.path_error import forced_response, hermite_bubble, passed_phase_change, path_local_error
from tribofmu.coupling.system import Contact, Point


def exact_response(h, w2, c, p, q, r, force_v, force_f):
    """e(h) of e' = A e + d(s), d cubic in u = s/h, from the augmented system's exponential."""
    Z = np.zeros((7, 7))
    Z[0, 1], Z[1, 0], Z[1, 1], Z[1, 2], Z[2, 1], Z[2, 2] = h, -w2 * h, -c * h, p * h, q * h, r * h
    for k in range(4):
        Z[1, 3 + k], Z[2, 3 + k] = h * math.factorial(k) * force_v[k], h * math.factorial(k) * force_f[k]
        if k:
            Z[3 + k, 2 + k] = 1.0
    return expm(Z)[:3, 3]


CASES = [  # (h, w2, c, p, q, r): slow, a stiff lubricant (r h -6e3), a melting one (r h > 0), a stiff loop
    (1e-3, 4e3, 2.0, 1e-2, 3e4, -4.0),
    (1e-4, 1e5, 30.0, -2e-2, 1e6, -6e7),
    (2e-3, 1e4, 10.0, 20.0, -5.0, 60.0),
    (1e-4, 1e5, 4e4, 3.0, -2e6, -6e5),
]


@pytest.mark.parametrize("h,w2,c,p,q,r", CASES)
def test_the_forced_response_is_the_exponentials(h, w2, c, p, q, r):
    rng = np.random.default_rng(7)
    force_v, force_f = rng.normal(size=4), rng.normal(size=4) * 1e2
    got = np.array(forced_response(h, w2, c, p, q, r, force_v, force_f))
    want = exact_response(h, w2, c, p, q, r, force_v, force_f)
    # (2,3) Pade: exact for the cubic's terms where the dynamics are slow; a stiff mode's part
    # is its quasi-static answer, to a few per cent in v. A stiff mode at |z| ~ 60 keeps a
    # remnant R(z) ~ 3/|z| of its start, which moves the stiff loop's x and f by up to a fifth
    assert got[1] == pytest.approx(want[1], rel=5e-2), (got, want)
    assert np.allclose(got, want, rtol=0.2, atol=1e-3 * np.abs(want).max()), (got, want)


def test_a_slow_step_is_exact_for_each_term_of_the_cubic():
    for k in range(4):  # no dynamics: e_v(h) = h / (k + 1), e_x(h) = h^2 / ((k + 1) (k + 2))
        force = tuple(1.0 if j == k else 0.0 for j in range(4))
        x, v, f = forced_response(1e-3, 0.0, 0.0, 0.0, 0.0, 0.0, force, force)
        assert v == pytest.approx(1e-3 / (k + 1), rel=1e-12) and f == pytest.approx(1e-3 / (k + 1), rel=1e-12)
        assert x == pytest.approx(1e-6 / ((k + 1) * (k + 2)), rel=1e-12)


def test_the_bubble_is_the_hermite_curve_less_the_line():
    dv0, dv1, s0, s1, h = 1e-3, -2e-3, 4.0, -7.0, 1e-3
    b1, b2, b3 = hermite_bubble(dv0, dv1, s0, s1, h)
    for u in np.linspace(0.0, 1.0, 7):
        curve = ((2 * u ** 3 - 3 * u ** 2 + 1) * dv0 + (u ** 3 - 2 * u ** 2 + u) * h * s0
                 + (-2 * u ** 3 + 3 * u ** 2) * dv1 + (u ** 3 - u ** 2) * h * s1)
        assert b1 * u + b2 * u ** 2 + b3 * u ** 3 == pytest.approx(curve - (dv0 + (dv1 - dv0) * u), abs=1e-15)


class Toy:
    """A friction with a state, linear in dv and f: F = k dv + e f, f' = a dv + b f; the block a
    mass M on springs 2K = M w2 with the drive at rest (V = 0, dv = -v)."""

    k, e, a, b, M, w2 = 3.0, 0.5, 40.0, -60.0, 0.2, 900.0

    def rhs(self, t, y):
        x, v, f = y
        dv = -v
        return [v, (self.k * dv + self.e * f) / self.M - self.w2 * x, self.a * dv + self.b * f]

    def force(self, y):
        return self.k * -y[1] + self.e * y[2]

    def slopes(self):  # (c, p, q, r) of estimate.state_slopes
        return self.k / self.M, self.e / self.M, -self.a, self.b


def test_the_path_error_is_the_steps_miss_of_the_exact_flow():
    """A step computed as the coupling does (the block under the force ramp between the two
    ends' forces, the friction's state along the straight line of dv) misses the exact flow of
    the reduced equations; the path error, from the two points and the friction's mean, reads
    that miss in x, v and f to second order in h."""
    toy, y0, misses = Toy(), np.array([1e-3, 0.05, 0.02]), []
    for h in (4e-3, 2e-3):
        exact = solve_ivp(toy.rhs, (0.0, h), y0, method="Radau", rtol=1e-12, atol=1e-16).y[:, -1]
        # the run: the end found by the exact end force (the loop's root), the block under the
        # ramp between the two forces, f along the line of dv between the two ends
        F0, F1 = toy.force(y0), toy.force(exact)
        block = solve_ivp(lambda t, y: [y[1], (F0 + (F1 - F0) * t / h) / toy.M - toy.w2 * y[0]], (0.0, h), y0[:2],
                          method="Radau", rtol=1e-12, atol=1e-16, dense_output=True)
        x1, v1 = block.y[:, -1]
        line = lambda t: -(y0[1] + (v1 - y0[1]) * t / h)  # noqa: E731
        lube = solve_ivp(lambda t, f: [toy.a * line(t) + toy.b * f[0]], (0.0, h), [y0[2]], method="Radau",
                         rtol=1e-12, atol=1e-16, dense_output=True)
        f1 = lube.y[0, -1]
        ts = np.linspace(0.0, h, 2001)
        F_mean = np.trapezoid(toy.k * line(ts) + toy.e * lube.sol(ts)[0], ts) / h
        start = Point(0, x=y0[0], v=y0[1], a=(F0 / toy.M - toy.w2 * y0[0]), F=F0, f=y0[2], mode=Contact.BACKWARD)
        end = Point(int(h * 1e9), x=x1, v=v1, a=(toy.force((x1, v1, f1)) / toy.M - toy.w2 * x1), f=f1,
                    F=toy.force((x1, v1, f1)), F_start=F0, F_rate=(toy.force((x1, v1, f1)) - F0) / h,
                    F_mean=F_mean, mode=Contact.BACKWARD, ramped=True)
        *ends, inside = path_local_error(start, end, h, toy.w2, toy.slopes(), 1.0 / toy.M)
        got, want = np.array(ends), exact - np.array([x1, v1, f1])
        misses.append((got, want))
        # and v's at the step's middle beyond the line between the ends' (what the results
        # between points miss): the exact flow against the block's own path there
        middle = solve_ivp(toy.rhs, (0.0, h / 2), y0, method="Radau", rtol=1e-12, atol=1e-16).y[1, -1]
        inside_true = middle - block.sol(h / 2)[1] - 0.5 * want[1]
        # (16-18 % here: the friction's force along its path taken as the parabola through its
        # ends with its mean)
        assert inside == pytest.approx(inside_true, rel=0.25), (h, inside, inside_true)
        assert np.all(np.abs(got - want) <= 0.05 * np.abs(want)), (h, got, want)  # (2.5 % at 4 ms)
    # and the estimate's error shrinks faster than the error itself (second order in h)
    (g1, w1), (g2, w2) = misses
    assert np.all(np.abs(g2 - w2) / np.abs(w2) < np.abs(g1 - w1) / np.abs(w1))


def test_no_mean_force_no_path_error():
    start = Point(0, F=1.0, f=0.5, mode=Contact.FORWARD)
    end = Point(1000, F=1.1, f=0.5, mode=Contact.FORWARD, ramped=True)
    assert path_local_error(start, end, 1e-6, 1e3, (1.0, 0.0, 0.0, -1.0), 5.0) is None


def lubricant():
    from tribofmu.physics.laws.boundary import BoundaryLaw

    law = BoundaryLaw()
    return law, law.melt_threshold()


def slip_points(law, f0, f1, F_mean, dv0=2e-5, dv1=-1.5e-5, n=-2e5):
    start = Point(0, V=dv0, f=f0, F=law.force(dv0, n, f0), n=n, mode=Contact.FORWARD)
    end = Point(4_000_000, V=dv1, f=f1, F=law.force(dv1, n, f1), n=n, F_mean=F_mean, mode=Contact.BACKWARD)
    return start, end


def test_a_grip_inside_a_molten_step_is_an_event_passed_over():
    """Both ends molten, the friction's mean force over the step (along its line of dv) is the
    molten force's mean but for the solid phase's elastic grip, which only a re-solidifying
    inside the step can give."""
    law, melt = lubricant()
    start, end = slip_points(law, melt + 1.5, melt + 1.2, None)
    molten = law.path_mean_force(start.dv, end.dv, end.n, start.f)
    scale = max(abs(start.F), abs(end.F))
    assert not passed_phase_change(law, start, *slip_points(law, melt + 1.5, melt + 1.2, molten)[1:], scale, 1e-3)
    # a grip: the mean force holds an elastic term neither end has
    gripped = slip_points(law, melt + 1.5, melt + 1.2, molten + 5.0 * scale)[1]
    assert passed_phase_change(law, start, gripped, scale, 1e-3)
    # within tol of the force: not worth a step
    assert not passed_phase_change(law, start, slip_points(law, melt + 1.5, melt + 1.2, molten + 1e-4 * scale)[1],
                                   scale, 1e-3)
    # an end solid: its elastic term is in its own force, no event to tell
    solid_start, solid_end = slip_points(law, melt - 0.2, melt + 1.2, molten + 5.0 * scale)
    assert not passed_phase_change(law, solid_start, solid_end, scale, 1e-3)
    # a friction without a lubricant that melts, or that reports no mean force
    assert not passed_phase_change(None, start, gripped, scale, 1e-3)
    assert not passed_phase_change(law, start, slip_points(law, melt + 1.5, melt + 1.2, None)[1], scale, 1e-3)
