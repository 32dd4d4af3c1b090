"""Lumped heat balance of the lubricant film. Pure physics, no FMI.

    C dT/dt = q P - G (T - T_ambient)

T [K] the film temperature; P [W] the friction power F (V - v) dissipated in the contact;
C [J/K] the heat capacity of what heats up (a film of thickness h and area S holds
rho c S h, about 2e6 J/(m^3 K) * 3e-18 m^3 = 6e-12 J/K for the paper's Fig. 6 film);
q [1] the share of the friction power that heats the film (the rest leaves through the
surfaces at once); G [W/K] the conductance from the film to the surroundings at
T_ambient [K].

Over a step with the power held, the balance is linear with constant coefficients and is
solved exactly (:func:`advance_thermal`): the only error a master makes is in the power it
supplies, and the heat the film receives over the step is exactly ``q P h``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .parameters import Parameter, above, at_least, parameter, problems_of, within

# The film's temperature at the start (the Thermal FMU's; a scene starts it at conditions.T).
START_T = Parameter("T0", 290.0, "K", "film temperature at the start", at_least(0))


@dataclass(frozen=True)
class ThermalParams:
    """The heat balance's parameters."""

    C: float = parameter(6e-12, "J/K", "heat capacity of the film", above(0), symbol="C")
    q: float = parameter(1.0, "1", "share of the friction power that heats the film", within(0, 1), symbol="q")
    G: float = parameter(1e-11, "W/K", "thermal conductance from the film to the surroundings", at_least(0),
                         symbol="G")
    T_ambient: float = parameter(290.0, "K", "temperature of the surroundings", at_least(0, unit="K"),
                                 symbol="T_ambient")

    def problems(self) -> list[str]:
        """Every parameter that is not finite or out of range, as ``name must be ..., got value``."""
        return problems_of(self)

    @property
    def time_constant(self) -> float:
        """C / G [s] (inf without conduction)."""
        return self.C / self.G if self.G > 0 else math.inf

    def steady_temperature(self, P: float) -> float:
        """T [K] the film settles at under a constant power P [W] (inf without conduction)."""
        return self.T_ambient + self.q * P / self.G if self.G > 0 else math.copysign(math.inf, P)


@dataclass(frozen=True)
class ThermalStep:
    """Outcome of one step: T [K] at its end, heat received q P h [J] and heat conducted
    away int G (T - T_ambient) dt [J] over it. C (T_end - T_start) = received - lost exactly."""

    T: float
    received: float
    lost: float


def power_problems(P: float) -> list[str]:
    """Out-of-range friction power [W]. A negative power is accepted: friction never feeds
    energy in, but a master that pairs F and dv from different instants, or rounds an
    exact zero, may hand over a slightly negative product for a step."""
    return [] if math.isfinite(P) else [f"P must be finite, got {P}"]


def advance_thermal(T: float, P: float, h: float, params: ThermalParams) -> ThermalStep:
    """Exact solution of the heat balance over a step h [s] with the power P [W] held.

    T(s) = T_inf + (T - T_inf) exp(-s / tau), tau = C / G, T_inf = T_ambient + q P / G;
    without conduction (G = 0) T rises linearly by q P h / C.
    """
    received = params.q * P * h
    if params.G == 0.0:
        return ThermalStep(T + received / params.C, received, 0.0)
    rate = params.G / params.C  # 1/s
    excess = T - params.T_ambient - params.q * P / params.G  # K, distance from T_inf
    # expm1 keeps tiny steps exact: the change is excess * (exp(-rate h) - 1)
    change = excess * math.expm1(-rate * h)
    T_end = T + change
    lost = received - params.C * change
    return ThermalStep(T_end, received, lost)


def temperature_rate(T: float, P: float, params: ThermalParams) -> float:
    """dT/dt [K/s] of the heat balance."""
    return (params.q * P - params.G * (T - params.T_ambient)) / params.C
