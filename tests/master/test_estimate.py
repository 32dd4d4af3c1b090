"""The run's own error estimate (coupling/estimate.py) against exact solutions."""
import math
import random
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import expm

from tribofmu.coupling.algorithms import AdaptiveCoupling
from tribofmu.coupling.estimate import GlobalErrorEstimate
from tribofmu.coupling.settings import STEP_CONTROL
from tribofmu.coupling.window_error import WindowError
from tribofmu.coupling.system import Contact
from tribofmu.physics import FluidLaw

from fakes import drive_scales, fig2_system

# (w2 [1/s^2], c [1/s], h [s]): under-, over- and critically damped, undamped, a free mass,
# a free mass with damping, a damping so stiff that exp(l2 h) underflows, and negative
# damping (a friction whose force falls as the slip grows: the error grows)
CASES = [(1e4, 10.0, 1e-3), (100.0, 1e3, 2e-3), (2500.0, 100.0, 1e-3), (4e4, 0.0, 5e-3),
         (0.0, 0.0, 1e-2), (0.0, 50.0, 1e-2), (1e4, 1e6, 1e-3), (23333.0, 3.0, 0.02),
         (23333.0, -400.0, 2e-3), (100.0, -3e3, 1e-3)]


def matrix(w2, c):
    return np.array([[0.0, 1.0], [-w2, -c]])


def estimate_at(w2, ex, ev):
    estimate = GlobalErrorEstimate()
    estimate.w2, estimate.ex, estimate.ev = w2, ex, ev
    return estimate


@pytest.mark.parametrize("w2, c, h", CASES)
def test_carried_error_is_the_exact_flow_of_the_linear_error_ode(w2, c, h):
    e0 = np.array([3e-6, -2e-4])
    estimate = estimate_at(w2, *e0)
    ev = estimate.advance(h, c, 0.0, 0.0, stuck=False)
    exact = expm(matrix(w2, c) * h) @ e0
    scale = np.abs(e0).max()
    assert estimate.ex == pytest.approx(exact[0], abs=1e-12 * scale, rel=1e-9)
    assert ev == estimate.ev == pytest.approx(exact[1], abs=1e-12 * scale, rel=1e-9)


def test_local_errors_add_after_the_flow_and_superpose():
    """Errors committed at each step are carried by the steps after: the estimate at the
    end is the sum over steps of exp(A (t_N - t_k)) l_k, with A changing with c."""
    rng = random.Random(7)
    w2, h = 9e3, 1e-3
    estimate = estimate_at(w2, 0.0, 0.0)
    total = np.zeros(2)
    for _ in range(40):
        c, local = rng.uniform(0.0, 200.0), np.array([rng.uniform(-1e-7, 1e-7), rng.uniform(-1e-5, 1e-5)])
        estimate.advance(h, c, local[0], local[1], stuck=False)
        total = expm(matrix(w2, c) * h) @ total + local
    assert estimate.ex == pytest.approx(total[0], rel=1e-9)
    assert estimate.ev == pytest.approx(total[1], rel=1e-9)


def test_a_stuck_step_zeroes_the_error_in_v_but_carries_x():
    w2, c, h = 1e4, 10.0, 1e-3
    e0 = np.array([3e-6, -2e-4])
    estimate = estimate_at(w2, *e0)
    assert estimate.advance(h, c, 1e-8, 5e-5, stuck=True) == 0.0 == estimate.ev
    assert estimate.ex == pytest.approx((expm(matrix(w2, c) * h) @ e0)[0] + 1e-8, rel=1e-12)


def test_the_error_marked_is_carried_by_the_same_motion_without_the_local_errors_that_follow():
    """After mark(), old is the marked error carried as the whole one is, no local error added
    (coupling/lead_in.py compares the two): it equals the flow of the marked error alone, the
    whole is old plus the locals' own carry (linear), and a stuck end zeroes its v too. Its
    spread is the spread at the mark, carried by the same flow with no share added since, and
    old_v() reports the two as advance() reports the whole (a root-sum-square, the carried
    error's sign): d compares like with like."""
    w2, c, h = 1e4, 10.0, 1e-3
    estimate = estimate_at(w2, 3e-6, -2e-4)
    estimate.advance(h, c, 1e-7, 2e-6, stuck=False)
    assert estimate.old is None
    estimate.mark()
    marked, marked_spread = (estimate.ex, estimate.ev), estimate.spread[:2]
    assert any(marked_spread)  # (the first step's share)
    locals_only = estimate_at(w2, 0.0, 0.0)
    for local in ((1e-7, -3e-6), (-2e-7, 5e-6), (4e-8, 1e-6)):
        estimate.advance(h, c, *local, stuck=False)
        locals_only.advance(h, c, *local, stuck=False)
    flow = expm(matrix(w2, c) * 3 * h) @ np.array(marked)
    assert estimate.old[:2] == pytest.approx(tuple(flow), rel=1e-9)
    assert estimate.ev == pytest.approx(estimate.old[1] + locals_only.ev, rel=1e-9)
    assert estimate.old_spread[:2] == pytest.approx(tuple(expm(matrix(w2, c) * 3 * h) @ np.array(marked_spread)), rel=1e-9)
    assert abs(estimate.spread[1]) > abs(estimate.old_spread[1])  # (the shares added since)
    assert estimate.old_v() == math.copysign(math.hypot(estimate.old[1], estimate.old_spread[1]), estimate.old[1])
    estimate.advance(h, c, 0.0, 0.0, stuck=True)
    assert estimate.old[1] == 0.0 and estimate.old[0] != 0.0
    restored = GlobalErrorEstimate()
    restored.restore(estimate.export())
    assert restored.old == estimate.old and restored.old_spread == estimate.old_spread


