"""The per-mode solvers of one implicit step, pure: each is given the evaluations it may make
(the loop function, the block's answer to a force) and returns its answer; the step
(coupling/contact.py) decides which runs and keeps what they measured.

- :func:`slip_root`: slipping, the root of the decreasing loop function H(dv) = (the block's
  relative velocity after the step under the friction at dv) - dv, on a bracket;
- :func:`secant_rounds`: slipping, the root of G(dv), the loop function with the friction
  stepped to dv (its state integrated along the step), one friction step an iterate;
- :func:`stick_force`: stuck at the step's end, the held force that keeps dv = 0;
- :func:`stick_ramp`: stuck all through, the force ramp that keeps both dv = 0 and x on the drive;
- :func:`stick_onset`: slipping into stick, where inside the step dv reaches 0.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

from ..physics.roots import illinois
from .blocks import StickJacobian
from .interpolation import hermite


class Probe(NamedTuple):
    """The held step under the friction at +-delta: that force [N], the relative velocity
    dv [m/s] and the position x [m] the block answered with at the step's end, and the
    relative acceleration d(dv)/dt [m/s^2] there."""

    F: float
    dv: float
    x: float
    dv_slope: float


def stick_onset(dv0: float, slope0: float, dv_end: float, slope_end: float, h: float, xtol: float) -> float:
    """The fraction of a step of h [s] at which dv, slipping from dv0 to dv_end [m/s] (past 0)
    with slopes d(dv)/dt slope0, slope_end at its ends [m/s^2], reaches 0 (1: it does not):
    the root of its cubic Hermite interpolant (a straight line lands short of a curving dv,
    and the retried step then lands short again), to xtol of the step."""
    if dv0 == dv_end or dv0 * dv_end > 0.0:
        return 1.0

    def dv(s: float) -> float:
        return hermite(dv0, dv_end, slope0, slope_end, h, s)

    return min(1.0, max(0.0, illinois(dv, 0.0, 1.0, dv0, dv_end, xtol=xtol, rtol=0.0)))


def slip_root(loop: Callable[[float], float], lo: float, h_lo: float, direction: float, *, delta: float,
              root_tol: float, expected_gain: float, max_iterations: int, aim_beyond: float,
              hi: float | None = None, h_hi: float | None = None) -> tuple[float, float]:
    """Root of the decreasing loop function beyond lo (H(lo) = h_lo; slip in ``direction``), on
    the bracket [lo, hi] if given, to root_tol [m/s] in H and delta [m/s] in dv.

    Returns (dv, loop gain): the gain is -(slope of the loop function) - 1, i.e. how strongly
    the block's answer reacts to the assumed dv, measured on the bracket.
    """
    if hi is None:
        lo, h_lo, hi, h_hi = bracket(loop, lo, h_lo, direction, delta, expected_gain, max_iterations, aim_beyond)
    # (a bracket narrower than the "zero" velocity, as when the predicted dv already was
    # the root, measures round-off: keep the gain the step expected)
    if abs(hi - lo) > delta:
        gain = max(0.0, -(h_hi - h_lo) / (hi - lo) - 1.0)
    else:
        gain = expected_gain
    if h_hi == 0:
        return hi, gain
    if abs(h_lo) <= root_tol:
        return lo, gain
    if abs(h_hi) <= root_tol:
        return hi, gain
    return illinois(loop, lo, hi, h_lo, h_hi, xtol=delta, rtol=0.0, ftol=root_tol,
                    max_iterations=max_iterations), gain


def bracket(loop: Callable[[float], float], lo: float, h_lo: float, direction: float, delta: float,
            expected_gain: float, max_iterations: int, aim_beyond: float) -> tuple[float, float, float, float]:
    """A bracket (lo, H(lo), hi, H(hi)) of the decreasing loop function's root beyond lo, H(lo) =
    h_lo, in ``direction``: hi aimed with the expected gain (placed aim_beyond past the aim),
    then a fixed-point pass, then widening."""
    # Aim at the root with the last step's loop gain; where that falls short, the
    # fixed-point pass from the nearer point lands beyond the root: the friction
    # there is at least as large, so the block answers with a smaller dv.
    gain = expected_gain
    for fraction in (((1.0 + aim_beyond) / (1.0 + gain), 1.0) if gain > 0 else (1.0,)):
        hi = lo + fraction * h_lo
        h_hi = loop(hi)
        if direction * h_hi < 0 or h_hi == 0:
            break
        lo, h_lo = hi, h_hi
    else:  # not beyond even so: the law is not monotone here; widen
        for _ in range(max_iterations):
            hi = lo + 2.0 * (h_lo if h_lo != 0 else direction * delta)
            h_hi = loop(hi)
            if direction * h_hi < 0 or h_hi == 0:
                break
            lo, h_lo = hi, h_hi
    return lo, h_lo, hi, h_hi


def secant_rounds(g_at: Callable[[float], float], dv: float, gain: float, direction: float, keep_side: bool,
                  *, floor: float, root_tol: float, rounds: int) -> tuple[float, float, bool]:
    """A secant on G(dv) = g_at(dv) (the friction stepped to dv), started with the loop's own
    slope -(1 + gain), one evaluation an iterate, at most ``rounds``. An iterate that would
    leave the slip side (``direction`` * dv <= floor) is pulled back halfway to it (keep_side)
    or ends the rounds. Returns (dv, the gain the secant measured, whether G(dv) is within
    root_tol there); the last evaluation was at the returned dv."""
    dv_a = g_a = None
    for _ in range(rounds):
        g = g_at(dv)
        if dv_a is not None and g != g_a:
            measured = -(g - g_a) / (dv - dv_a) - 1.0
            if measured < 0.0 and not keep_side and direction * g < 0.0:
                # G rises on the way toward delta: a force falling with dv (velocity
                # weakening, a Stribeck curve) can give G more roots than one there, or
                # none and a stick; the trials' bracket from delta decides
                return dv, gain, False
            gain = max(0.0, measured)
        if abs(g) <= root_tol:
            return dv, gain, True
        new = dv + g / (1.0 + gain) if dv_a is None or g == g_a else dv - g * (dv - dv_a) / (g - g_a)
        if not min(dv, dv + g) <= new <= max(dv, dv + g):
            # The root lies between dv and the block's answer dv + g (a force that rises
            # with dv brakes the block more beyond dv): a secant through a curving G that
            # leaves it (a gamma = 1 lubricant: 3e159 m/s) steps with the gain instead.
            new = dv + g / (1.0 + gain)
        dv_a, g_a = dv, g
        if not direction * new > floor:
            if not keep_side:
                return dv, gain, False
            new = 0.5 * (dv + direction * floor)
        dv = new
    return dv, gain, False


def stick_force(block_under: Callable[[float], float], pos: Probe, neg: Probe, delta: float,
                max_iterations: int) -> float:
    """The force [N] that keeps the blocks together over the step (dv = 0 at its end, to
    delta), block_under(F) the block's relative velocity under the held force F.

    It lies between the friction at -delta and at +delta (the probes ``neg``, ``pos``); the
    secant on the block's answer starts from those two evaluations. The block is left
    stepped (or modelled) under the returned force.
    """
    F_pos, F_neg = pos.F, neg.F
    a, da, b, db = F_neg, neg.dv, F_pos, pos.dv
    if da == db:
        block_under(F_pos)
        return F_pos
    F = b
    for _ in range(max_iterations):
        F = b - db * (b - a) / (db - da)
        d = block_under(F)
        if abs(d) <= delta or d == db:
            break
        a, da, b, db = b, db, F, d
    low, high = min(F_neg, F_pos), max(F_neg, F_pos)
    if not low <= F <= high:
        # Round-off past the bound (a step of a few ns, where the probes' dv differ by
        # less than delta): the stick force is the friction's to bound, dv stays within delta.
        F = min(max(F, low), high)
        block_under(F)
    return F


class StickRamp(NamedTuple):
    """The stick ramp's outcome: the fraction of the step at which the ramp leaves the
    friction's bounds (1: stuck throughout), and the Jacobian it measured (None: it had one)."""

    event: float
    jacobian: StickJacobian | None


