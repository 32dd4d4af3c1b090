"""In-process slaves: the pure physics behind the small protocol the coupling algorithms use.

:class:`~tribofmu.coupling.system.CoupledSystem` and the algorithms of
:mod:`tribofmu.coupling.algorithms` talk to their slaves through
:class:`~tribofmu.coupling.system.SlaveLike` (value references, set/get reals, do_step,
save/restore). These classes present :mod:`tribofmu.physics` through that protocol without
any FMU: the TriboPair FMU runs the master's own implicit, error-controlled coupling on them
inside its ``doStep``. Each mirrors the FMU of the same physics (inputs, outputs, internal
state), and saving is a plain copy of its variables.

- :class:`BlockPart`: the block between two springs, as ``BlockSpring.fmu`` (inputs F [N],
  F_rate [N/s]; outputs x [m], v [m/s], a [m/s^2]).
- :class:`FrictionPart`: the friction law, as ``Friction.fmu`` (inputs dv [m/s], n [Pa],
  T [K]; outputs F [N], f [1]; internal state the previous step's dv, which the lubricant
  kinetics follow linearly over a step).
- :class:`FollowedDrive`: the upper block as a host gives it, V [m/s] and its acceleration
  a [m/s^2] at the start of the host's step: V(s) = V0 + a s, X integrated (outputs X, V, a).
"""
from __future__ import annotations

from ..physics.block import BlockState, acceleration, advance_block
from ..physics.friction import FrictionLaw
from ..physics.laws.boundary import KINETICS_TOL
from .system import CALL_KINDS


class InProcessSlave:
    """A slave whose variables are attributes of this object, named by ``variables``.

    ``state`` names the attributes a step may change or the coupling may set: what
    :meth:`save` copies and :meth:`restore` puts back (all immutable values)."""

    variables: tuple[str, ...] = ()
    state: tuple[str, ...] = ()
    states_are_copies = True  # (a save is a copy of a few values: kept at every point, CoupledSystem)

    def __init__(self, instance: str):
        self.instance = instance
        self.calls = 0
        self.calls_by_kind = dict.fromkeys(CALL_KINDS, 0)
        self.refs = {name: ref for ref, name in enumerate(self.variables)}

    def set_reals(self, refs: list[int], values: list[float]) -> None:
        self.calls += 1
        self.calls_by_kind["set"] += 1
        for ref, value in zip(refs, values):
            setattr(self, self.variables[ref], float(value))

    def get_reals(self, refs: list[int]) -> list[float]:
        self.calls += 1
        self.calls_by_kind["get"] += 1
        return [getattr(self, self.variables[ref]) for ref in refs]

    def do_step(self, t: float, h: float) -> None:
        self.calls += 1
        self.calls_by_kind["doStep"] += 1
        self.advance(t, h)

    def advance(self, t: float, h: float) -> None:
        raise NotImplementedError

    def save(self) -> tuple:
        self.calls_by_kind["save"] += 1
        return tuple(getattr(self, name) for name in self.state)

    def restore(self, saved: tuple) -> None:
        self.calls_by_kind["restore"] += 1
        for name, value in zip(self.state, saved):
            setattr(self, name, value)

    def free_state(self, saved: tuple) -> None:
        self.calls_by_kind["free"] += 1


class BlockPart(InProcessSlave):
    """The block of mass M [kg] between two springs of stiffness K [N/m], eq. (3), under the
    force F + F_rate s over a step (exact, :func:`~tribofmu.physics.block.advance_block`)."""

    variables = ("F", "F_rate", "x", "v", "a")
    state = variables

    def __init__(self, instance: str, M: float, K: float, x0: float, v0: float):
        super().__init__(instance)
        self.M, self.K = M, K
        self.F = self.F_rate = 0.0
        self.x, self.v = x0, v0
        # As BlockSpring.fmu at initialization: under its input F = 0.
        self.a = acceleration(BlockState(x0, v0), 0.0, M, K)

    def advance(self, t: float, h: float) -> None:
        state = advance_block(BlockState(self.x, self.v), self.F, self.F_rate, h, self.M, self.K)
        self.x, self.v = state.x, state.v
        self.a = acceleration(state, self.F + self.F_rate * h, self.M, self.K)


class FrictionPart(InProcessSlave):
    """The friction law at relative velocity dv [m/s], normal stress n [Pa], temperature
    T [K]; F [N] is evaluated on demand (direct feedthrough), f [1] is the state."""

    variables = ("dv", "n", "T", "F", "f", "F_mean")
    state = ("dv", "n", "T", "f", "F_mean", "dv_previous")

    def __init__(self, instance: str, law: FrictionLaw, f0: float, n: float, T: float,
                 kinetics_tol: float = KINETICS_TOL):
        super().__init__(instance)
        self.law, self.kinetics_tol = law, kinetics_tol
        self.dv, self.n, self.T = 0.0, n, T
        self.f, self.F_mean = f0, 0.0
        self.dv_previous = None  # m/s, the input of the last step (None: none yet)

    @property
    def F(self) -> float:
        return self.law.force(self.dv, self.n, self.f)

    def advance(self, t: float, h: float) -> None:
        self.f, self.F_mean = self.law.advance(self.f, self.dv, self.n, self.T, h, rtol=self.kinetics_tol,
                                               atol=self.kinetics_tol, dv_start=self.dv_previous)
        self.dv_previous = self.dv


class FollowedDrive(InProcessSlave):
    """The upper block as a host gives it: from :meth:`follow` (t0 [s], V0 [m/s], a [m/s^2])
    on, V = V0 + a (t - t0) and X = X(t0) + V0 (t - t0) + a (t - t0)^2 / 2 [m].

    X starts at 0: the coupling uses only how far the drive moves over a step."""

    variables = ("X", "V", "a")
    state = ("t0", "X0", "V0", "a", "s")

    def __init__(self, instance: str, t0: float = 0.0, V0: float = 0.0, a: float = 0.0):
        super().__init__(instance)
        self.t0, self.X0, self.V0, self.a, self.s = t0, 0.0, V0, a, 0.0

    def follow(self, t0: float, V0: float, a: float) -> None:
        """From t0 [s] on, follow V0 [m/s] with acceleration a [m/s^2]; X goes on from here."""
        self.X0 = self.X
        self.t0, self.V0, self.a, self.s = t0, V0, a, 0.0

    @property
    def X(self) -> float:
        return self.X0 + self.s * (self.V0 + 0.5 * self.a * self.s)

    @property
    def V(self) -> float:
        return self.V0 + self.a * self.s

    def advance(self, t: float, h: float) -> None:
        self.s = t + h - self.t0
