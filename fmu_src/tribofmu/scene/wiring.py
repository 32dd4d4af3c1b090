"""How a scenario maps onto the FMUs: start values of each FMU and the constant inputs.

Shared by the master and the SSP export so both instantiate the same system.
"""
from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

from ..physics.friction import REGIMES, Effects, LubricantConstants
from .scenario import Scenario

# Effects field -> Friction FMU parameter name
EFFECT_PARAMETERS = {"melting": "melting", "pressure": "pressure_term",
                     "temperature": "temperature_term", "viscous": "viscous_term",
                     "elastic": "elastic_term"}
CONNECTIONS = (("Drive", "V", "BlockSpring", "V"), ("BlockSpring", "dv", "Friction", "dv"),
               ("Friction", "F", "BlockSpring", "F"))


def fmu_parameters(scenario: Scenario) -> dict[str, dict[str, Any]]:
    """Start values by FMU name (only the FMUs the scene uses); SI units."""
    fr = scenario.friction
    friction = {"regime": REGIMES[fr.regime], "mu_friction": fr.mu_friction, "S": fr.S, "m": fr.m,
                "gamma": fr.gamma, "f0": fr.f0}
    friction.update({f.name: getattr(fr.lubricant, f.name) for f in fields(LubricantConstants)})
    friction.update({EFFECT_PARAMETERS[f.name]: getattr(fr.effects, f.name) for f in fields(Effects)})
    every = {"Drive": {"A": scenario.drive.A, "omega": scenario.drive.omega},
             "BlockSpring": {"M": scenario.block.M, "K": scenario.block.K,
                             "x0": scenario.block.x0, "v0": scenario.block.v0},
             "Friction": friction}
    return {name: every[name] for name in scenario.fmus}


def constant_inputs(scenario: Scenario) -> dict[str, float]:
    """The friction FMU's inputs that a scene holds constant: n [Pa], T [K]."""
    return {"n": scenario.conditions.n, "T": scenario.conditions.T}


def scales(scenario: Scenario) -> tuple[float, float, float]:
    """Position [m], velocity [m/s] and time [s] scales of the scene, for tolerances."""
    b, d = scenario.block, scenario.drive
    w0 = math.sqrt(2 * b.K / b.M)
    position = max(abs(d.A) if "Drive" in scenario.fmus else 0.0, abs(b.x0), abs(b.v0) / max(w0, d.omega))
    velocity = max(position * d.omega, abs(b.v0), abs(b.x0) * w0)
    return position or 1e-9, velocity or 1e-9, d.period
