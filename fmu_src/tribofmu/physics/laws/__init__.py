"""The friction laws, one module each, and their registry.

A scene names its law (``friction.regime = "dry"``), the Friction FMU takes its integer code
(``regime = 0``); either is resolved once, by :func:`law_class` / :func:`make_law`, to a law
object (:class:`tribofmu.physics.friction.FrictionLaw`) that everything else asks. To add a
law: a module here with a :class:`FrictionLaw` subclass (a new name and code), its line in
:data:`LAWS`, and a scene (see docs/layout.md).
"""
from __future__ import annotations

from dataclasses import fields

from ..friction import FrictionLaw
from .boundary import BoundaryLaw
from .dry import DryLaw
from .fluid import FluidLaw
from .mixed import MixedLaw

__all__ = ["LAWS", "law_class", "make_law", "regime_problem", "law_parameters",
           "DryLaw", "FluidLaw", "BoundaryLaw", "MixedLaw"]

LAWS: dict[str, type[FrictionLaw]] = {law.name: law for law in (
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


def law_parameters() -> dict[str, tuple[float, str, str]]:
    """The FMU parameters the laws add to the shared ones: name -> (default, unit, description)."""
    out = {}
    for law in LAWS.values():
        defaults = {f.name: f.default for f in fields(law)}
        for name, (unit, text) in law.fmu_parameters.items():
            out[name] = (defaults[name], unit, text)
    return out
