"""How a scenario maps onto the FMUs: start values of each FMU and the constant inputs.

Shared by the master and the SSP export so both instantiate the same system.
"""
from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

from ..physics.friction import REGIMES, Effects, LubricantConstants
from ..physics.load import PROGRAMS
from .scenario import Scenario

# Effects field -> Friction FMU parameter name
EFFECT_PARAMETERS = {"melting": "melting", "pressure": "pressure_term",
                     "temperature": "temperature_term", "viscous": "viscous_term",
                     "elastic": "elastic_term"}
CONNECTIONS = (("Drive", "V", "BlockSpring", "V"), ("BlockSpring", "dv", "Friction", "dv"),
               ("Friction", "F", "BlockSpring", "F"),
               # beyond the paper: a load program and the film's heat balance
               ("Load", "n", "Friction", "n"), ("Thermal", "T", "Friction", "T"),
               ("Friction", "F", "Thermal", "F"), ("BlockSpring", "dv", "Thermal", "dv"))
# How the master treats each FMU beyond the dv -> F loop (see tribofmu.master.system):
# Load steps with the drive (a function of time); Thermal follows the solved loop, its T
# exchanged explicitly, and gets the step's exact mean friction power through its input P
# (an SSP master, which can only connect variables, feeds F and dv instead).


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
    if "Thermal" in scenario.fmus:
        th = scenario.thermal
        every["Thermal"] = {"C": th.C, "q": th.q, "G": th.G, "T_ambient": th.T_ambient,
                            "T0": scenario.conditions.T}
    if "Load" in scenario.fmus:
        ld = scenario.load_program
        every["Load"] = {"program": PROGRAMS[ld.program], "n0": ld.n0, "n1": ld.n1, "t_start": ld.t_start,
                         "t_end": ld.t_end, "amplitude": ld.amplitude, "period": ld.period, "phase": ld.phase}
    return {name: every[name] for name in scenario.fmus}


def constant_inputs(scenario: Scenario) -> dict[str, float]:
    """The friction FMU's inputs that a scene holds constant: n [Pa], T [K] (those not fed
    by a Load or Thermal FMU)."""
    held = {"n": scenario.conditions.n, "T": scenario.conditions.T}
    fed = {end_var for start, _, end, end_var in CONNECTIONS
           if end == "Friction" and start in scenario.fmus and end_var in held}
    return {k: v for k, v in held.items() if k not in fed}


def build_system(scenario: Scenario, slaves: dict[str, Any]):
    """The master's :class:`~tribofmu.master.system.CoupledSystem` of the scene, from its
    slaves by FMU name (as instantiated from :func:`fmu_parameters`)."""
    from ..master.system import CoupledSystem

    friction = slaves.get("Friction")
    return CoupledSystem(block=slaves["BlockSpring"], drive=slaves.get("Drive"), friction=friction,
                         conditions=constant_inputs(scenario) if friction is not None else None,
                         load=slaves.get("Load"), thermal=slaves.get("Thermal"))


def input_signals(points, grid) -> dict[str, Any]:
    """The friction's inputs T [K], n [Pa] and the heat received Q [J] on the time grid [s],
    interpolated linearly between communication points."""
    import numpy as np

    t = np.array([p.t_ns for p in points], dtype=np.int64) / 1e9
    return {name: np.interp(grid, t, np.array([getattr(p, name) for p in points]))
            for name in ("T", "n", "Q")}


def scales(scenario: Scenario) -> tuple[float, float, float]:
    """Position [m], velocity [m/s] and time [s] scales of the scene, for tolerances."""
    b, d = scenario.block, scenario.drive
    w0 = math.sqrt(2 * b.K / b.M)
    position = max(abs(d.A) if "Drive" in scenario.fmus else 0.0, abs(b.x0), abs(b.v0) / max(w0, d.omega))
    velocity = max(position * d.omega, abs(b.v0), abs(b.x0) * w0)
    return position or 1e-9, velocity or 1e-9, d.period
