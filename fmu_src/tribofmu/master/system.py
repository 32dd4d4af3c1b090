"""The coupled system: Drive -> V, BlockSpring -> v, dv = V - v -> Friction -> F -> BlockSpring.

:class:`CoupledSystem` knows which variable of which slave carries what, and offers the few
primitives a coupling algorithm needs. It knows nothing of the physics inside the slaves:
no mass, no friction law. A scene without a Friction slave has F = 0; without a Drive,
X = V = 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol


class SlaveLike(Protocol):
    instance: str
    calls: int
    refs: dict[str, int]

    def set_reals(self, refs: list[int], values: list[float]) -> None: ...
    def get_reals(self, refs: list[int]) -> list[float]: ...
    def do_step(self, t: float, h: float) -> None: ...
    def save(self) -> Any: ...
    def restore(self, state: Any) -> None: ...
    def free_state(self, state: Any) -> None: ...


@dataclass
class Point:
    """The coupled state at a communication point; SI units, time in integer nanoseconds.

    F is the force the block felt at the end of the step that led here; F_start and
    F_rate describe the force over that step (F_start + F_rate s), for energy audits.
    mode: +1/-1 slipping with dv > 0 / < 0, 0 stuck (dv held at 0 by the coupling).
    """

    t_ns: int
    X: float = 0.0
    V: float = 0.0
    aX: float = 0.0
    x: float = 0.0
    v: float = 0.0
    a: float = 0.0
    F: float = 0.0
    f: float = 0.0
    F_start: float = 0.0
    F_rate: float = 0.0
    mode: int = 0
    est_error: float = 0.0  # the algorithm's own error estimate of this step (0 if none)
    event: float = 1.0  # fraction of the step at which a stuck contact broke away (1: none)
    ramped: bool = False  # the step ramped the force while slipping (else held or stuck)

    @property
    def dv(self) -> float:
        return self.V - self.v


@dataclass
class States:
    """Saved FMU states of every slave (opaque handles)."""

    handles: dict[str, Any] = field(default_factory=dict)


class CoupledSystem:
    """Slaves plus wiring. drive and friction may be None (the scene does not need them).

    conditions: constant inputs of the friction slave, e.g. ``{"n": -20.0, "T": 290.0}``.
    """

    def __init__(self, block: SlaveLike, drive: SlaveLike | None = None,
                 friction: SlaveLike | None = None, conditions: dict[str, float] | None = None):
        self.block, self.drive, self.friction = block, drive, friction
        self.slaves = [s for s in (drive, block, friction) if s is not None]
        b = block.refs
        self._block_in = [b["F"], b["F_rate"]]
        self._block_out = [b["x"], b["v"], b["a"]]
        if drive is not None:
            self._drive_out = [drive.refs[k] for k in ("X", "V", "a")]
        if friction is not None:
            fr = friction.refs
            self._dv = [fr["dv"]]
            self._friction_out = [fr["F"], fr["f"]]
            if conditions:
                friction.set_reals([fr[k] for k in conditions], list(conditions.values()))

    # -- outputs ----------------------------------------------------------------------
    def drive_outputs(self) -> tuple[float, float, float]:
        """X [m], V [m/s], drive acceleration [m/s^2] at the drive's current time."""
        if self.drive is None:
            return 0.0, 0.0, 0.0
        return tuple(self.drive.get_reals(self._drive_out))

    def block_outputs(self) -> tuple[float, float, float]:
        """x [m], v [m/s], a [m/s^2] of the block."""
        return tuple(self.block.get_reals(self._block_out))

    def friction_outputs(self, dv: float) -> tuple[float, float]:
        """F [N], f [1] with the friction's input set to dv [m/s] (no step)."""
        if self.friction is None:
            return 0.0, 0.0
        self.friction.set_reals(self._dv, [dv])
        return tuple(self.friction.get_reals(self._friction_out))

    # -- steps --------------------------------------------------------------------------
    def step_drive(self, t: float, h: float) -> tuple[float, float, float]:
        if self.drive is None:
            return 0.0, 0.0, 0.0
        self.drive.do_step(t, h)
        return self.drive_outputs()

    def step_block(self, F: float, F_rate: float, t: float, h: float) -> tuple[float, float, float]:
        """Step the block under the force F + F_rate s [N]; returns x, v, a at t + h."""
        self.block.set_reals(self._block_in, [F, F_rate])
        self.block.do_step(t, h)
        return self.block_outputs()

    def step_friction(self, dv: float, t: float, h: float) -> tuple[float, float]:
        """Step the friction with dv [m/s] held; returns F, f at t + h for that dv."""
        if self.friction is None:
            return 0.0, 0.0
        self.friction.set_reals(self._dv, [dv])
        self.friction.do_step(t, h)
        return tuple(self.friction.get_reals(self._friction_out))

    def finish_step(self, start: Point, end: Point, t: float, h: float) -> None:
        """Called once the coupled loop of a step t -> t + h [s] is solved (end holds its
        outcome, every slave of the loop stands at t + h): a place to step FMUs that only
        follow the loop (e.g. a heat balance fed by the friction power). Rolled back with
        the rest when the step is rejected. Nothing to do in the three-FMU system."""

    # -- rollback -----------------------------------------------------------------------
    def save(self, *slaves: SlaveLike) -> States:
        return States({s.instance: (s, s.save()) for s in (slaves or self.slaves) if s is not None})

    def restore(self, states: States) -> None:
        for slave, handle in states.handles.values():
            slave.restore(handle)

    def free(self, states: States) -> None:
        for slave, handle in states.handles.values():
            slave.free_state(handle)
        states.handles.clear()

    def start_point(self) -> Point:
        """The point at t = 0 with F = friction at the initial dv."""
        X, V, aX = self.drive_outputs()
        x, v, a = self.block_outputs()
        F, f = self.friction_outputs(V - v)
        return Point(0, X, V, aX, x, v, a, F, f, F_start=F)

    @property
    def calls(self) -> dict[str, int]:
        return {s.instance: s.calls for s in self.slaves}
