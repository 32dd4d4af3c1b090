"""The coupled system: Drive -> V, BlockSpring -> v, dv = V - v -> Friction -> F -> BlockSpring,
and optionally Load -> n -> Friction and Friction power -> Thermal -> T -> Friction.

:class:`CoupledSystem` knows which variable of which slave carries what, and offers the few
primitives a coupling algorithm needs. It knows nothing of the physics inside the slaves:
no mass, no friction law. A scene without a Friction slave has F = 0; without a Drive,
X = V = 0.

Which loops are iterated and which are exchanged:

- dv -> F -> dv is stiff and fast (stick, a solid lubricant): the coupling algorithm solves
  it implicitly in every step, with rollback.
- Load -> n is a pure function of time, no loop: the Load slave is stepped with the drive,
  before the coupled loop, and the friction gets n at the step's end (what the implicit
  step evaluates the friction at).
- Friction power -> Thermal -> T -> Friction is a loop, but a slow one (the film's time
  constant C/G and its heating time are many steps long): it is exchanged explicitly. Once
  a step's dv -> F loop is solved (:meth:`CoupledSystem.finish_step`), the Thermal slave
  gets the exact mean friction power of that step, steps, and its T(t + h) is the
  friction's T over the next step. A rejected step rolls the Thermal back with the rest.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Protocol, Sequence

from .quadrature import step_dissipation  # the energy audit's own quadrature
from .step_log import StepLog


# The kinds of call a coupling step makes, as a slave's ``calls_by_kind`` counts them: get and
# set reals (fmi2GetReal/fmi3GetFloat64, ...SetReal/SetFloat64), doStep, and the FMU state's
# get ("save"), set ("restore") and free.
CALL_KINDS = ("get", "set", "doStep", "save", "restore", "free")


class SlaveLike(Protocol):
    instance: str
    calls: int
    calls_by_kind: dict[str, int]  # optional: CALL_KINDS -> count (test fakes may lack it)
    refs: dict[str, int]

    def set_reals(self, refs: Sequence[int], values: Sequence[float]) -> None: ...
    def get_reals(self, refs: Sequence[int]) -> list[float]: ...
    def do_step(self, t: float, h: float) -> None: ...
    def save(self) -> Any: ...
    def restore(self, state: Any) -> None: ...
    def free_state(self, state: Any) -> None: ...


class Contact(IntEnum):
    """A point's contact mode (``Point.mode``)."""

    BACKWARD = -1  # slipping with dv = V - v < 0
    STUCK = 0  # dv held at 0 by the coupling
    FORWARD = 1  # slipping with dv > 0
    UNKNOWN = 2  # the start, before any step has classified the contact

    slipping: bool  # FORWARD or BACKWARD
    stuck: bool  # STUCK
    direction: float  # the sign of dv while slipping (+1.0 forward, -1.0 backward), 0.0 otherwise

    def __init__(self, value: int):
        # each member's answers, made once: a coupling step asks them dozens of times (a
        # property, a Python call each, was 1 % of a fig2 run)
        self.slipping = value in (1, -1)
        self.stuck = value == 0
        self.direction = float(value) if self.slipping else 0.0


