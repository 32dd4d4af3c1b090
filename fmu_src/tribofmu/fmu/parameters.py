"""The declarations the FMUs share: the block's parameters and outputs, the friction law's
parameters (and, from the framework, :func:`parameter_cached` for what the parameters make).

BlockSpring and Friction declare their variables here, and TriboPair (block and friction in
one FMU) declares both sets with the same calls: one list of names, units, descriptions and
checks, so the pair cannot drift from the separate FMUs.
"""
from __future__ import annotations

from dataclasses import fields

from tribofmu.fmu.base import OUTPUT, PARAMETER, non_negative, positive
from tribofmu.fmu.effect_parameters import EFFECT_PARAMETERS
from tribofmu.fmu.fmu_state import parameter_cached  # noqa: F401 (the models import it from here)
from tribofmu.physics.friction import Effects, FrictionLaw, LubricantConstants
from tribofmu.physics.laws import LAWS, law_parameters, make_law, regime_problem


LUBRICANT = {  # name: (unit, description)
    "phi0_star": ("J/m3", "phi0*: constant part of phi0, eq. (15)"),
    "lam": ("Pa", "lambda: bulk elastic modulus of the solid-like lubricant, eq. (20)"),
    "lam_bar": ("Pa", "lambda-bar: melting decrement of lambda, eq. (20)"),
    "mu_shear": ("Pa", "mu: shear modulus of the solid-like lubricant, eq. (19)"),
    "mu_shear_bar": ("Pa", "mu-bar: melting decrement of the shear modulus, eq. (19)"),
    "phi1": ("J/m3", "phi1: Landau expansion coefficient, eq. (13)"),
    "phi2": ("J/m3", "phi2: Landau expansion coefficient, eq. (13)"),
    "phi3": ("J/m3", "phi3: Landau expansion coefficient, eq. (13)"),
    "alpha": ("J/(K.m3)", "alpha: temperature coefficient of phi0, eq. (15)"),
    "h": ("m", "lubricant layer thickness, eq. (22)"),
    "tau_f": ("Pa.s", "relaxation time of the excess volume, eq. (21)"),
    "tau_e": ("s", "Maxwell time of internal stress relaxation, eq. (22)"),
}


def _gamma(value):
    return None if value > -1 else f"must be > -1 (force must vanish at rest), got {value}"


def declare_block_parameters(slave) -> None:
    """M [kg], K [N/m], x0 [m], v0 [m/s] of the block between two springs, eq. (3)."""
    slave.declare("M", 0.6, PARAMETER, "kg", "mass of the lower block", check=positive)
    slave.declare("K", 7000.0, PARAMETER, "N/m", "stiffness of each of the two springs", check=non_negative)
    slave.declare("x0", 0.0, PARAMETER, "m", "position at the start")
    slave.declare("v0", 0.0, PARAMETER, "m/s", "velocity at the start")


def declare_block_outputs(slave) -> None:
    """x [m], v [m/s] and a [m/s2] of the lower block at the end of the step."""
    slave.declare("x", 0.0, OUTPUT, "m", "position of the lower block")
    slave.declare("v", 0.0, OUTPUT, "m/s", "velocity of the lower block")
    slave.declare("a", 0.0, OUTPUT, "m/s2", "acceleration of the lower block at the end of the step")


def declare_friction_parameters(slave) -> None:
    """The friction law's parameters: regime, the dry and fluid coefficients, the lubricant
    constants, the boundary model's switches and the start value f0."""
    slave.declare("regime", 0, PARAMETER, "1", "friction regime: " + ", ".join(
        f"{law.code} = {law.name}" for law in LAWS.values()), check=regime_problem)
    slave.declare("mu_friction", 0.5, PARAMETER, "1", "dry friction coefficient, eq. (4); mixed: the kinetic one",
                  check=non_negative)
    slave.declare("S", 1.0, PARAMETER, "m2", "contact area; dry load L = -n S", check=positive)
    slave.declare("m", 25.0, PARAMETER, "N.(s/m)^(gamma+1)",
                  "viscous coefficient m = k S / h^(gamma+1), eq. (12); mixed: m dv, N.s/m", check=non_negative)
    slave.declare("gamma", 0.0, PARAMETER, "1",
                  "power-law exponent: < 0 pseudoplastic, 0 Newtonian, > 0 dilatant", check=_gamma)
    defaults = LubricantConstants()
    for name, (unit, text) in LUBRICANT.items():
        check = non_negative if name in ("lam_bar", "mu_shear_bar") else (
            positive if name in ("lam", "mu_shear", "h", "tau_f", "tau_e", "phi3") else None)
        slave.declare(name, float(getattr(defaults, name)), PARAMETER, unit, text, check=check)
    for name, text in EFFECT_PARAMETERS.values():
        slave.declare(name, True, PARAMETER, "1", text)
    for name, (default, unit, text) in law_parameters().items():
        slave.declare(name, float(default), PARAMETER, unit, text)  # each law checks its own
    slave.declare("f0", 0.0, PARAMETER, "1", "boundary: excess volume at the start")
    # 1e-5 is twenty times below the master's default step tolerance on the force; tighter
    # only costs sub-steps (measured on fig6: the same nRMS(v) at 1e-5 and 1e-6)
    slave.declare("kinetics_tol", 1e-5, PARAMETER, "1",
                  "boundary: tolerance (absolute and relative) of eq. (21) inside a step", check=positive)


def friction_law(slave) -> FrictionLaw:
    """The law the parameters of :func:`declare_friction_parameters` on slave describe."""
    return make_law(
        slave.regime, mu_friction=slave.mu_friction, S=slave.S, m=slave.m, gamma=slave.gamma,
        **{name: getattr(slave, name) for name in law_parameters()},
        lubricant=LubricantConstants(**{f.name: getattr(slave, f.name) for f in fields(LubricantConstants)}),
        effects=Effects(**{field: getattr(slave, name) for field, (name, _) in EFFECT_PARAMETERS.items()}))
