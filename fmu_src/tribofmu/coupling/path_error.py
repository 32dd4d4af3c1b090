"""A slip step's local error for a friction with an internal state, from the step's own path.

Over a slip step the coupling and the Friction FMU see two different paths. The block felt the
force ramp F_start + F_rate s (or the held force) and moved along it: its relative velocity
dv = V - v followed a smooth curve through the step's two points, whose slopes are the
points' own, dv' = aX - a (the cubic Hermite curve: the block is linear under a ramp, so the
curve misses its path by O(h^4)). The friction was stepped along the straight line between
the two points' dv and advanced its state f along that line; its force along the way has the
two points' forces at its ends and the mean it reports (``F_mean``): to second order the
parabola through them. The reduced equations the step approximates are

    x' = v,   M v' = F(dv, f) - 2K x + (drive),   f' = g(dv, f),

so the computed path (the block's curve, the friction's f along the line) misses them by a
defect in v, the friction's force along its path less the force the block felt plus what the
curve's departure from the line, beta(s) = dv_curve - dv_line, moves the force by (F_dv beta),
and a defect in f, what beta moves the rate by (g_dv beta). The local error, exact less
computed, is the defect carried to the step's end by the variational equations
(coupling/estimate.py, the law's slopes at the step's middle):

    e' = A e + d(s),   e(0) = 0,   A = [[0, 1, 0], [-w2, -c, p], [0, q, r]],
    d(s) = (0, (F_path(s) - F_felt(s)) / M + c beta(s), -q beta(s)),

with all three components (x, v, f) charged to the carry. d is a cubic in s, so e(h) is exact
through one matrix exponential of the augmented system (the polynomial's terms as extra states:
Al-Mohy and Higham's device for phi-functions).

Why not the curvature the force's divided differences give (coupling/embedded.py): on boundary
friction the steps that carry the global error are solid steps just below the melt, where the
viscous slope is steep (c h = 4-5) but the lubricant's loop (a v error moves dv, f follows at
-g_f h ~ 60, F_f gives the force back) leaves a v error undamped over the step: the divided
difference read those steps' local v error with the wrong sign (correlation with the true one
-0.11 to -0.44), and the carry under-read the run's true error by 0.12-0.6 (gamma = 0.3-2 and
Fig. 6). Propagated through the full Jacobian, the force's miss along the step's path matched
the true local v error step by step (correlation 0.997-1.000) and carried to 0.86-1.07 of the
true global error (offline, 26 recordings of Fig. 6's rig at gamma = -2/3 to 2, omega = 20 and
6, per-step tol 1e-2 to 5e-5; branch h6-twin, research/twin/README.md, 2026-11-27).
"""
from __future__ import annotations

import cmath
import math

from .variational import resolvent_solve


def _cubic_roots(b: float, c: float, d: float) -> tuple[complex, complex, complex]:
    """The roots of z^3 + b z^2 + c z + d (Cardano; this module ships in the TriboPair FMU, which
    runs without numpy)."""
    shift = -b / 3.0  # z = y + shift: y^3 + p y + q
    p = c - b * b / 3.0
    q = 2.0 * b ** 3 / 27.0 - b * c / 3.0 + d
    u = (-q / 2.0 + cmath.sqrt(q * q / 4.0 + p ** 3 / 27.0)) ** (1.0 / 3.0)
    turn = complex(-0.5, math.sqrt(3.0) / 2.0)  # a cube root of unity
    return tuple(u * w - p / (3.0 * u * w) + shift for w in (1.0, turn, turn.conjugate()))


# e^z's (2,3) Pade approximant N(z) / D(z), N = 1 + 2z/5 + z^2/20, D = 1 - 3z/5 + 3z^2/20 - z^3/60,
# in partial fractions sum_i a_i / (z - z_i), a_i = N(z_i) / D'(z_i): fifth order, so that it is
# exact for the cubic forcing's terms where the dynamics are slow (the augmented system's
# nilpotent part needs e^z to z^4), and L-stable, so that a stiff mode (the lubricant's, |r| h up
# to 1e4) answers a forcing quasi-statically, -d / r, as it does (the carry's (1,2) approximant,
# coupling/estimate.py, is third order: it missed the cubic term by a third). D's roots are
# those of z^3 - 9 z^2 + 36 z - 60 (-60 D): 3.64 and 2.68 +- 3.05i.
PADE_POLES = _cubic_roots(-9.0, 36.0, -60.0)
PADE_RESIDUES = tuple((1.0 + 0.4 * z + z * z / 20.0) / (-0.6 + 0.3 * z - z * z / 20.0) for z in PADE_POLES)


