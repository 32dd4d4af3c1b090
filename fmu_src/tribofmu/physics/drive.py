"""The driven upper block, eqs. (1)-(2): ``X = A cos(w t)``, ``V = -A w sin(w t)``."""
from __future__ import annotations

import math
from dataclasses import dataclass

from .parameters import above, parameter, problems_of


@dataclass(frozen=True)
class DriveParams:
    """The harmonic drive of eqs. (1)-(2)."""

    A: float = parameter(2e-3, "m", "drive amplitude", symbol="A")
    omega: float = parameter(30.0, "rad/s", "drive angular frequency", above(0), symbol="ω")

    @property
    def period(self) -> float:
        """Drive period T = 2 pi / omega [s]."""
        return 2.0 * math.pi / self.omega

    def problems(self) -> list[str]:
        """Every parameter that is not finite or out of range, as ``name must be ..., got value``."""
        return problems_of(self)


def drive(t: float, A: float, omega: float) -> tuple[float, float, float]:
    """Upper block position X [m], velocity V [m/s], acceleration [m/s^2] at time t [s]."""
    c, s = math.cos(omega * t), math.sin(omega * t)
    return A * c, -A * omega * s, -A * omega * omega * c
