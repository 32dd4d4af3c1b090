"""Normal-stress programs n(t) for the friction's load input. Pure physics, no FMI.

n [Pa] is negative in compression (the dry load is L = -n S). Times t [s]. Programs:

- ``constant``: n = n0;
- ``ramp``: n0 until t_start, linear to n1 at t_end, n1 after;
- ``step``: n0 before t_start, n1 from t_start on;
- ``sine``: n = n0 + amplitude sin(2 pi t / period + phase), phase [rad].

Each is an exact function of time: a master evaluates it at any communication point, and
:meth:`LoadProgram.breakpoints` names the times where it is not smooth (a solver should
not step across them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .parameters import OneOf, parameter, problems_of

PROGRAMS = {"constant": 0, "ramp": 1, "step": 2, "sine": 3}
PROGRAM_NAMES = {code: name for name, code in PROGRAMS.items()}


@dataclass(frozen=True)
class LoadProgram:
    """A program and its parameters (those a program does not use are ignored)."""

    program: int = parameter(PROGRAMS["constant"], "1", "0 = constant, 1 = ramp, 2 = step, 3 = sine",
                             OneOf(PROGRAM_NAMES), symbol="program", note='a scene names it: `"ramp"`')
    n0: float = parameter(-20.0, "Pa", "normal stress: constant value, value before a ramp or step, mean of "
                          "a sine (negative in compression)", symbol="n0")
    n1: float = parameter(-20.0, "Pa", "ramp and step: normal stress after", symbol="n1")
    t_start: float = parameter(0.0, "s", "ramp: start; step: time of the step", symbol="t_start")
    t_end: float = parameter(1.0, "s", "ramp: end (n reaches n1)", symbol="t_end", note="> t_start for a ramp")
    amplitude: float = parameter(0.0, "Pa", "sine: amplitude", symbol="amplitude")
    period: float = parameter(1.0, "s", "sine: period", symbol="period", note="> 0 for a sine")
    phase: float = parameter(0.0, "rad", "sine: phase at t = 0", symbol="phase")

    def problems(self) -> list[str]:
        """Every parameter that is out of range, as ``name must be ..., got value``."""
        out = problems_of(self)
        if self.program == PROGRAMS["ramp"] and not self.t_end > self.t_start:
            out.append(f"t_end must be > t_start ({self.t_start}) for a ramp, got {self.t_end}")
        if self.program == PROGRAMS["sine"] and not self.period > 0:
            out.append(f"period must be > 0, got {self.period}")
        return out

    def n(self, t: float) -> float:
        """Normal stress [Pa] at time t [s]."""
        p = self.program
        if p == PROGRAMS["ramp"]:
            if t <= self.t_start:
                return self.n0
            if t >= self.t_end:
                return self.n1
            s = (t - self.t_start) / (self.t_end - self.t_start)
            return self.n0 + (self.n1 - self.n0) * s
        if p == PROGRAMS["step"]:
            return self.n0 if t < self.t_start else self.n1
        if p == PROGRAMS["sine"]:
            return self.n0 + self.amplitude * math.sin(2.0 * math.pi * t / self.period + self.phase)
        return self.n0

    def breakpoints(self) -> tuple[float, ...]:
        """Times [s] where n(t) or its slope jumps."""
        p = self.program
        if p == PROGRAMS["ramp"]:
            return (self.t_start, self.t_end)
        if p == PROGRAMS["step"]:
            return (self.t_start,)
        return ()

    def extremes(self, t0: float, t1: float) -> tuple[float, float]:
        """Smallest and largest n [Pa] over [t0, t1] [s]."""
        p = self.program
        if p == PROGRAMS["sine"]:
            if t1 - t0 >= self.period:
                return self.n0 - abs(self.amplitude), self.n0 + abs(self.amplitude)
            values = [self.n(t0), self.n(t1)]
            # interior extremes of the sine: where 2 pi t / period + phase = pi/2 + k pi
            k0 = math.ceil(((2 * math.pi * t0 / self.period + self.phase) - math.pi / 2) / math.pi)
            k1 = math.floor(((2 * math.pi * t1 / self.period + self.phase) - math.pi / 2) / math.pi)
            for k in range(k0, k1 + 1):
                values.append(self.n((math.pi / 2 + k * math.pi - self.phase) * self.period / (2 * math.pi)))
            return min(values), max(values)
        values = [self.n(t0), self.n(t1)] + [self.n(b) for b in self.breakpoints() if t0 <= b <= t1]
        if p == PROGRAMS["step"] and t0 <= self.t_start <= t1:
            values.append(self.n0)
        return min(values), max(values)