def _inverse_powers(pole: complex) -> tuple[complex, ...]:
    """1 / pole^(k+1), k = 0..3 (the forcing's terms u^k / k!: a cubic in the step's fraction
    u): 1 / pole divided by pole again for each next k."""
    power, powers = 1.0 / pole, []
    for _ in range(4):
        powers.append(power)
        power /= pole
    return tuple(powers)


# each pole with its residue and its inverse powers, made once (the same numbers for every step)
_POLE_TERMS = tuple((pole, residue, _inverse_powers(pole)) for pole, residue in zip(PADE_POLES, PADE_RESIDUES))


def hermite_bubble(dv0: float, dv1: float, slope0: float, slope1: float, h: float) -> tuple[float, float, float]:
    """The coefficients (of u, u^2, u^3; u = s / h) of beta(u) = the cubic Hermite curve through
    dv0, dv1 [m/s] with slopes slope0, slope1 [m/s^2] at the ends of a step of h [s], less the
    straight line between dv0 and dv1: 0 at both ends."""
    rise = dv1 - dv0
    return (-rise + h * slope0, 3.0 * rise - h * (2.0 * slope0 + slope1), -2.0 * rise + h * (slope0 + slope1))


def forced_response(h: float, w2: float, c: float, p: float, q: float, r: float,
                    force_v: tuple, force_f: tuple) -> tuple[float, float, float]:
    """e(h) [x m, v m/s, f 1] of e' = A e + d(s), e(0) = 0, A = [[0, 1, 0], [-w2, -c, p], [0, q, r]],
    d = (0, sum_k force_v[k] u^k, sum_k force_f[k] u^k) with u = s / h (k = 0..3; [m/s^2], [1/s]).
    Through the augmented system (the terms u^k / k! as four more states, z' = Z z over u in
    [0, 1], Z = [[h A, h k! d_k], [0, shift]]): e(h) = R(Z) e_0, e_0 the term u^0's unit vector,
    R :data:`PADE_POLES`' approximant, sum_i a_i (Z - z_i)^-1 e_0. Per pole the terms' part of
    (Z - z_i)^-1 e_0 is -1 / z_i^(k+1), which leaves (h A - z_i) u = sum_k h k! d_k / z_i^(k+1):
    one tridiagonal solve (:func:`.variational.resolvent_solve`, as the carry's)."""
    x = v = f = 0.0
    (a0, a1, a2, a3), (b0, b1, b2, b3) = force_v, force_f
    for pole, residue, (p1, p2, p3, p4) in _POLE_TERMS:
        # sum_k k! d_k / pole^(k+1), written out with the powers made once (the loop over k
        # dividing by the pole took a fifth of this function's time)
        bv = a0 * p1 + a1 * p2 + 2.0 * a2 * p3 + 6.0 * a3 * p4
        bf = b0 * p1 + b1 * p2 + 2.0 * b2 * p3 + 6.0 * b3 * p4
        u = resolvent_solve(h, w2, c, p, q, r, pole, 0.0, bv * h, bf * h)
        if u is None:
            raise ZeroDivisionError("a pole of the approximant is an eigenvalue of h A")
        x += (residue * u[0]).real
        v += (residue * u[1]).real
        f += (residue * u[2]).real
    return x, v, f


