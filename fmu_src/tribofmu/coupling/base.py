"""What every coupling algorithm is: the interface (:class:`CouplingAlgorithm`), its counters,
the scene's scales and the accepted motion's magnitudes, and the fixed-step explicit couplings
(``jacobi``, ``gauss-seidel``: every slave steps once per step, with the others' outputs from
the step's start or the freshest ones)."""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

from .contact import slip_mode
from .interpolation import NS
from .system import CoupledSystem, Point


@dataclass
class Magnitudes:
    """The largest |v| [m/s], |x| [m], |F| [N], |f| [1] of the accepted points so far: what a
    step's error is measured against. Updated only when a step is accepted (:meth:`accept`)."""

    v: float = 0.0
    x: float = 0.0
    F: float = 0.0
    f: float = 0.0

    def accept(self, point: Point) -> None:
        self.v, self.x, self.F = max(self.v, abs(point.v)), max(self.x, abs(point.x)), max(self.F, abs(point.F))
        self.f = max(self.f, abs(point.f))


@dataclass
class Counters:
    steps: int = 0  # accepted communication steps
    rejected: int = 0  # steps rolled back for their error and retried smaller
    landed: int = 0  # steps rolled back to end where the contact broke away or stuck inside them
    iterations: int = 0  # evaluations of the coupling loop (implicit solves)
    forced: int = 0  # steps accepted at the minimum step although above tolerance
    stick_steps: int = 0
    # the sum over accepted steps of p/(p + 1), p the step's order (local error ~ h^(p + 1)):
    # under error-per-step control each step's share of the run's error falls as the per-step
    # tolerance to that power (ErrorControlledCoupling.convergence_order)
    convergence_sum: float = 0.0


class CouplingAlgorithm(ABC):
    """Advance a :class:`CoupledSystem` from a point; the algorithm chooses its step."""

    name = "abstract"

    def __init__(self, step: float | None = None, tol: float | None = None):
        self.counters = Counters()
        self.step_ns = max(2, int(round((step or self.default_step) * NS)))
        self.tol = tol if tol is not None else self.default_tol

    default_step = 1e-4  # s
    default_tol = 1e-3

    def prepare(self, system: CoupledSystem, scales: "Scales") -> None:
        """Called once before the first step with the problem's scales."""
        self.scales = scales

    def observe(self, points: list[Point]) -> None:
        """The points the run accepted from the last :meth:`advance`, in order (an error-controlled
        coupling may steer its tolerance by them: coupling/controlled.py); nothing here."""

    @abstractmethod
    def advance(self, system: CoupledSystem, point: Point, stop_ns: int) -> list[Point]:
        """Advance from point toward stop_ns; returns the accepted points (may be empty)."""

    def finish(self, system: CoupledSystem) -> None:
        """Called once after the last step (or a failure): release what the algorithm holds."""

    def next_step(self, point: Point, stop_ns: int) -> int:
        return min(self.step_ns, stop_ns - point.t_ns)


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes, for tolerances: position [m], velocity [m/s], period [s]."""

    position: float
    velocity: float
    period: float


class ExplicitCoupling(CouplingAlgorithm):
    """Fixed-step explicit coupling; ``sequential`` picks Gauss-Seidel over Jacobi."""

    def __init__(self, step=None, tol=None, sequential: bool = False):
        super().__init__(step, tol)
        self.sequential = sequential
        self.name = "gauss-seidel" if sequential else "jacobi"

    def advance(self, system, point, stop_ns):
        h_ns = self.next_step(point, stop_ns)
        t, h = point.t_ns / NS, h_ns / NS
        F_start = point.F
        X, V, aX = system.step_drive(t, h)
        x, v, a = system.step_block(F_start, 0.0, t, h)
        # Jacobi gives the friction the relative velocity of the step's start; Gauss-Seidel
        # the one the drive and block just produced.
        dv_in = (V - v) if self.sequential else point.dv
        system.step_friction(dv_in, t, h)
        F, f = system.friction_outputs(V - v)  # direct feedthrough at the new point
        self.counters.steps += 1
        new = Point(point.t_ns + h_ns, X, V, aX, x, v, a, F, f, F_start=F_start, mode=slip_mode(V - v, 0.0))
        system.finish_step(point, new, t, h)
        return [new]