def test_a_carry_that_reaches_the_motions_size_says_it_saturated():
    estimate = GlobalErrorEstimate()
    estimate.w2 = 100.0
    estimate.advance(1e-3, 0.0, 1e-9, 1e-6, stuck=False, x_scale=1e-2, v_scale=0.1)
    assert not estimate.saturated  # within the motion's size: a linear carry
    estimate.advance(1e-3, -5e3, 0.0, 0.5, stuck=False, x_scale=1e-2, v_scale=0.1)
    assert estimate.saturated and estimate.ev == 0.1  # held at the scale, and it says so
    estimate.advance(1e-3, 0.0, 0.0, 0.0, stuck=True, x_scale=1e-2, v_scale=0.1)
    assert estimate.saturated  # once saturated, the run's estimate cannot vouch for it


def carry_problem_of(law, inputs_vary=False):
    from tribofmu.coupling.estimate import carry_problem
    return carry_problem(law, inputs_vary)


@pytest.mark.parametrize("law, vouches", [
    (FluidLaw(gamma=0.0), True), (FluidLaw(gamma=1.5), True), (FluidLaw(gamma=-0.2), True),
    (FluidLaw(gamma=-0.95), True),
])
def test_the_carry_vouches_only_for_a_force_of_dv_alone_with_a_bounded_slope(law, vouches):
    """(A shear-thinning fluid's slope is unbounded at rest but integrable across dv = 0: its
    carry follows it, tests/master/test_shear_thinning.py; a Stribeck curve's unbounded slope at
    breakaway is not, its drop with a bounded slope is: tests/master/test_stribeck_estimate.py.)"""
    from tribofmu.physics import laws

    assert (carry_problem_of(law) is None) == vouches
    assert carry_problem_of(law, inputs_vary=True) is not None  # a Load or Thermal FMU moves n, T
    assert carry_problem_of(laws.DryLaw()) is None
    # the lubricant's state: its slip steps' path errors carried by the law's slopes (issue 36)
    assert carry_problem_of(laws.BoundaryLaw()) is None
    assert carry_problem_of(laws.BoundaryLaw(), inputs_vary=True) is not None  # a Thermal FMU's T
    assert carry_problem_of(laws.MixedLaw(stribeck_exponent=1.0)) is None  # a Stribeck drop: followed
    assert carry_problem_of(laws.MixedLaw(stribeck_exponent=3.0, mu_static=0.9)) is None
    assert "unbounded" in carry_problem_of(laws.MixedLaw(stribeck_exponent=0.5))
    assert carry_problem_of(laws.MixedLaw(stribeck_exponent=0.5, mu_static=0.5, mu_friction=0.5)) is None


def test_the_block_is_learned_from_its_answers():
    """a = F/M - w2 x: from a point and the block's velocity per unit impulse 1/M."""
    M, K = 0.6, 7000.0
    estimate = GlobalErrorEstimate()
    x, F = 1.3e-3, 4.0
    a = (F - 2 * K * x) / M
    estimate.observe(x, a, F, 1.0 / M, x_floor=1e-6)
    assert estimate.w2 == pytest.approx(2 * K / M, rel=1e-12)
    # x at round-off, no response measured yet, or a nonsense w2 <= 0: nothing learned
    for args in ((1e-9, a, F, 1.0 / M), (x, a, F, 0.0), (x, F / M + 1.0, F, 1.0 / M)):
        estimate.observe(*args, x_floor=1e-6)
        assert estimate.w2 == pytest.approx(2 * K / M, rel=1e-12)


def test_the_adaptive_learns_the_block_of_the_run():
    """On fig. 2's rig (fakes: M = 0.6 kg, K = 7000 N/m) the estimate's w2 converges on
    2K/M, which nobody told the coupling."""
    from tribofmu.master import run

    system, scales = fig2_system(), drive_scales()
    algorithm = AdaptiveCoupling(tol=1e-4)
    run(system, algorithm, 0.5 * scales.period, scales)
    assert algorithm.estimate.w2 == pytest.approx(2 * 7000.0 / 0.6, rel=2e-3)