def path_forcing(start, end, h: float, slopes: tuple[float, float, float, float],
                 velocity_per_impulse: float) -> tuple[tuple, tuple] | None:
    """The defect d(u) of the slip step's path (see the module's docstring) as the cubics'
    coefficients (force_v [m/s^2], force_f [1/s]) of :func:`forced_response`; None where the
    friction reports no mean force over the step."""
    mean = end.F_mean
    if mean is None or h <= 0.0 or velocity_per_impulse <= 0.0:
        return None
    vpi = velocity_per_impulse
    c, _, q, _ = slopes
    # the force the block felt, F_start + F_rate s, and the friction's along its path: the
    # parabola through the two points' forces with the friction's own mean
    felt0, felt_rise = end.F_start, end.F_rate * h
    bulge = 6.0 * (mean - 0.5 * (start.F + end.F))
    miss = (start.F - felt0, end.F - start.F + bulge - felt_rise, -bulge, 0.0)
    # the block's slope of dv at the step's start under the force it felt (the point's a was
    # under the force before: a held step jumps to its end force)
    slope0 = start.aX - start.a - (felt0 - start.F) * vpi
    beta = (0.0, *hermite_bubble(start.dv, end.dv, slope0, end.aX - end.a, h))
    return tuple(m * vpi + c * b for m, b in zip(miss, beta)), tuple(-q * b for b in beta)


def _halved(cubic: tuple) -> tuple[float, float, float, float]:
    """The coefficients d_k of a cubic in u (k = 0..3) as one in u' = 2 u: d_k / 2^k."""
    d0, d1, d2, d3 = cubic
    return d0, d1 / 2.0, d2 / 4.0, d3 / 8.0


def path_local_error(start, end, h: float, w2: float, slopes: tuple[float, float, float, float],
                     velocity_per_impulse: float) -> tuple[float, float, float, float] | None:
    """The local error (x [m], v [m/s], f [1]; exact less computed) of the slip step of h [s]
    from point start to point end (see the module's docstring), and v's [m/s] at the step's
    middle beyond the line between the step's ends' (the results between points are
    interpolated from the ends: where the force the block felt crosses the true one inside the
    step, as a stiff loop's ringing ramp does, the ends agree and the middle does not). slopes:
    (c [1/s], p [m/s^2], q [1/m], r [1/s]) of
    :meth:`~.estimate.GlobalErrorEstimate.state_slopes`; w2 [1/s^2] the springs over the mass;
    1/M = velocity_per_impulse. None where the friction reports no mean force over the step, or
    the result is not finite."""
    forcing = path_forcing(start, end, h, slopes, velocity_per_impulse)
    if forcing is None:
        return None
    force_v, force_f = forcing
    # the middle: the same cubic over the first half, u = u' / 2
    half_v, half_f = _halved(force_v), _halved(force_f)
    try:
        x, v, f = forced_response(h, w2, *slopes, force_v, force_f)
        middle = forced_response(0.5 * h, w2, *slopes, half_v, half_f)[1]
    except ZeroDivisionError:  # (a pole of the approximant is an eigenvalue of h A itself)
        return None
    inside = middle - 0.5 * v
    return (x, v, f, inside) if all(map(math.isfinite, (x, v, f, inside))) else None


def passed_phase_change(law, start, end, F_scale: float, tol: float) -> bool:
    """Whether the lubricant changed phase inside the slip step from point start to point end
    and back, with both ends molten: the friction's mean force over the step (``F_mean``, along
    its path) then holds the solid phase's elastic grip, which no end shows, by more than tol x
    F_scale [N] (the ends' larger force) past the molten force's mean along the same path. The grip is an event the step
    passed over: the block, held by it, would have kept dv near 0 and the lubricant solid (a
    reversal at gamma = -0.3, per-step tol 1e-2: a 1.4 ms step whose mean force was 11x its end
    forces; its run lost the drive's phase, 46 % off where it estimated 2e-4). Its linearisation
    about the computed path cannot see that: such a step is not to be taken (coupling/embedded.py),
    and a run that had to take one cannot vouch for itself. (Both ends solid, a melt inside the
    step would move the elastic term by f, which the ends show: not told apart here.)"""
    if law is None or end.F_mean is None or not (start.mode.slipping and end.mode.slipping):
        return False
    if law.melt_margin(start.f) > 0.0 or law.melt_margin(end.f) > 0.0:
        return False
    molten = law.path_mean_force(start.dv, end.dv, end.n, max(start.f, end.f))
    return abs(end.F_mean - molten) > tol * F_scale