def stick_ramp(block_at: Callable[[float, float], tuple[float, float]], pos: Probe, neg: Probe, h: float,
               h_ns: int, x_target: float, jacobian: StickJacobian | None, start_at_pos: bool, *,
               delta: float, position_tol: float, iterations: int) -> StickRamp:
    """Stuck over the whole step of h [s]: the force ramp F0 + rate s that keeps the blocks
    together, i.e. ends with dv = 0 (to delta [m/s]) and moves the block exactly as far as the
    drive (x at x_target [m], to position_tol). block_at(F0, rate) steps the block and returns
    its (dv, x) at the step's end.

    A held force can match only one of the two, and then the position drifts by O(h^3) a step
    through the spring term; the ramp matches both, and needs no force from the previous step
    (so no ringing). The block's answer is affine in (F0, rate) for a linear block; it is not
    assumed: the Newton steps use secant slopes, or the last ramp's ``jacobian`` (of a step of
    this length) from the probe the block really answered (``start_at_pos``: the +delta one).
    """
    F_pos, d_pos, x_pos, F_neg, d_neg, x_neg = pos.F, pos.dv, pos.x, neg.F, neg.dv, neg.x
    if F_pos == F_neg:
        return StickRamp(0.0, None)
    dF = F_pos - F_neg
    rate_probe = dF / h
    if jacobian is not None:
        d_F, x_F, d_r, x_r = jacobian.d_F, jacobian.x_F, jacobian.d_r, jacobian.x_r
        real = pos if start_at_pos else neg
        F0, rate, d0, x0 = real.F, 0.0, real.dv, real.x
    else:
        # slopes in F0 from the two held probes, in rate from one more evaluation
        d_F, x_F = (d_pos - d_neg) / dF, (x_pos - x_neg) / dF
        F0, rate = F_neg, 0.0
        d0, x0 = d_neg, x_neg
        d_r, x_r = None, None
    for _ in range(iterations):
        if d_r is None:
            d1, x1 = block_at(F0, rate + rate_probe)
            d_r, x_r = (d1 - d0) / rate_probe, (x1 - x0) / rate_probe
        det = d_F * x_r - d_r * x_F
        if det == 0:
            break
        # Newton on (dv_end, x_end - x_target) = 0 with the secant Jacobian
        rx = x0 - x_target
        F0, rate = F0 - (d0 * x_r - d_r * rx) / det, rate - (d_F * rx - x_F * d0) / det
        d0, x0 = block_at(F0, rate)
        if abs(d0) <= delta and abs(x0 - x_target) <= position_tol:
            break
    measured = None
    if jacobian is None and d_r is not None:
        measured = StickJacobian(h_ns, d_F, x_F, (pos.dv_slope - neg.dv_slope) / dF, d_r, x_r)
    return StickRamp(ramp_event(F0, F0 + rate * h, min(F_neg, F_pos), max(F_neg, F_pos)), measured)


def ramp_event(F0: float, F1: float, low: float, high: float) -> float:
    """The fraction of a step at which a force ramp from F0 to F1 [N] leaves [low, high] (0:
    it starts outside, 1: it stays within)."""
    if not low <= F0 <= high:
        return 0.0
    if F1 > high:
        return (high - F0) / (F1 - F0)
    if F1 < low:
        return (low - F0) / (F1 - F0)
    return 1.0
