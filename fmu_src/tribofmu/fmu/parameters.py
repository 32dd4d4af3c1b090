"""The FMU side of the physics' parameter declarations (:mod:`tribofmu.physics.parameters`):
each declared parameter becomes an FMU parameter (:func:`declare_parameter`) with its name,
default, unit, description and range check; and the variables the FMUs share: the block's
parameters and outputs, the friction law's parameters (and, from the framework,
:func:`parameter_cached` for what the parameters make).

BlockSpring and Friction declare their variables here, and TriboPair (block and friction in
one FMU) declares both sets with the same calls, so the pair cannot drift from the separate FMUs.
"""
from __future__ import annotations

from tribofmu.fmu.base import INPUT, OUTPUT, PARAMETER, positive
from tribofmu.fmu.fmu_state import parameter_cached  # noqa: F401 (the models import it from here)
from tribofmu.physics.block import BlockParams
from tribofmu.physics.friction import START_F, Conditions, Effects, FrictionLaw, LubricantConstants
from tribofmu.physics.laws.boundary import KINETICS_TOL
from tribofmu.physics.laws import LAWS, law_fields, law_parameters, make_law, regime_problem
from tribofmu.physics.parameters import Parameter, declared  # noqa: F401 (the models import it from here)


def declare_parameter(slave, p: Parameter, checked: bool = True) -> None:
    """One declared parameter as an FMU parameter: its FMU name, default, unit, description
    and (checked) its range, refused with the declaration's message."""
    slave.declare(p.fmu_variable, p.default, PARAMETER, p.unit, p.description, check=p.check if checked else None)


def declare_block_parameters(slave) -> None:
    """The block's parameters (:class:`tribofmu.physics.block.BlockParams`), eq. (3)."""
    for p in declared(BlockParams):
        declare_parameter(slave, p)


def declare_friction_inputs(slave) -> None:
    """n [Pa] and T [K], the friction's inputs besides dv (:class:`tribofmu.physics.friction.Conditions`)."""
    for p in declared(Conditions):
        slave.declare(p.name, p.default, INPUT, p.unit, p.description)


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
    # Every law's parameters: those every law carries are checked on their own, those a law
    # adds by that law (model_problems), so a scene of one law is not refused for another's.
    for p in _FRICTION_PARAMETERS:
        declare_parameter(slave, p, checked=p.name in _SHARED)
    declare_parameter(slave, START_F)
    slave.declare("kinetics_tol", KINETICS_TOL, PARAMETER, "1",
                  "boundary: tolerance (absolute and relative) of eq. (21) inside a step", check=positive)


# The law's fields (every law's and those each law adds: make_law keeps its law's), the
# lubricant's and the switches', read from the FMU's parameters.
_LAW = law_fields()
_LUBRICANT, _EFFECTS = declared(LubricantConstants), declared(Effects)
_FRICTION_PARAMETERS = law_parameters()
_SHARED = {p.name for p in (*declared(FrictionLaw), *_LUBRICANT)}


def friction_law(slave) -> FrictionLaw:
    """The law the parameters of :func:`declare_friction_parameters` on slave describe."""
    def values(parameters) -> dict:
        return {p.name: getattr(slave, p.fmu_variable) for p in parameters}
    return make_law(slave.regime, **values(_LAW), lubricant=LubricantConstants(**values(_LUBRICANT)),
                    effects=Effects(**values(_EFFECTS)))
