"""The step quadrature of the energy audit, in plain floats (shipped in the FMUs).

Over a communication step the block felt a linear force ramp and the velocities are cubic
Hermite interpolants: the product is a quartic, which 3-point Gauss-Legendre quadrature
integrates exactly.
"""
from __future__ import annotations

import math

from .interpolation import NS, hermite, velocity_slopes

# 3-point Gauss-Legendre on [0, 1]: exact for polynomials up to degree 5
GAUSS_NODES = (0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0)
GAUSS_WEIGHTS = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)


def step_dissipation(start, end) -> float:
    """int F (V - v) dt [J] over the communication step start -> end (points), the audit's
    quadrature for one step (called once per step by a system that feeds the friction power
    to a heat balance)."""
    h = (end.t_ns - start.t_ns) / NS
    if h <= 0.0:
        return 0.0
    v0_slope, v1_slope = velocity_slopes(start, end)
    total = 0.0
    for s, w in zip(GAUSS_NODES, GAUSS_WEIGHTS):
        V = hermite(start.V, end.V, start.aX, end.aX, h, s)
        v = hermite(start.v, end.v, v0_slope, v1_slope, h, s)
        total += w * (end.F_start + end.F_rate * s * h) * (V - v)
    return h * total
