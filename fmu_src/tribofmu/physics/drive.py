"""The driven upper block, eqs. (1)-(2): ``X = A cos(w t)``, ``V = -A w sin(w t)``."""
from __future__ import annotations

import math


def drive_problems(A: float, omega: float) -> list[str]:
    out = []
    if not math.isfinite(A):
        out.append(f"A must be finite, got {A}")
    if not (math.isfinite(omega) and omega > 0):
        out.append(f"omega must be > 0, got {omega}")
    return out


def drive(t: float, A: float, omega: float) -> tuple[float, float, float]:
    """Upper block position X [m], velocity V [m/s], acceleration [m/s^2] at time t [s]."""
    c, s = math.cos(omega * t), math.sin(omega * t)
    return A * c, -A * omega * s, -A * omega * omega * c
