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
