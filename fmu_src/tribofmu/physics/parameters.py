"""How a parameter of the physics is declared: once, as a field of the dataclass of the physics
that reads it (a friction law, the lubricant, the block, the drive, the heat balance, the load
program), with its default, unit, range, description and the equation it comes from.

    name: float = parameter(default, "unit", "what it is, eq. (n)", above(bound, "why"), symbol="...")

Everything else is derived from these declarations (:func:`declared`): the checks of the physics
(:func:`problems_of`), the FMUs' variables and their checks (:mod:`tribofmu.fmu.parameters`), the
scene's tables and keys, ``--set`` and the axis units (:mod:`tribofmu.scene.scenario`), the wiring
of a scene to its FMUs (:mod:`tribofmu.scene.wiring`) and the parameter tables of docs/model.md
(:mod:`tribofmu.scene.parameter_docs`). Standard library only: shipped in every FMU, run in hosts
without numpy.
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass, field, fields, replace
from typing import Any

_KEY = "tribofmu.parameter"  # where a field's metadata holds its declaration


@dataclass(frozen=True)
class Range:
    """The values a parameter may take: above ``low`` (``strict``: ``>``, else ``>=``), at most
    ``high`` where given; ``why`` is said in the message, ``unit`` after the bound."""

    low: float
    strict: bool = False
    high: float | None = None
    why: str = ""
    unit: str = ""

    @property
    def text(self) -> str:
        """``> -1``, ``>= 0 K``, ``in [0, 1]``."""
        if self.high is not None:
            return f"in [{self.low:g}, {self.high:g}]"
        return f"{'>' if self.strict else '>='} {self.low:g}" + (f" {self.unit}" if self.unit else "")

    @property
    def described(self) -> str:
        """:attr:`text` and why: ``> 0 (why)``."""
        return f"{self.text} ({self.why})" if self.why else self.text

    def __call__(self, value: float) -> str | None:
        """None in range, else ``must be ..., got value`` (the FMU check's form)."""
        low_ok = value > self.low if self.strict else value >= self.low
        if low_ok and (self.high is None or value <= self.high):
            return None
        return f"must be {self.described}, got {value}"


@dataclass(frozen=True)
class OneOf:
    """An integer code among ``names`` (code -> name)."""

    names: dict

    @property
    def text(self) -> str:
        """``0 (constant), 1 (ramp) or 2 (step)``."""
        codes = [f"{code} ({name})" for code, name in self.names.items()]
        return f"{', '.join(codes[:-1])} or {codes[-1]}"

    @property
    def described(self) -> str:
        return self.text

    def __call__(self, value: int) -> str | None:
        return None if value in self.names else f"must be {self.text}, got {value}"


def above(low: float, why: str = "") -> Range:
    """``> low``."""
    return Range(low, strict=True, why=why)


def at_least(low: float, why: str = "", unit: str = "") -> Range:
    """``>= low``."""
    return Range(low, why=why, unit=unit)


def within(low: float, high: float) -> Range:
    """``in [low, high]``."""
    return Range(low, high=high)


@dataclass(frozen=True)
class Parameter:
    """One declared parameter. name: the field's, the scene key in its table and the FMU
    variable (``fmu_name`` where the FMU's differs); unit as modelDescription.xml writes it
    (``m2``, ``Pa.s``; :func:`display_unit` for labels); description: the FMU's,
    naming the equation; check: its :class:`Range` (None: any finite value); symbol and note:
    how docs/model.md writes it and reads the paper on it."""

    name: str
    default: Any
    unit: str
    description: str
    check: Range | OneOf | None = None
    symbol: str = ""
    note: str = ""
    fmu_name: str = ""

    @property
    def fmu_variable(self) -> str:
        return self.fmu_name or self.name

    def problems(self, value: Any) -> list[str]:
        """``name must be ..., got value`` for a value that is not finite or out of range."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return []
        if not math.isfinite(value):
            return [f"{self.name} must be finite, got {value}"]
        why = self.check(value) if self.check else None
        return [f"{self.name} {why}"] if why else []


def parameter(default: Any, unit: str, description: str, check: Range | OneOf | None = None, *,
              symbol: str = "", note: str = "", fmu_name: str = ""):
    """A dataclass field declaring a parameter (its name is the field's)."""
    return field(default=default, metadata={_KEY: Parameter("", default, unit, description, check, symbol,
                                                            note, fmu_name)})


def declared(cls_or_instance) -> tuple[Parameter, ...]:
    """The parameters a dataclass declares, in field order (a subclass's after its base's)."""
    return _declared_by(cls_or_instance if isinstance(cls_or_instance, type) else type(cls_or_instance))


@functools.lru_cache(maxsize=None)
def _declared_by(cls: type) -> tuple[Parameter, ...]:
    """:func:`declared` of a class, made once per class (frozen Parameters: nothing changes
    them; every FMU instantiation and every check of an instance asks again)."""
    return tuple(replace(f.metadata[_KEY], name=f.name) for f in fields(cls) if _KEY in f.metadata)


def own_parameters(cls: type, base: type) -> tuple[Parameter, ...]:
    """The parameters cls declares beyond those of its base class."""
    inherited = {p.name for p in declared(base)}
    return tuple(p for p in declared(cls) if p.name not in inherited)


def problems_of(instance) -> list[str]:
    """Every declared parameter of a dataclass instance that is not finite or out of range,
    as ``name must be ..., got value``."""
    return [problem for p in declared(instance) for problem in p.problems(getattr(instance, p.name))]


def display_unit(unit: str) -> str:
    """A unit as modelDescription.xml writes it, for a label: ``m2`` -> ``m^2``, ``Pa.s`` -> ``Pa s``."""
    return re.sub(r"([A-Za-z)])(\d)", r"\1^\2", unit.replace(".", " "))
