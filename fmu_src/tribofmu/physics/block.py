"""The lower block between two springs, eq. (3): ``M x'' + 2 K x = F``. Pure physics.

x [m], v [m/s], a [m/s^2]; F [N]; M, K (per spring) and the start: :class:`BlockParams`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .parameters import above, at_least, parameter, problems_of


@dataclass(frozen=True)
class BlockState:
    x: float = 0.0  # m
    v: float = 0.0  # m/s


@dataclass(frozen=True)
class BlockParams:
    """The lower block between its springs: the parameters of eq. (3) and its start."""

    M: float = parameter(0.6, "kg", "mass of the lower block", above(0), symbol="M")
    K: float = parameter(7000.0, "N/m", "stiffness of each of the two springs", at_least(0), symbol="K")
    x0: float = parameter(0.0, "m", "position at the start", symbol="x0")
    v0: float = parameter(0.0, "m/s", "velocity at the start", symbol="v0")

    def problems(self) -> list[str]:
        """Every parameter that is not finite or out of range, as ``name must be ..., got value``."""
        return problems_of(self)


def advance_block(state: BlockState, F: float, F_rate: float, h: float,
                  M: float, K: float) -> BlockState:
    """Exact solution of eq. (3) over a step h [s] for the force ``F + F_rate s``, s in [0, h].

    F [N] is the force at the start of the step and F_rate [N/s] its slope (0 holds F).
    The oscillator is linear, so any such force has a closed-form response: the block
    adds no discretisation error of its own, whatever the step.
    """
    x0, v0 = state.x, state.v
    if K == 0.0:  # a free mass
        x = x0 + v0 * h + F * h * h / (2 * M) + F_rate * h ** 3 / (6 * M)
        v = v0 + F * h / M + F_rate * h * h / (2 * M)
        return BlockState(x, v)
    k2 = 2.0 * K
    w0 = math.sqrt(k2 / M)
    # Particular solution (F + F_rate s)/2K; the rest oscillates freely at w0.
    y0 = x0 - F / k2
    dy0 = v0 - F_rate / k2
    c, s = math.cos(w0 * h), math.sin(w0 * h)
    y = y0 * c + dy0 / w0 * s
    dy = -y0 * w0 * s + dy0 * c
    return BlockState(y + (F + F_rate * h) / k2, dy + F_rate / k2)


def acceleration(state: BlockState, F: float, M: float, K: float) -> float:
    """x'' [m/s^2] under force F [N], from eq. (3)."""
    return (F - 2.0 * K * state.x) / M


def energy(state: BlockState, M: float, K: float) -> float:
    """Kinetic plus spring energy [J] (two springs of stiffness K)."""
    return 0.5 * M * state.v ** 2 + K * state.x ** 2
