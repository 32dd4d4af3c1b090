"""What saves real block steps inside and across implicit steps: the block's answers to the
forces a step tried, and the affine model of its response through them (:class:`BlockResponse`,
one per step), the block's slope the last step measured (:class:`BlockSlope`) and the last stick
ramp's Jacobian (:class:`StickJacobian`), kept from step to step by :class:`ReuseCache`.

The block's answer to the force is affine in it (a linear block: a mass on springs), and the
loop function's iterates differ only in the force: from two real steps under two forces of one
family (held, or ramped from the step's start force) the block's answer to a third is their
affine combination, without a step. The final force is always stepped for real and the model
checked against it (to the root tolerance): a block that is not affine is stepped
for every iterate instead.

A slip step's first real block step plus the block's slope d(v, x, a)/dF_end [per N] from the
last step of the same family model its answer to the other forces the root tries: one real
trial instead of two. The slope of a linear block depends on the step alone; from another step
length it is scaled by h (v) and h^2 (x), the leading terms of a mass's response (h/M held,
h/2M ramped; h^2/2M, h^2/6M), exact as h -> 0: off by O(w2 h^2) of the slope, which the final
real step's check catches, and the step then models from its two real answers instead.

Better still, a block that is a mass on springs (eq. (3), closed form: :class:`BlockModel`) is
identified from its real answers (:class:`BlockIdentification`, kept by the ReuseCache): its
answers to any force over any step are then predicted from the step's start
(:class:`BlockPrediction`) and the block steps once, at the step's answer, which checks the
prediction; one that misses sends the step back to be solved without it (the paths above).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import NamedTuple

# Below this |w2 h^2| the response integrals are summed as their Taylor series: the closed
# forms (h - sin(w h)/w)/w2 cancel to a relative 6 eps/|w2 h^2| (1.3e-13 at 1e-2), and the
# series through the z^4 term is off by z^5/10! there (3e-17): both far below the check of
# every prediction against a real step (to the root tolerance).
SERIES_BELOW = 1e-2


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


# (the last one kept: a step's tries ask for the same (w2, h) again and again)
@functools.lru_cache(maxsize=1)
def response_integrals(w2: float, h: float) -> tuple[float, float, float, float]:
    """The integrals of a step of h [s] of x'' = -w2 x + u(t) [w2 in 1/s^2] (any sign; 0 a free
    mass): (cos(w h), sin(w h)/w, (1 - cos(w h))/w2, (h - sin(w h)/w)/w2), the answer of x to
    x0, v0, a held u and a ramped u per unit (:meth:`BlockModel.answer`)."""
    z = w2 * h * h
    if abs(z) < SERIES_BELOW:
        # cos, sin/w, (1 - cos)/w2, (h - sin/w)/w2 through their z^4 terms
        c = 1.0 - z / 2.0 * (1.0 - z / 12.0 * (1.0 - z / 30.0 * (1.0 - z / 56.0)))
        s = h * (1.0 - z / 6.0 * (1.0 - z / 20.0 * (1.0 - z / 42.0 * (1.0 - z / 72.0))))
        q = h * h / 2.0 * (1.0 - z / 12.0 * (1.0 - z / 30.0 * (1.0 - z / 56.0 * (1.0 - z / 90.0))))
        r = h ** 3 / 6.0 * (1.0 - z / 20.0 * (1.0 - z / 42.0 * (1.0 - z / 72.0 * (1.0 - z / 110.0))))
        return c, s, q, r
    w = math.sqrt(abs(w2))
    if w2 > 0.0:
        c, s, half = math.cos(w * h), math.sin(w * h) / w, math.sin(0.5 * w * h)
        q = 2.0 * half * half / w2
    else:  # (a negative w2: the exponential branch of the same integrals)
        c, s, half = math.cosh(w * h), math.sinh(w * h) / w, math.sinh(0.5 * w * h)
        q = -2.0 * half * half / w2
    return c, s, q, (h - s) / w2


class BlockModel(NamedTuple):
    """A block that answers as ``x'' = inv_M F(t) - w2 x`` (a mass on springs, eq. (3): inv_M =
    1/M [1/kg], w2 = 2K/M [1/s^2]), learned from its real answers (:class:`BlockIdentification`)."""

    inv_M: float
    w2: float

    def answer(self, x0: float, v0: float, F0: float, rate: float, h: float) -> tuple[float, float, float]:
        """x [m], v [m/s], a [m/s^2] after a step of h [s] from x0, v0 under F0 + rate s [N],
        in closed form (the block's own answer to round-off, if it is such a block)."""
        c, s, q, r = response_integrals(self.w2, h)
        inv_M, w2 = self.inv_M, self.w2
        x = x0 * c + v0 * s + inv_M * (F0 * q + rate * r)
        v = v0 * c - w2 * x0 * s + inv_M * (F0 * s + rate * q)
        return x, v, inv_M * (F0 + rate * h) - w2 * x


def separation(p: tuple[float, float, float], q: tuple[float, float, float]) -> float:
    """How far apart two answers (F_end, x, a) are for :class:`BlockIdentification`: the sine
    of the angle between their (F_end, x), scale-free in [0, 1] (0: they determine nothing
    together)."""
    cross, size = p[0] * q[1] - q[0] * p[1], abs(p[0] * q[1]) + abs(q[0] * p[1])
    return abs(cross) / size if size > 0.0 else 0.0


@dataclass
class BlockIdentification:
    """The block's :class:`BlockModel` from its real answers: each answer (F_end, x, a) of a
    mass on springs satisfies a = inv_M F_end - w2 x exactly (eq. (3) at the step's end), so
    two with independent (F_end, x) give inv_M and w2 to round-off. It keeps the two answers
    farthest apart (:func:`separation`) of all it saw: the block does not change, and a stick
    following the drive (F proportional to x) adds no information. Every prediction is checked
    by a real step (contact.ImplicitStep); a miss forgets them (:meth:`forget`)."""

    answers: list[tuple[float, float, float]] = field(default_factory=list)

    def observe(self, F_end: float, x: float, a: float) -> None:
        new, kept = (F_end, x, a), self.answers
        if len(kept) < 2:
            if not kept or separation(kept[0], new) > 0.0:
                kept.append(new)
            return
        p, q = kept
        best = max(((p, q), (p, new), (q, new)), key=lambda pair: separation(*pair))
        self.answers = list(best)

    def forget(self) -> None:
        self.answers = []

    def model(self) -> BlockModel | None:
        """The block's model from the kept answers (None: fewer than two, or a mass that is not
        positive: no such block)."""
        if len(self.answers) < 2:
            return None
        (F_p, x_p, a_p), (F_q, x_q, a_q) = self.answers
        det = F_p * x_q - x_p * F_q
        if det == 0.0:
            return None
        inv_M = (a_p * x_q - x_p * a_q) / det
        w2 = (a_p * F_q - F_p * a_q) / det
        return BlockModel(inv_M, w2) if inv_M > 0.0 and math.isfinite(w2) else None


@dataclass
class ReuseCache:
    """The solves' own measurements that the next steps reuse to save FMU calls (not the
    coupling's state: a run continues within its tolerances without them): the block's slope
    last measured per family, held (False) and ramped (True), the last stick ramp's
    Jacobian, and the block's identification (its model)."""

    block_slopes: dict[bool, BlockSlope] = field(default_factory=dict)
    stick_jacobian: StickJacobian | None = None
    block: BlockIdentification = field(default_factory=BlockIdentification)
    # (t_ns, contact mode, d(dv)/dt [m/s^2]) at the last three points steps started from
    slopes: list[tuple[int, int, float]] = field(default_factory=list)
    # (t_ns and mode of the point a try started from, its slip root's miss of the extrapolated
    # dv per h^3 [m/s^4]): the last try whose dv was predicted along the slope's course
    guess_miss: tuple[int, int, float] | None = None

    def slope_fit(self, t_ns: int, mode: int, dv_slope: float) -> tuple[float, float, float] | None:
        """How d(dv)/dt went on over the last steps, for the next step's predicted dv: (c1 [m/s^3],
        c2 [m/s^4]) of the slope s(t) = dv_slope + c1 t + c2 t^2 (t from t_ns) through the
        slopes at the last three points steps started from (two: c2 = 0), the latest at t_ns
        [ns] in ``mode`` (the point the next step starts from; a try again from it keeps what
        it has), and the last try's miss per h^3 [m/s^4] (from this point or the one before, of
        this mode; else 0). Only points of that mode count; None where none went before (the
        first step, after a change of mode, or a run continued from an earlier point)."""
        slopes = self.slopes
        if slopes and slopes[-1][0] > t_ns:
            slopes.clear()
        if not slopes or slopes[-1][0] != t_ns:
            self.slopes = slopes = slopes[-2:] + [(t_ns, mode, dv_slope)]
        before = [(t / 1e9 - t_ns / 1e9, s) for t, m, s in slopes[:-1] if m == mode]
        rate = self.miss_rate(mode)
        if len(before) == 2 and all(m == mode for _, m, _ in slopes):
            (t1, s1), (t2, s2) = before
            det = t1 * t2 * (t2 - t1)
            if det != 0.0:  # (s - dv_slope) = c1 t + c2 t^2 through both
                d1, d2 = s1 - dv_slope, s2 - dv_slope
                return (d1 * t2 * t2 - d2 * t1 * t1) / det, (d2 * t1 - d1 * t2) / det, rate
        if before and slopes[-2][1] == mode:
            t1, s1 = before[-1]
            return (s1 - dv_slope) / t1, 0.0, rate
        return None

    def miss_rate(self, mode: int) -> float:
        """The last try's miss per h^3 [m/s^4] where it started from one of the last two points
        (this one or the one before) in ``mode``; else 0."""
        miss = self.guess_miss
        if miss is None or miss[1] != mode:
            return 0.0
        return miss[2] if any(miss[0] == t for t, m, _ in self.slopes[-2:] if m == mode) else 0.0

    def export(self) -> dict:
        return {"block_slopes": [list(slope) for slope in self.block_slopes.values()],
                "stick_jacobian": list(self.stick_jacobian) if self.stick_jacobian is not None else None,
                "block_answers": [list(answer) for answer in self.block.answers],
                "slopes": [list(slope) for slope in self.slopes],
                "guess_miss": list(self.guess_miss) if self.guess_miss is not None else None}

    @classmethod
    def from_export(cls, state: dict) -> "ReuseCache":
        slopes = [BlockSlope(*slope) for slope in state["block_slopes"]]
        jacobian = state["stick_jacobian"]
        # (a state exported before the block was identified has none: it is learned again)
        answers = [tuple(answer) for answer in state.get("block_answers", [])]
        return cls({slope.ramp: slope for slope in slopes},
                   StickJacobian(*jacobian) if jacobian is not None else None, BlockIdentification(answers),
                   [tuple(slope) for slope in state.get("slopes", [])],
                   tuple(state["guess_miss"]) if state.get("guess_miss") is not None else None)


class BlockResponse:
    """The block's real answers within one step of ``h_ns`` [ns] and the affine model through
    them. ``slope``: the last step's measured slope (any family), the seed of a model from one
    real answer where it is of the step's family; ``same_force_rtol``: end forces this close
    are one force to the model."""

    def __init__(self, h_ns: int, ramp: bool, slope: BlockSlope | None, same_force_rtol: float,
                 prediction: "BlockPrediction | None" = None):
        self.h_ns, self.slope, self.same_force_rtol = h_ns, slope, same_force_rtol
        self.samples: list[BlockAnswer] = []  # real answers under one family of forces
        self.affine = True  # off once the block turned out not affine in the force
        self.seed = self.seed_of_family(ramp)
        self.seed_allowed = False  # on while a slip root is sought (probes and stick forces step for real)
        self.last_seeded = False  # the latest modelled answer came from one real answer and the seed
        # the learned block's answers from the step's start (None: no model, or it missed)
        self.prediction = prediction
        self.last_predicted: BlockAnswer | None = None  # the latest answer the prediction gave
        self.prediction_missed = False  # a real step disagreed with the prediction
        self.ramp_moved = False  # a predicted answer had a ramp that moved (rate != 0)

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
        if self.affine and samples and abs(F - samples[-1].F_end) <= self.same_force_rtol * abs(samples[-1].F_end):
            # (a law whose force does not move with dv, as dry friction's in slip; a last bit
            # of round-off apart, a second real answer would make a model of round-off)
            b = samples[-1]
            self.last_seeded = False
            return b if F == b.F_end else b._replace(F_end=F)
        if self.prediction is not None:
            self.last_seeded = False
            self.ramp_moved = self.ramp_moved or rate != 0.0
            self.last_predicted = self.prediction.answer(F0, rate, F)
            return self.last_predicted
        if not self.affine or not samples:
            return None
        b = samples[-1]
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


class BlockPrediction(NamedTuple):
    """The learned block's answers over one step of h [s] from its state at the step's start
    (x0 [m], v0 [m/s]): no step of the block, checked by the one real step at the root."""

    model: BlockModel
    x0: float
    v0: float
    h: float

    def answer(self, F0: float, rate: float, F_end: float) -> BlockAnswer:
        """The answer to F0 + rate s [N] (F_end its end force as the step's family names it)."""
        x, v, a = self.model.answer(self.x0, self.v0, F0, rate, self.h)
        return BlockAnswer(F_end, x, v, a, F0, rate)
