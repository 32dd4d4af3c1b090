"""The friction laws, one module each, and their registry.

A scene names its law (``friction.regime = "dry"``), the Friction FMU takes its integer code
(``regime = 0``); either is resolved once, by :func:`law_class` / :func:`make_law`, to a law
object (:class:`tribofmu.physics.friction.FrictionLaw`) that everything else asks. To add a
law: a module here with a :class:`FrictionLaw` subclass (a new name and code), its line in
:data:`LAWS`, and a scene (see docs/layout.md).
"""
from __future__ import annotations

from dataclasses import fields

from ..friction import Effects, FrictionLaw, LubricantConstants
from ..parameters import Parameter, declared, own_parameters
from .boundary import BoundaryLaw
from .dry import DryLaw
from .fluid import FluidLaw
from .mixed import MixedLaw

__all__ = ["LAWS", "law_class", "make_law", "regime_problem", "law_fields", "law_parameters",
           "DryLaw", "FluidLaw", "BoundaryLaw", "MixedLaw"]

def _reading_its_own(law: type[FrictionLaw]) -> type[FrictionLaw]:
    """The law, its ``keys`` completed by the parameters it declares itself (a law reads what
    it adds)."""
    law.keys = law.keys | {p.name for p in own_parameters(law, FrictionLaw)}
    return law


LAWS: dict[str, type[FrictionLaw]] = {law.name: _reading_its_own(law) for law in (
    DryLaw,
    FluidLaw,
    BoundaryLaw,
    MixedLaw,
)}
_BY_CODE = {law.code: law for law in LAWS.values()}
assert len(_BY_CODE) == len(LAWS), "two laws share an FMU code"


def law_class(regime: str | int) -> type[FrictionLaw]:
    """The law named regime (a scene's name) or coded regime (the FMU's integer); KeyError
    naming the choices otherwise."""
    table = _BY_CODE if isinstance(regime, int) and not isinstance(regime, bool) else LAWS
    try:
        return table[regime]
    except (KeyError, TypeError):
        raise KeyError(regime_problem(regime)) from None


def regime_problem(regime) -> str | None:
    """None for a known law name or code, else ``must be one of ..., got value``."""
    if (isinstance(regime, int) and not isinstance(regime, bool) and regime in _BY_CODE) or (
            isinstance(regime, str) and regime in LAWS):
        return None
    if isinstance(regime, str):
        return f"must be one of {', '.join(LAWS)}, got {regime!r}"
    codes = [f"{law.code} ({law.name})" for law in LAWS.values()]
    return f"must be {', '.join(codes[:-1])} or {codes[-1]}, got {regime}"


def make_law(regime: str | int, **parameters) -> FrictionLaw:
    """The law for regime with those of parameters its class has (others are ignored: a
    scene or an FMU carries every law's parameters)."""
    cls = law_class(regime)
    names = {f.name for f in fields(cls)}
    return cls(**{k: v for k, v in parameters.items() if k in names})


def law_fields() -> tuple[Parameter, ...]:
    """The laws' own parameters: those every law has (:class:`FrictionLaw`'s), then those each
    law adds (a law reads those of its ``keys``; :func:`make_law` keeps its own)."""
    return (*declared(FrictionLaw), *(p for law in LAWS.values() for p in own_parameters(law, FrictionLaw)))


def law_parameters() -> tuple[Parameter, ...]:
    """Every friction parameter an FMU carries, in the FMUs' order: those every law has, the
    lubricant's constants, the boundary model's switches, then those each law adds."""
    shared = declared(FrictionLaw)
    return (*shared, *declared(LubricantConstants), *declared(Effects), *law_fields()[len(shared):])