# -- the window audit ---------------------------------------------------------------------------

@dataclass
class P:
    t_ns: int
    global_error: float
    v: float
    a: float = 0.0  # m/s^2, dv/dt: the interpolants' slopes
    aX: float = 0.0
    mode: Contact = Contact.FORWARD
    inside_error: float = 0.0  # m/s, at the step's middle beyond the line of the carried errors
    a_lag: float = 0.0  # m/s^2, how far the motion's slope lies beyond a


def random_points(seed=3, n=60, span=1.0):
    """Random errors at random times, on a motion the cubic interpolants follow exactly (v a
    cubic in t: no interpolation term, the window's RMS is the carried error's alone)."""
    rng = random.Random(seed)
    times = sorted(rng.sample(range(1, int(span * 1e9)), n - 1))
    c = [rng.uniform(-0.2, 0.2) for _ in range(4)]

    def point(t_ns, error):
        t = t_ns * 1e-9
        return P(t_ns, error, c[0] + c[1] * t + c[2] * t * t + c[3] * t ** 3, c[1] + 2 * c[2] * t + 3 * c[3] * t * t)

    return [point(0, 0.0)] + [point(t, rng.uniform(-1e-4, 1e-4)) for t in times]


# the whole run, a window cutting through steps, one reaching beyond the last point (the RMS
# is over the part covered)
@pytest.mark.parametrize("window", [(0.0, 1.0), (0.2137, 0.7771), (0.9, 1.5)])
def test_window_rms_is_the_integral_of_the_linearly_interpolated_error(window):
    points = random_points()
    audit = WindowError(window)
    for i in range(0, len(points), 7):  # fed in chunks, as a run records
        audit.add(points[i:i + 7])
    t = np.array([p.t_ns for p in points]) * 1e-9
    e = np.array([p.global_error for p in points])
    lo, hi = window[0], min(window[1], t[-1])
    breaks = [s for s in t if lo < s < hi]
    square = quad(lambda s: np.interp(s, t, e) ** 2, lo, hi, points=breaks or None, limit=200,
                  epsabs=0.0, epsrel=1e-12)[0]
    v_max = max(abs(p.v) for p in points if window[0] <= p.t_ns * 1e-9 <= window[1])
    assert audit.nrms() == pytest.approx(math.sqrt(square / (hi - lo)) / v_max, rel=1e-9)


def test_window_audit_without_coverage_or_motion_is_nan():
    points = random_points()
    beyond = WindowError((2.0, 3.0))
    beyond.add(points)
    assert math.isnan(beyond.nrms())
    still = WindowError((0.0, 1.0))
    still.add([P(p.t_ns, p.global_error, 0.0) for p in points])
    assert math.isnan(still.nrms())


# -- the carried estimate against the true error of a run -----------------------------------------

@pytest.mark.parametrize("m, gamma, omega, M, K", [(25.0, 0.0, 50.0, 0.6, 7000.0), (200.0, 0.0, 30.0, 0.6, 7000.0),
                                                   (25.0, -0.5, 40.0, 0.3, 3000.0), (25.0, 1.0, 40.0, 0.3, 3000.0)])
def test_carried_estimate_tracks_the_true_error_of_a_fluid_run(m, gamma, omega, M, K):
    """Block on springs in a power-law fluid under the sinusoidal drive: the run's estimated
    global error in v has the RMS of its true error (against an rtol-1e-12 solution of the
    same ODE, M x'' + 2K x = m sgn(V - v)|V - v|^(gamma + 1)) within a factor 1.5."""
    from scipy.integrate import solve_ivp

    from tribofmu.master import run

    A = 2e-3
    law = FluidLaw(m=m, gamma=gamma)
    scales = drive_scales(omega, A)
    system = fig2_system(law, omega, A, M, K)
    out = run(system, AdaptiveCoupling(tol=1e-3), 3 * scales.period, scales)
    t = np.array([p.t_ns for p in out.points]) * 1e-9

    def rhs(s, y):
        return [y[1], (law.force(-A * omega * math.sin(omega * s) - y[1], -20.0) - 2 * K * y[0]) / M]

    exact = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-15, t_eval=t).y[1]
    true = exact - np.array([p.v for p in out.points])
    estimated = np.array([p.global_error for p in out.points])
    ratio = math.sqrt(np.mean(estimated ** 2) / np.mean(true ** 2))
    assert 1 / 1.5 < ratio < 1.5


