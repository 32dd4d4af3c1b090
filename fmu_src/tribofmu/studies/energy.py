"""Energy audit of a co-simulation run, from its communication points.

Over each communication step [t0, t0 + h] the block felt the force ``F_start + F_rate s``
(s in [0, h], recorded on the step's end point); the drive and block velocities are the
cubic Hermite interpolants the results are sampled with (V with the drive's accelerations,
v with :func:`velocity_slopes`). A linear force times a cubic velocity is a quartic, which
3-point Gauss-Legendre quadrature integrates exactly: the integrals below are exact for the
trajectory the run delivers, so what is left in the balance is the run's own error.

    W  = int F V dt             work the drive does through the friction
    D  = int F (V - v) dt       heat dissipated in the contact
    dE = (M v^2 / 2 + K x^2)(end) - (start)   block energy (two springs of stiffness K)
    residual = W - D - dE       = int F v dt - dE: 0 for an exact run

Units: J. ``residual_rel`` is the residual relative to |D| (or to the
largest block energy reached if that is larger: a contact that never slips dissipates
nothing, and its D is round-off).
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ..master.algorithms import NS, velocity_slopes

# 3-point Gauss-Legendre on [0, 1]: exact for polynomials up to degree 5
_GL_S = np.array([0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0])
_GL_W = np.array([5.0, 8.0, 5.0]) / 18.0


def _hermite(y0, y1, d0, d1, h, s):
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    return h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1


def step_integrals(points: Sequence[Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per communication step: h [s], int F V dt [J], int F v dt [J] (arrays of n-1)."""
    n = len(points) - 1
    if n < 1:
        z = np.zeros(0)
        return z, z, z
    t = np.array([p.t_ns for p in points], dtype=np.int64)
    h = np.diff(t) / NS
    get = lambda k: np.array([getattr(p, k) for p in points])
    V, aX, v = get("V"), get("aX"), get("v")
    F0, rate = get("F_start")[1:], get("F_rate")[1:]
    slopes = np.array([velocity_slopes(p0, p1) for p0, p1 in zip(points, points[1:])])
    s = _GL_S[:, None]
    force = F0 + rate * (s * h)
    V_s = _hermite(V[:-1], V[1:], aX[:-1], aX[1:], h, s)
    v_s = _hermite(v[:-1], v[1:], slopes[:, 0], slopes[:, 1], h, s)
    WV = h * (_GL_W[:, None] * force * V_s).sum(axis=0)
    Wv = h * (_GL_W[:, None] * force * v_s).sum(axis=0)
    return h, WV, Wv


def energy_audit(points: Sequence[Any], scenario) -> dict[str, Any]:
    """Work, dissipation and block energy balance of a run (see the module doc); J.

    negative_dissipation_steps counts steps whose dissipation is below minus a round-off
    allowance (1e-8 of |F| times the velocity scale times h, or 1e-8 of the run's mean
    dissipation over the step if larger): friction that feeds energy into the system,
    which only a numerical error can do.
    """
    M, K = scenario.block.M, scenario.block.K
    energy = lambda p: 0.5 * M * p.v ** 2 + K * p.x ** 2
    if len(points) < 2:
        return {"W": 0.0, "D": 0.0, "dE": 0.0, "residual": 0.0, "residual_rel": 0.0,
                "negative_dissipation_steps": 0, "steps": 0}
    h, WV, Wv = step_integrals(points)
    D_step = WV - Wv
    W, D = float(WV.sum()), float(D_step.sum())
    dE = energy(points[-1]) - energy(points[0])
    residual = W - D - dE
    E_max = max(energy(p) for p in points)
    F_abs = np.array([max(abs(p0.F), abs(p1.F_start), abs(p1.F_start + p1.F_rate * hh))
                      for p0, p1, hh in zip(points, points[1:], h)])
    v_scale = max(max(abs(p.V) for p in points), max(abs(p.v) for p in points), 1e-300)
    # round-off of the quadrature, and the interpolants' O(h^3) slivers where F and V - v
    # change sign a hair apart: 1e-8 of the run's mean dissipation rate
    span = max(float(h.sum()), 1e-300)
    allowance = np.maximum(1e-8 * F_abs * v_scale * h, 1e-8 * abs(D) / span * h)
    negative = int(np.count_nonzero(D_step < -allowance))
    denom = max(abs(D), E_max)  # D alone is round-off where the contact never slips
    return {"W": W, "D": D, "dE": float(dE), "residual": float(residual),
            "residual_rel": float(residual / denom) if denom > 0 else 0.0,
            "negative_dissipation_steps": negative,
            "most_negative_step_dissipation": float(min(0.0, D_step.min())),
            "steps": int(len(h))}


def step_dissipation(start: Any, end: Any) -> float:
    """int F (V - v) dt [J] over the communication step start -> end, the same quadrature
    as :func:`step_integrals` for one step, in plain floats (called once per step by a
    master that feeds the friction power to a heat balance)."""
    h = (end.t_ns - start.t_ns) / NS
    if h <= 0.0:
        return 0.0
    v0_slope, v1_slope = velocity_slopes(start, end)
    total = 0.0
    for s, w in zip(_GL_S_LIST, _GL_W_LIST):
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        V = h00 * start.V + h10 * h * start.aX + h01 * end.V + h11 * h * end.aX
        v = h00 * start.v + h10 * h * v0_slope + h01 * end.v + h11 * h * v1_slope
        total += w * (end.F_start + end.F_rate * s * h) * (V - v)
    return h * total


_GL_S_LIST, _GL_W_LIST = [float(s) for s in _GL_S], [float(w) for w in _GL_W]


def heat_audit(points: Sequence[Any], scenario) -> dict[str, Any]:
    """The heat the Thermal FMU received against the friction dissipation of the run.

    Q [J]: the Thermal FMU's own count of the heat it received (its output Q at the last
    point); D [J]: the audit's dissipation int F (V - v) dt (:func:`energy_audit`);
    q [1]: the share of the friction power that heats the film. relative_mismatch =
    (Q - q D) / (q D). Empty when the scene has no Thermal FMU.
    """
    if "Thermal" not in scenario.fmus or len(points) < 2:
        return {}
    h, WV, Wv = step_integrals(points)
    D = float((WV - Wv).sum())
    q = scenario.thermal.q
    Q = float(points[-1].Q - points[0].Q)
    expected = q * D
    return {"Q": Q, "D": D, "q": q, "mismatch": Q - expected,
            "relative_mismatch": (Q - expected) / abs(expected) if expected != 0 else 0.0,
            "T_start": float(points[0].T), "T_end": float(points[-1].T),
            "T_max": float(max(p.T for p in points))}
