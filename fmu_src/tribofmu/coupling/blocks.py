"""What saves real block steps inside and across implicit steps: the block's answers to the
forces a step tried, and the affine model of its response through them (:class:`BlockResponse`,
one per step), the block's slope the last step measured (:class:`BlockSlope`) and the last stick
ramp's Jacobian (:class:`StickJacobian`), kept from step to step by :class:`ReuseCache`.

The block's answer to the force is affine in it (a linear block: a mass on springs), and the
loop function's iterates differ only in the force: from two real steps under two forces of one
family (held, or ramped from the step's start force) the block's answer to a third is their
affine combination, without a step. The final force is always stepped for real and the model
checked against it (``settings.model_miss_tolerance``): a block that is not affine is stepped
for every iterate instead.

A slip step's first real block step plus the block's slope d(v, x, a)/dF_end [per N] from the
last step of the same family model its answer to the other forces the root tries: one real
trial instead of two. The slope of a linear block depends on the step alone; from another step
length it is scaled by h (v) and h^2 (x), the leading terms of a mass's response (h/M held,
h/2M ramped; h^2/2M, h^2/6M), exact as h -> 0: off by O(w2 h^2) of the slope, which the final
real step's check catches, and the step then models from its two real answers instead.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple


class BlockAnswer(NamedTuple):
    """The block's state at the step's end under the force F0 + rate s (F_end at the end)."""

    F_end: float  # N
    x: float  # m
    v: float  # m/s
    a: float  # m/s^2
    F0: float  # N
    rate: float  # N/s


class BlockSlope(NamedTuple):
    """The block's response to its end force over a step of ``h_ns`` [ns] held or ramped
    (``ramp``): d v/dF_end [m/s/N], d x/dF_end [m/N], d a/dF_end [m/s^2/N]."""

    h_ns: int
    ramp: bool
    v: float
    x: float
    a: float

    def scaled(self, h_ns: int) -> "BlockSlope":
        r = h_ns / self.h_ns
        return BlockSlope(h_ns, self.ramp, self.v * r, self.x * r * r, self.a)


class StickJacobian(NamedTuple):
    """A stuck step's block response over ``h_ns`` [ns] to the force F0 + rate s: d dv_end/dF0
    [m/s/N], d x_end/dF0 [m/N], d (d(dv)/dt)_end/dF0 [1/(kg)] (held), and d dv_end/d rate,
    d x_end/d rate [per N/s]. Affine for a linear block and a function of the step alone: the
    next stuck step of the same length models its second probe and starts the stick ramp's
    Newton from it instead of measuring it again (two real block steps fewer)."""

    h_ns: int
    d_F: float
    x_F: float
    slope_F: float
    d_r: float
    x_r: float


@dataclass
class ReuseCache:
    """The solves' own measurements that the next steps reuse to save FMU calls (not the
    coupling's state: a run continues within its tolerances without them): the block's slope
    last measured per family, held (False) and ramped (True), and the last stick ramp's
    Jacobian."""

    block_slopes: dict[bool, BlockSlope] = field(default_factory=dict)
    stick_jacobian: StickJacobian | None = None

    def export(self) -> dict:
        return {"block_slopes": [list(slope) for slope in self.block_slopes.values()],
                "stick_jacobian": list(self.stick_jacobian) if self.stick_jacobian is not None else None}

    @classmethod
    def from_export(cls, state: dict) -> "ReuseCache":
        slopes = [BlockSlope(*slope) for slope in state["block_slopes"]]
        jacobian = state["stick_jacobian"]
        return cls({slope.ramp: slope for slope in slopes},
                   StickJacobian(*jacobian) if jacobian is not None else None)


class BlockResponse:
    """The block's real answers within one step of ``h_ns`` [ns] and the affine model through
    them. ``slope``: the last step's measured slope (any family), the seed of a model from one
    real answer where it is of the step's family; ``same_force_rtol``: end forces this close
    are one force to the model."""

    def __init__(self, h_ns: int, ramp: bool, slope: BlockSlope | None, same_force_rtol: float):
        self.h_ns, self.slope, self.same_force_rtol = h_ns, slope, same_force_rtol
        self.samples: list[BlockAnswer] = []  # real answers under one family of forces
        self.affine = True  # off once the block turned out not affine in the force
        self.seed = self.seed_of_family(ramp)
        self.seed_allowed = False  # on while a slip root is sought (probes and stick forces step for real)
        self.last_seeded = False  # the latest modelled answer came from one real answer and the seed

    def seed_of_family(self, ramp: bool) -> BlockSlope | None:
        """The last step's block slope, scaled to this step, where it was of this family
        (held or ramped); else None."""
        slope = self.slope
        return slope.scaled(self.h_ns) if slope is not None and slope.ramp == ramp else None

    def hold(self) -> None:
        """The step goes on held: the seed is the held family's."""
        self.seed = self.seed_of_family(False)

    def model(self, F: float, F0: float, rate: float) -> BlockAnswer | None:
        """The block's answer to the end force F, affine in it through the last two real
        answers under distinct end forces (None: fewer than two, or the model is off)."""
        samples = self.samples
        if not self.affine or not samples:
            return None
        b = samples[-1]
        if abs(F - b.F_end) <= self.same_force_rtol * abs(b.F_end):
            # (a law whose force does not move with dv, as dry friction's in slip; a last bit
            # of round-off apart, a second real answer would make a model of round-off)
            self.last_seeded = False
            return b if F == b.F_end else b._replace(F_end=F)
        if len(samples) < 2:
            if self.seed is None or not self.seed_allowed:
                return None
            self.last_seeded = True
            dF, seed = F - b.F_end, self.seed
            return BlockAnswer(F, b.x + seed.x * dF, b.v + seed.v * dF, b.a + seed.a * dF, F0, rate)
        self.last_seeded = False
        spanning = self.spanning()
        if spanning is None:
            return None
        a, b = spanning
        w = (F - a.F_end) / (b.F_end - a.F_end)
        return BlockAnswer(F, a.x + w * (b.x - a.x), a.v + w * (b.v - a.v), a.a + w * (b.a - a.a), F0, rate)

    def spanning(self) -> tuple[BlockAnswer, BlockAnswer] | None:
        """The real answer farthest in force from the latest one, and the latest (near ones
        amplify the round-off of their difference); None with fewer than two or no spread."""
        samples = self.samples
        if len(samples) < 2:
            return None
        b = samples[-1]
        a = max(samples[:-1], key=lambda s: abs(s.F_end - b.F_end))
        if abs(a.F_end - b.F_end) <= self.same_force_rtol * abs(b.F_end):
            return None
        # More force, more speed: answers whose v differ by round-off (forces of 1e-13 N
        # that differ by 1e-16 N, at a reversal) or the wrong way are no slope (one read
        # -0.05 (m/s)/N, and the next step's modelled trials ran dv out to 1e206 m/s).
        dv = b.v - a.v
        if dv * (b.F_end - a.F_end) <= 0.0 or abs(dv) <= self.same_force_rtol * max(abs(a.v), abs(b.v)):
            return None
        return a, b

    def measured_slope(self, ramp: bool) -> BlockSlope | None:
        """The block's slope from the two real answers farthest apart in force, if any."""
        spanning = self.spanning()
        if spanning is None:
            return None
        a, b = spanning
        dF = b.F_end - a.F_end
        return BlockSlope(self.h_ns, ramp, (b.v - a.v) / dF, (b.x - a.x) / dF, (b.a - a.a) / dF)
