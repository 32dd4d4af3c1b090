"""The variational equations of the block and a friction with state, carried over one step.

An error (ex [m], ev [m/s], ef [1]) in the block's state and the lubricant's moves, to first
order, by e' = A e with A = [[0, 1, 0], [-w2, -c, p], [0, q, r]]: w2 = 2K/M [1/s^2], c = F_dv/M
[1/s], p = F_f/M [m/s^2], q = -g_dv [1/m], r = g_f [1/s] (coupling/estimate.py states them).
Over a step of h [s] its flow e^(A h) is taken by rational approximants of the exponential in
partial fractions: per pole z, one solve of the tridiagonal A h - z I (:func:`resolvent_solve`).
The global estimate's carry uses the (1,2) approximant (:func:`state_flow`); the path error's
forced response the (2,3) one (coupling/path_error.py). Standard library only: this module
ships in the TriboPair FMU, which runs without numpy.
"""
from __future__ import annotations

import math

from ..physics.laws.boundary import KINETICS_TOL


# The (1,2) Pade approximant of e^z, R(z) = (1 + z/3) / (1 - 2z/3 + z^2/6), in partial fractions:
# its poles PADE_POLE and its conjugate, 2 +- i sqrt(2), its residue at the first PADE_RESIDUE
# (6 (1 + z1/3) / (z1 - conj(z1))), so that R(z) = 2 Re(PADE_RESIDUE / (z - PADE_POLE)) for real z
PADE_POLE = complex(2.0, math.sqrt(2.0))
PADE_RESIDUE = complex(1.0, -5.0 / math.sqrt(2.0))


def state_flow(h: float, w2: float, c: float, p: float, q: float, r: float,
               ex: float, ev: float, ef: float) -> tuple[float, float, float]:
    """R(A h) (ex, ev, ef) over a step of h [s] for the variational equations of
    :meth:`.estimate.GlobalErrorEstimate.state_slopes`, A = [[0, 1, 0], [-w2, -c, p], [0, q, r]], with R
    the (1,2) Pade approximant of the exponential: third order (A h of a non-stiff mode off
    e^(A h) by (A h)^4 / 72) and L-stable (R(z) ~ 2/z as |z| grows: a stiff mode decays within
    the step, as it does). The f-mode is stiff (|r| h up to 1e4) and a solid lubricant's
    c h up to 1e5: an explicit or A-stable-only rule would ring or blow up, e^(A h) in closed
    form is the 2x2 flow's cubic-in-three-eigenvalues (scipy's expm 130 us, numpy's eig 25
    us a step). In partial fractions, R(A h) e = 2 Re(alpha (A h - z1 I)^-1 e) (z1, alpha:
    PADE_POLE, PADE_RESIDUE): A h - z1 I is tridiagonal, one complex elimination, no (A h)^2
    whose stiff entries would swamp the rest. (Exact solve: the denominator is 0 only where
    an eigenvalue of A h is z1 itself; then the carry is not finite, as R is not.)"""
    u = resolvent_solve(h, w2, c, p, q, r, PADE_POLE, ex, ev, ef)
    if u is None:
        return math.nan, math.nan, math.nan
    k = 2.0 * PADE_RESIDUE
    return (k * u[0]).real, (k * u[1]).real, (k * u[2]).real


def resolvent_solve(h: float, w2: float, c: float, p: float, q: float, r: float, z: complex,
                    ex: complex, ev: complex, ef: complex) -> tuple[complex, complex, complex] | None:
    """u of (A h - z I) u = (ex, ev, ef) for the variational equations' A = [[0, 1, 0], [-w2, -c,
    p], [0, q, r]] (:func:`state_flow`) over a step of h [s], at a pole z of a rational
    approximant of the exponential: A h - z I is tridiagonal, one elimination (None where its
    pivot is 0, z an eigenvalue of A h itself)."""
    d0, d1, d2 = -z, -c * h - z, r * h - z  # the diagonal of A h - z I
    a, P, Q = -w2 * h, p * h, q * h
    # rows: d0 u0 + h u1 = ex; a u0 + d1 u1 + P u2 = ev; Q u1 + d2 u2 = ef
    pivot = d1 - a * h / d0 - P * Q / d2
    if pivot == 0.0:
        return None
    u1 = (ev - a * ex / d0 - P * ef / d2) / pivot
    return (ex - h * u1) / d0, u1, (ef - Q * u1) / d2


def step_transition(h: float, w2: float, velocity_per_impulse: float, sensitivities,
                    ex: float, ev: float, ef: float) -> tuple[float, float, float]:
    """(ex, ev, ef) carried over a slip step of h [s] by the step's own map: the lubricant's
    sensitivities over the step (``sensitivities``: (d f1, d F_mean) each against (f0, dv0,
    dv1), :meth:`~tribofmu.physics.laws.boundary.BoundaryLaw.step_sensitivities`, along the path
    its sub-steps took) and the block's exact response to its mean force (the spring's flow,
    w2 = 2K/M [1/s^2], and a force held over the step, 1/M = velocity_per_impulse). dv = V - v
    moves by -ev; the force's dependence on the step's end makes the map implicit in ev1, one
    division. (The variational equations at the step's middle (:func:`state_flow`) lost part
    of an error at each melt and re-solidification, 0.35x after two periods at a rig whose
    errors persist; this map keeps 0.96-1.0x: bench_carry_sensitivity.py.)"""
    (f_f, f_0, f_1), (m_f, m_0, m_1) = sensitivities
    w = math.sqrt(w2) if w2 > 0.0 else 0.0
    if w * h > 1e-8:
        c, s = math.cos(w * h), math.sin(w * h)
        xx, xv, vx, vv = c, s / w, -w * s, c
        bx, bv = (1.0 - c) / w2 * velocity_per_impulse, s / w * velocity_per_impulse
    else:
        xx, xv, vx, vv = 1.0, h, -w2 * h, 1.0
        bx, bv = 0.5 * h * h * velocity_per_impulse, h * velocity_per_impulse
    known = m_f * ef - m_0 * ev  # the mean force's change but for its end's dv
    ev1 = (vx * ex + vv * ev + bv * known) / (1.0 + bv * m_1)
    force = known - m_1 * ev1
    return xx * ex + xv * ev + bx * force, ev1, f_f * ef - f_0 * ev - f_1 * ev1


def lubricant_step(law, start, end, h: float, velocity_per_impulse: float) -> tuple | None:
    """What :func:`step_transition` takes besides the error, for the slip step of h [s] from
    point start to point end of a friction with state: (1/M, the law's sensitivities over the
    step from start's f and dv to end's dv, n and T their means), its kinetics at the FMUs' own
    tolerance (``KINETICS_TOL``): the sub-steps across the melt threshold's kink followed in two
    parts (physics/laws/tangent.py), the map's sensitivities are within 0.3 % (median) of central
    differences there at 1e-5, 0.2 % at 1e-6 (``benchmarks/bench_map_sensitivity.py``,
    docs/coupling-record.md);
    None where the law has none (its melting off, a slope not finite) or the block's mass is
    not yet known."""
    if velocity_per_impulse <= 0.0 or law is None or not law.gives_step_map:
        return None
    stepped = law.step_sensitivities(start.f, end.dv, 0.5 * (start.n + end.n), 0.5 * (start.T + end.T), h,
                                     KINETICS_TOL, KINETICS_TOL, dv_start=start.dv)
    return None if stepped is None else (velocity_per_impulse, stepped[1])
