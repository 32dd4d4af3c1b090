"""The block and the friction law coupled inside one model, stepped by a host's steps.

:class:`PairModel` is what the TriboPair FMU runs in its ``doStep``: the master's own
:class:`~tribofmu.coupling.embedded.EmbeddedCoupling` (implicit steps of the dv -> F -> dv
loop with exact stick, an embedded error estimate, rollback) on the in-process parts of
:mod:`tribofmu.coupling.inprocess`, advanced over each host step [t, t + h] in integer
nanoseconds with as many internal steps as the tolerance needs. Between host steps it keeps
the current point and the adaptive step size; :meth:`PairModel.snapshot` and
:meth:`PairModel.from_snapshot` carry all of it but the parameters (the parts' variables,
the point, the algorithm's :meth:`~AdaptiveCoupling.export_state`), so a host's get/set FMU
state continues exactly.

The drive is the host's: V [m/s] and its acceleration a [m/s^2] at the start of each host
step, followed linearly within it (a host that gives no acceleration holds V).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

from ..physics.friction import FrictionLaw
from ..physics.laws.boundary import KINETICS_TOL
from .base import Scales
from .embedded import EmbeddedCoupling as AdaptiveCoupling
from .inprocess import BlockPart, FollowedDrive, FrictionPart
from .interpolation import NS
from .system import CoupledSystem, Point


@dataclass(frozen=True)
class PairParameters:
    """M [kg], K [N/m] per spring, x0 [m], v0 [m/s]; the friction law and f0 [1]; tol [1] of
    the internal coupling (as ``tribofmu simulate --tol``); kinetics_tol [1] the lubricant
    kinetics' own (as the Friction FMU's)."""

    M: float
    K: float
    x0: float
    v0: float
    law: FrictionLaw
    f0: float
    tol: float
    kinetics_tol: float = KINETICS_TOL  # [1] of the lubricant kinetics, as the Friction FMU's


class PairModel:
    """Block, friction and the host's drive, coupled by :class:`AdaptiveCoupling`."""

    # Internal steps (accepted or rejected) one host step may take before it is refused
    # (about a second of work): a host step of hours would otherwise run for hours.
    MAX_ADVANCES = 50_000

    def __init__(self, parameters: PairParameters, t_start: float, V: float, a_drive: float,
                 n: float, T: float):
        self._build(parameters, t_start, V, a_drive, n, T)
        self.algorithm = AdaptiveCoupling(tol=parameters.tol)
        self.algorithm.prepare(self.system, self._scales(V, a_drive, 1e-9))
        self.point = replace(self.system.start_point(), t_ns=round(t_start * NS))

    def _build(self, p: PairParameters, t_start: float, V: float, a_drive: float, n: float,
               T: float) -> None:
        self.parameters = p
        self.drive = FollowedDrive("drive", t_start, V, a_drive)
        self.block = BlockPart("block", p.M, p.K, p.x0, p.v0)
        self.friction = FrictionPart("friction", p.law, p.f0, n, T, p.kinetics_tol)
        self.system = CoupledSystem(self.block, self.drive, self.friction, conditions={"n": n, "T": T}, law=p.law)
        # The block's own period sets the coupling's shortest and longest steps (1e-7 of it and
        # all of it, settings.LIMITS; the host's step bounds them too). A free mass has none: 1 s.
        self.period = 2.0 * math.pi * math.sqrt(p.M / (2.0 * p.K)) if p.K > 0 else 1.0

    def _scales(self, V: float, a_drive: float, velocity: float) -> Scales:
        """The motion's scales for the coupling's "zero" velocity and position tolerances:
        the largest |V|, |v| seen and the drive's acceleration over the block's period."""
        w = 2.0 * math.pi / self.period
        velocity = max(velocity, abs(V), abs(a_drive) / w, abs(self.block.v))
        position = max(velocity / w, abs(self.block.x), 1e-12)
        return Scales(position, velocity, self.period)

    def step(self, t: float, h: float, V: float, a_drive: float, n: float, T: float) -> Point:
        """Advance from host time t [s] by h [s] with the drive at V [m/s], accelerating at
        a_drive [m/s^2] from t on, and the friction's inputs n [Pa], T [K] held; returns the
        point at t + h. Internal time is the host's rounded to the nanosecond: a host step
        that does not reach the next nanosecond leaves the state as it is."""
        t_ns = round(t * NS)
        stop_ns = round((t + h) * NS)
        self.drive.follow(t_ns / NS, V, a_drive)
        self.friction.set_reals([self.friction.refs["n"], self.friction.refs["T"]], [n, T])
        algorithm = self.algorithm
        # (AdaptiveCoupling floors its error scale at a millionth of these: from complete rest,
        # a host giving V = a_drive = 0 over its first step, the motion so far is round-off)
        algorithm.scales = self._scales(V, a_drive, algorithm.scales.velocity)
        point = replace(self.point, t_ns=t_ns, X=self.drive.X, V=V, aX=a_drive)
        for _ in range(self.MAX_ADVANCES):
            if point.t_ns >= stop_ns:
                break
            new = algorithm.advance(self.system, point, stop_ns)
            if new:
                point = new[-1]
        else:
            raise ArithmeticError(
                f"the internal coupling took {self.MAX_ADVANCES} steps and reached only "
                f"t = {point.t_ns / NS:.9g} s of this host step [{t:.9g}, {t + h:.9g}] s; "
                f"use a shorter communication step (or a looser tol)")
        self.point = point
        return point

    # -- state ---------------------------------------------------------------------------
    def snapshot(self) -> dict:
        """Everything the model needs to continue, besides its parameters, as plain values
        (JSON-able: pythonfmu serializes FMU states as JSON; floats round-trip exactly)."""
        return {"drive": list(self.drive.save()), "block": list(self.block.save()),
                "friction": list(self.friction.save()), "point": asdict(self.point),
                "algorithm": self.algorithm.export_state()}

    @classmethod
    def from_snapshot(cls, parameters: PairParameters, snapshot: dict) -> "PairModel":
        """The model of :meth:`snapshot`, with these parameters."""
        friction = snapshot["friction"]
        model = cls.__new__(cls)
        model._build(parameters, 0.0, 0.0, 0.0, friction[1], friction[2])
        model.drive.restore(snapshot["drive"])
        model.block.restore(snapshot["block"])
        model.friction.restore(friction)
        model.point = Point(**snapshot["point"])
        state = snapshot["algorithm"]
        model.algorithm = AdaptiveCoupling(tol=parameters.tol)
        model.algorithm.prepare(model.system, Scales(*state["scales"]))
        model.algorithm.import_state(state)
        return model
