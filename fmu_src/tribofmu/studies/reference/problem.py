"""The problem the reference solver solves: a scenario's rig, drive, friction law, load program
and film heating, as plain functions of time and state (SI units), with the scales used for
absolute tolerances."""
from __future__ import annotations

import math

import numpy as np

from ...physics.block import BlockState, acceleration
from ...physics.drive import drive
from ...physics.friction import FrictionLaw
from ...physics.thermal import temperature_rate
from ...scene.scenario import Scenario

EPS = float(np.finfo(float).eps)
MAX_EVENTS = 100_000  # a scenario needing more is chattering, not physics
MAX_STALLS = 20  # consecutive zero-length segments before giving up


class Problem:
    """A scenario as the functions of t [s] and state the solvers need."""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self.M, self.K = scenario.block.M, scenario.block.K
        self.A, self.omega = scenario.drive.A, scenario.drive.omega
        self.period = scenario.drive.period
        self.driven = "Drive" in scenario.fmus
        self.has_friction = "Friction" in scenario.fmus
        self.law: FrictionLaw = scenario.friction.law()
        self.n, self.T = scenario.conditions.n, scenario.conditions.T
        self.program = scenario.load_program.program_() if "Load" in scenario.fmus else None
        self.thermal = scenario.thermal.params() if "Thermal" in scenario.fmus else None
        # Block's own angular frequency [rad/s] (0 for a free mass).
        self.omega0 = math.sqrt(2.0 * self.K / self.M)

    def n_at(self, t: float) -> float:
        """Normal stress [Pa] at t [s]."""
        return self.n if self.program is None else self.program.n(t)

    def breakpoints(self, t0: float, t1: float) -> list[float]:
        """Times in (t0, t1) [s] where n(t) is not smooth."""
        return sorted(b for b in (self.program.breakpoints() if self.program else ()) if t0 < b < t1)

    def heat_rate(self, T: float, power: float) -> float:
        """dT/dt [K/s] of the film under friction power [W]."""
        return temperature_rate(T, power, self.thermal)

    def drive(self, t: float) -> tuple[float, float, float]:
        """X [m], V [m/s], V' [m/s^2] of the upper block (all 0 without a Drive)."""
        if not self.driven:
            return 0.0, 0.0, 0.0
        return drive(t, self.A, self.omega)

    def stick_force(self, t: float, x: float) -> float:
        """Friction force [N] that makes the lower block follow the upper one (v = V):
        eq. (3) solved for F with x'' = V'."""
        _, V, V_dot = self.drive(t)
        spring_acc = acceleration(BlockState(x, V), 0.0, self.M, self.K)
        return self.M * (V_dot - spring_acc)

    def shortest_period(self) -> float:
        """The shorter of the drive's and the block's periods [s]."""
        return min(self.period, 2.0 * math.pi / self.omega0) if self.omega0 > 0 else self.period

    def output_drive(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        XV = np.array([self.drive(float(ti))[:2] for ti in t]).reshape(len(t), 2)
        return XV[:, 0], XV[:, 1]


def state_scale(p: Problem) -> np.ndarray:
    """Typical magnitudes of x [m], v [m/s], f [1], T [K] for absolute tolerances."""
    b = p.scenario.block
    x_scale = max(abs(p.A) if p.driven else 0.0, abs(b.x0),
                  abs(b.v0) / p.omega0 if p.omega0 > 0 else 0.0)
    v_scale = max(abs(p.A) * p.omega if p.driven else 0.0, abs(b.v0), abs(b.x0) * p.omega0)
    x_scale = x_scale or v_scale * p.period or 1.0
    v_scale = v_scale or x_scale / p.period
    T_scale = max(p.T, p.thermal.T_ambient if p.thermal else 0.0, 1.0)
    return np.array([x_scale, v_scale, 1.0, T_scale])