def dry_run_errors(omega, tol):
    """(true, estimated) nRMS(v) of an adaptive run on fig. 2's rig at drive frequency omega
    over its second and third periods: the true one on a uniform grid of the delivered
    (interpolated) signal against the exact piecewise motion, the estimate from WindowError."""
    from tribofmu.coupling.interpolation import sample
    from tribofmu.master import run

    from fakes import exact_dry

    scales, system = drive_scales(omega), fig2_system(omega=omega)
    out = run(system, AdaptiveCoupling(tol=tol), 3 * scales.period, scales)
    window = (scales.period, 3 * scales.period)
    grid = np.linspace(*window, 2001)
    _, v, _ = exact_dry(grid, omega=omega)
    true = math.sqrt(np.mean((sample(out.points, grid)["v"] - v) ** 2)) / np.abs(v).max()
    audit = WindowError(window)
    audit.add(out.points)
    return true, audit.nrms()


# (estimate/true with the embedded coupling, issue 31: 0.53, 0.71, 0.57; at omega = 13 and
# tol 1e-3 the true error was 3.1e-3 before the stick ramp's breakaway miss was held to tol)
@pytest.mark.parametrize("omega, tol", [(30.0, 1e-3), (13.0, 1e-3), (30.0, 1e-4)])
def test_carried_estimate_is_within_3x_of_the_true_error_of_a_dry_run(omega, tol):
    true, estimated = dry_run_errors(omega, tol)
    assert true / 3 < estimated < 3 * true


# (1.04x and 0.56x since the embedded coupling, issue 31; before, a strict xfail: 5x and 3.7x)
@pytest.mark.parametrize("tol", [1e-3, 1e-4])
def test_carried_estimate_is_within_3x_of_the_true_error_of_a_mostly_stuck_dry_run(tol):
    true, estimated = dry_run_errors(80.0, tol)
    assert true / 3 < estimated < 3 * true


def test_the_error_inside_a_step_adds_its_bubble():
    """A step whose carried errors are 0 at both ends but e at its middle (a ringing ramp's: the
    ends agree, the middle does not) adds the bubble 4 e u (1 - u): RMS e sqrt(16/30)."""
    e, vmax = 2e-6, 0.5
    points = [P(0, 0.0, vmax), P(1_000_000, 0.0, vmax, inside_error=e)]
    audit = WindowError((0.0, 1e-3))
    audit.add(points)
    assert audit.nrms() == pytest.approx(e * math.sqrt(16.0 / 30.0) / vmax, rel=1e-12)
    half = WindowError((0.0, 0.5e-3))  # the first half: the bubble's integral to u = 1/2 (1/60)
    half.add(points)
    assert half.nrms() == pytest.approx(e * 4.0 * math.sqrt(1.0 / 60.0 / 0.5) / vmax, rel=1e-12)


@pytest.mark.xfail(strict=True, reason="WindowError takes max |v| only from points inside the "
                   "window: a window inside one step (no point in it) gives nan although the run "
                   "covers it and v is not 0 there")
def test_window_inside_one_step_has_an_estimate():
    points = [P(0, 1e-4, 0.1), P(1_000_000_000, 3e-4, 0.2)]
    audit = WindowError((0.4, 0.6))
    audit.add(points)
    assert math.isfinite(audit.nrms())


def test_local_errors_that_cancel_leave_the_spread_of_what_each_left_unknown():
    """Two steps whose local errors in v cancel: the carried error is 0, but each step's
    estimate was known only to a tenth of itself (1 - the step-size rule's safety), of
    unknown sign: the run reports their root-sum-square, not 0 (a lubricant's runaway took
    back the error it met, and the estimate read 0.17x its true one). Where they add up, the
    spread is a small part of what is reported; a snapshot carries it."""
    share = 1.0 - STEP_CONTROL.safety
    cancelling = GlobalErrorEstimate()
    first = cancelling.advance(1e-6, 0.0, 0.0, 1e-3, stuck=False)
    second = cancelling.advance(1e-6, 0.0, 0.0, -1e-3, stuck=False)
    assert cancelling.ev == pytest.approx(0.0, abs=1e-15)
    assert first == pytest.approx(math.hypot(1e-3, share * 1e-3), rel=1e-12)
    assert second == pytest.approx(math.sqrt(2.0) * share * 1e-3, rel=1e-9) and second > 0.1 * first
    adding = GlobalErrorEstimate()
    adding.advance(1e-6, 0.0, 0.0, 1e-3, stuck=False)
    assert adding.advance(1e-6, 0.0, 0.0, 1e-3, stuck=False) == pytest.approx(2e-3, rel=share ** 2)
    copy = GlobalErrorEstimate()
    copy.restore(cancelling.export())
    assert copy.spread == cancelling.spread and copy.advance(1e-6, 0.0, 0.0, 0.0, stuck=False) == pytest.approx(second)
    stuck = copy.advance(1e-6, 0.0, 0.0, 0.0, stuck=True)  # (v rides on the drive: no error, known or not)
    assert stuck == 0.0 and copy.spread[1] == 0.0