@dataclass
class Point:
    """The coupled state at a communication point; SI units, time in integer nanoseconds.

    F is the force the block felt at the end of the step that led here; F_start and
    F_rate describe the force over that step (F_start + F_rate s), for energy audits.
    mode: a :class:`Contact` (slipping forward or backward, stuck: dv held at 0 by the coupling,
    or unknown: the start, before any step classified the contact; a plain int given, as from
    a JSON snapshot, is read as the Contact it names).
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
    F_mean: float | None = None  # N, the friction's own mean force over the step (None: not reported)
    mode: Contact = Contact.UNKNOWN
    est_error: float = 0.0  # m/s, the algorithm's own estimate of this step's error in v (0: none)
    global_error: float = 0.0  # m/s, its estimate of the error in v carried to here (0: none)
    # m/s, its estimate of the error in v at the middle of the step to here beyond the line
    # between the carried errors at its ends (0: none; coupling/path_error.py)
    inside_error: float = 0.0
    # m/s^2, how far the motion's acceleration here lies beyond a, the block's own: a held slip
    # step in a stiff loop ends at its mean force (coupling/local_errors.py held_slope_lag)
    a_lag: float = 0.0
    event: float = 1.0  # fraction of the step at which the contact broke away or stuck (1: none)
    ramped: bool = False  # the step ramped the force while slipping (else held or stuck)
    T: float = math.nan  # K, the friction's temperature input at this point (Thermal's output)
    n: float = math.nan  # Pa, the friction's normal stress input at this point
    Q: float = 0.0  # J, heat the Thermal slave received up to this point (0 without one)

    def __post_init__(self):
        if type(self.mode) is not Contact:
            self.mode = Contact(self.mode)

    @property
    def dv(self) -> float:
        return self.V - self.v


@dataclass
class States:
    """Saved FMU states of every slave (opaque handles; a :class:`~.step_log.Logged` for a
    slave whose steps the system replays)."""

    handles: dict[str, Any] = field(default_factory=dict)


class CoupledSystem:
    """Slaves plus wiring. drive and friction may be None (the scene does not need them).

    conditions: constant inputs of the friction slave, e.g. ``{"n": -20.0, "T": 290.0}``.
    load: a slave whose output ``n`` [Pa] feeds the friction's input n (a function of time);
    thermal: a slave with inputs ``P`` [W] and outputs ``T`` [K], ``Q`` [J] whose T feeds the
    friction's input T and which is fed the friction power. Both need a friction slave.
    law: the friction law the friction slave runs, where known (a scene's, the pair's; None
    for a Friction FMU of unknown make): its slopes carry the run's error estimate
    (coupling/estimate.py), the coupling never steps it.
    """

    def __init__(self, block: SlaveLike, drive: SlaveLike | None = None,
                 friction: SlaveLike | None = None, conditions: dict[str, float] | None = None,
                 load: SlaveLike | None = None, thermal: SlaveLike | None = None, law=None):
        if friction is None and (load is not None or thermal is not None):
            raise ValueError("a load or thermal slave feeds the friction: give a friction slave")
        self.block, self.drive, self.friction = block, drive, friction
        self.law = law
        self.load, self.thermal = load, thermal
        self.slaves = [s for s in (drive, load, block, friction, thermal) if s is not None]
        # (each call's value references a tuple, built once: a slave may key what it prepared
        # for them on it)
        b = block.refs
        self._block_in = (b["F"], b["F_rate"])
        self._block_out = (b["x"], b["v"], b["a"])
        if drive is not None:
            self._drive_out = tuple(drive.refs[k] for k in ("X", "V", "a"))
        if friction is not None:
            self._wire_friction(conditions or {})
        if load is not None:
            self._wire_load()
        if thermal is not None:
            self._wire_thermal()
        self._logs = self._step_logs()

    def _step_logs(self) -> dict[int, StepLog]:
        """The saved states of the slaves only the system steps (all but the friction), replayed
        from checkpoints (StepLog), by id(slave); none for a slave whose states are plain copies
        (an optional ``states_are_copies``: cheaper saved than replayed)."""
        stepped = ((self.drive, None), (self.block, self._block_in), (self.load, None),
                   (self.thermal, getattr(self, "_thermal_P", None)))
        return {id(s): StepLog(s, inputs) for s, inputs in stepped
                if s is not None and not getattr(s, "states_are_copies", False)}

    def _logged_step(self, slave: SlaveLike, values, t: float, h: float) -> None:
        """The slave was stepped by h from t [s] with these input values (set just before)."""
        log = self._logs.get(id(slave))
        if log is not None:
            log.stepped(values, t, h)

    def _wire_friction(self, conditions: dict[str, float]) -> None:
        """The friction's references, and its constant inputs (those no load or thermal slave feeds)."""
        friction = self.friction
        fr = friction.refs
        self._dv = (fr["dv"],)
        # F, f, and the mean force over the step where the friction reports it (no output read twice)
        self._friction_force = (fr["F"], fr["f"])
        self._friction_out = self._friction_force + ((fr["F_mean"],) if "F_mean" in fr else ())
        fed = {"n"} if self.load is not None else set()
        fed |= {"T"} if self.thermal is not None else set()
        held = {k: v for k, v in conditions.items() if k not in fed}
        if held:
            friction.set_reals([fr[k] for k in held], list(held.values()))
        self._friction_n, self._friction_T = (fr["n"],), (fr["T"],)
        self._n = friction.get_reals(self._friction_n)[0]
        self._T = friction.get_reals(self._friction_T)[0]

    def _wire_load(self) -> None:
        """The load's n feeds the friction's n from the start."""
        self._load_n = (self.load.refs["n"],)
        self._n = self.load.get_reals(self._load_n)[0]
        self.friction.set_reals(self._friction_n, [self._n])

    def _wire_thermal(self) -> None:
        """The thermal slave's T feeds the friction's T from the start."""
        thermal = self.thermal
        self._thermal_P = (thermal.refs["P"],)
        self._thermal_out = (thermal.refs["T"], thermal.refs["Q"])
        self._T, self._Q = thermal.get_reals(self._thermal_out)
        self.friction.set_reals(self._friction_T, [self._T])

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
        return tuple(self.friction.get_reals(self._friction_force))

    @property
    def friction_n(self) -> float:
        """[Pa] the normal stress the friction's input holds now (a step's n(t + h) once
        :meth:`step_drive` stepped the load)."""
        return self._n

    # -- steps --------------------------------------------------------------------------
    def step_drive(self, t: float, h: float) -> tuple[float, float, float]:
        """Step the drive (and the load program) to t + h [s]; the friction's n becomes the
        load's n(t + h). Returns X, V, drive acceleration at t + h."""
        if self.load is not None:
            self.load.do_step(t, h)
            self._logged_step(self.load, None, t, h)
            self._n = self.load.get_reals(self._load_n)[0]
            self.friction.set_reals(self._friction_n, [self._n])
        if self.drive is None:
            return 0.0, 0.0, 0.0
        self.drive.do_step(t, h)
        self._logged_step(self.drive, None, t, h)
        return self.drive_outputs()

    def step_block(self, F: float, F_rate: float, t: float, h: float) -> tuple[float, float, float]:
        """Step the block under the force F + F_rate s [N]; returns x, v, a at t + h."""
        self.block.set_reals(self._block_in, [F, F_rate])
        self.block.do_step(t, h)
        self._logged_step(self.block, (F, F_rate), t, h)
        return self.block_outputs()

    def step_friction(self, dv: float, t: float, h: float,
                      set_input: bool = True) -> tuple[float, float, float | None]:
        """Step the friction to dv [m/s] at t + h; returns F, f at t + h and the mean force
        [N] over the step (None where the friction does not report it). set_input=False: the
        friction holds dv as its input already (the caller's last trial set it)."""
        if self.friction is None:
            return 0.0, 0.0, None
        if set_input:
            self.friction.set_reals(self._dv, [dv])
        self.friction.do_step(t, h)
        F, f, *F_mean = self.friction.get_reals(self._friction_out)
        return F, f, (F_mean[0] if F_mean else None)

    def finish_step(self, start: Point, end: Point, t: float, h: float) -> None:
        """Called once the coupled loop of a step t -> t + h [s] is solved (end holds its
        outcome, every slave of the loop stands at t + h): a place to step FMUs that only
        follow the loop (e.g. a heat balance fed by the friction power). Rolled back with
        the rest when the step is rejected.

        With a thermal slave: its power input is the step's mean friction power, the exact
        integral of F (V - v) over the step as the energy audit computes it (so the heat it
        receives is the audit's dissipation times q), then it steps, and its T(t + h) is
        the friction's T for the next step. end gets T, n and Q."""
        if self.friction is None:
            return
        if self.thermal is not None:
            power = step_dissipation(start, end) / h
            self.thermal.set_reals(self._thermal_P, [power])
            self.thermal.do_step(t, h)
            self._logged_step(self.thermal, (power,), t, h)
            self._T, self._Q = self.thermal.get_reals(self._thermal_out)
            self.friction.set_reals(self._friction_T, [self._T])
        end.T, end.n, end.Q = self._T, self._n, self._Q if self.thermal is not None else 0.0

    # -- rollback -----------------------------------------------------------------------
    def save(self, *slaves: SlaveLike) -> States:
        return States({s.instance: (s, self._save(s)) for s in (slaves or self.slaves) if s is not None})

    def _save(self, slave: SlaveLike) -> Any:
        log = self._logs.get(id(slave))
        return slave.save() if log is None else log.save()

    def save_over(self, states: States) -> States:
        """The slaves' current states in place of ``states`` (saved by this system before):
        overwritten where a slave can (an optional ``save_into(handle) -> bool``: one call),
        else freed and saved anew (a logged slave's: :meth:`.StepLog.save_over`). Returns
        ``states``."""
        for name, (slave, handle) in list(states.handles.items()):
            log = self._logs.get(id(slave))
            if log is not None:
                states.handles[name] = (slave, log.save_over(handle))
                continue
            save_into = getattr(slave, "save_into", None)
            if save_into is None or not save_into(handle):
                slave.free_state(handle)
                states.handles[name] = (slave, slave.save())
        return states

    def _restore(self, slave: SlaveLike, handle: Any) -> None:
        log = self._logs.get(id(slave))
        if log is None:
            slave.restore(handle)
        else:
            log.restore(handle)

    def loop_states(self, states: States) -> States:
        """The part of states an implicit step restores between its evaluations: the block's
        and the friction's (the drive, load and thermal stay where the step put them)."""
        loop = (self.block, self.friction)
        return States({name: held for name, held in states.handles.items() if held[0] in loop})

    def restore(self, states: States) -> None:
        for slave, handle in states.handles.values():
            self._restore(slave, handle)

    def restore_in_step(self, held) -> None:
        """Inside a step, the load (if any) stepped to its end already: the given (slave, state
        handle) pairs, the block's and the friction's, back at the step's start, the friction's
        n again the load's n(t + h) the step solves at (a restored state holds the start's)."""
        for slave, handle in held:
            self._restore(slave, handle)
            if slave is self.friction and self.load is not None:
                slave.set_reals(self._friction_n, [self._n])

    def free(self, states: States) -> None:
        for slave, handle in states.handles.values():
            log = self._logs.get(id(slave))
            if log is None:
                slave.free_state(handle)
            else:
                log.free(handle)
        states.handles.clear()

    def start_point(self) -> Point:
        """The point at t = 0 with F = friction at the initial dv."""
        X, V, aX = self.drive_outputs()
        x, v, a = self.block_outputs()
        F, f = self.friction_outputs(V - v)
        if self.friction is None:
            return Point(0, X, V, aX, x, v, a, F, f, F_start=F, mode=Contact.UNKNOWN)
        return Point(0, X, V, aX, x, v, a, F, f, F_start=F, mode=Contact.UNKNOWN, T=self._T, n=self._n,
                     Q=self._Q if self.thermal is not None else 0.0)

    @property
    def calls(self) -> dict[str, int]:
        return {s.instance: s.calls for s in self.slaves}

    @property
    def calls_by_kind(self) -> dict[str, int]:
        """Every slave's hot-path calls summed by kind (:data:`CALL_KINDS`); a slave that does
        not count by kind adds nothing."""
        total = dict.fromkeys(CALL_KINDS, 0)
        for slave in self.slaves:
            for kind, count in getattr(slave, "calls_by_kind", {}).items():
                total[kind] += count
        return total

    @property
    def calls_by_instance_and_kind(self) -> dict[str, dict[str, int]]:
        return {s.instance: dict(getattr(s, "calls_by_kind", {})) for s in self.slaves}
