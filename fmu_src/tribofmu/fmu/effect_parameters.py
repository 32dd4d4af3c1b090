"""The boundary model's switches (:class:`tribofmu.physics.friction.Effects`) as Boolean
parameters of the Friction and TriboPair FMUs: the one map from a switch to its FMU parameter.

The FMUs declare and read the parameters by it (:mod:`tribofmu.fmu.parameters`) and the scene
sets them from a scenario's ``[effects]`` by it (:mod:`tribofmu.scene.wiring`). No imports:
the scene reads it without loading the FMU framework.
"""
from __future__ import annotations

EFFECT_PARAMETERS = {  # Effects field: (FMU parameter name, description)
    "melting": ("melting", "boundary: f evolves by eq. (21) (false: f stays at f0)"),
    "pressure": ("pressure_term", "boundary: normal-stress terms of eqs. (15), (21)"),
    "temperature": ("temperature_term", "boundary: alpha T in eq. (15)"),
    "viscous": ("viscous_term", "boundary: viscous force m sgn(dv)|dv|^(gamma+1) in eq. (23)"),
    "elastic": ("elastic_term", "boundary: elastic force tau S in eq. (23)"),
}
