"""The two evaluations one implicit step makes, each with what it knows of where its slave
stands: the friction's answer to a relative velocity (:class:`FrictionSide`: a trial at its
start state, or a step that integrates its state) and the block's answer to a force
(:class:`BlockSide`: a real step, or the affine model of :class:`~.blocks.BlockResponse`).
Both roll their slave back to the step's start from the states the step was given."""
from __future__ import annotations

from typing import NamedTuple

from .blocks import BlockAnswer, BlockResponse
from .system import CoupledSystem


class FrictionAnswer(NamedTuple):
    """The friction's latest answer: at the relative velocity dv [m/s], the force F [N], the
    state f [1], and its mean force over the step [N] (None for a trial, which does not step)."""

    dv: float
    F: float
    f: float
    F_mean: float | None


class KnownTrials:
    """The friction's trial answers at the probes' relative velocities (+-delta: its force
    bounds at rest), kept from step to step while the friction stands where they were read:
    the same normal stress n and temperature T in, the same state f out. A trial reads the
    friction's output at its state (no step), and the friction's force at a given dv is a
    function of n, T and its state f (the Friction FMU's contract, models/Friction.py: F =
    law.force(dv, n, f)): the same trial gives the same answer, to the last bit, so a step
    that finds it here reads it from here (dry friction's stuck steps: both probes). Nothing
    of the run's state: a run without it gives the same answers."""

    def __init__(self):
        self.where: tuple | None = None  # (n [Pa], T [K], f [1]) the answers were read at
        self.answers: dict[float, tuple[float, float]] = {}  # dv [m/s] -> (F [N], f [1])

    def at(self, where: tuple) -> dict[float, tuple[float, float]]:
        """The answers read where the friction stands now (``where`` = (n, T, f)): kept while
        it stays there, a fresh (empty) table from a step that moved it (a NaN never matches)."""
        if where != self.where:
            self.where, self.answers = where, {}
        return self.answers


class FrictionSide:
    """The friction over the step from t over h [s]; ``saved``: its (slave, state handle) pairs
    at the step's start; ``known``: trial answers (dv -> F, f) at its start state read before
    (:class:`KnownTrials`), where the step may reuse and add those at the velocities
    ``remembered`` (the probes')."""

    def __init__(self, system: CoupledSystem, saved: list, t: float, h: float,
                 known: dict[float, tuple[float, float]] | None = None, remembered: tuple[float, ...] = ()):
        self.system, self.saved, self.t, self.h = system, saved, t, h
        self.known, self.remembered = known, remembered
        self.last: FrictionAnswer | None = None  # its latest answer
        # its latest step's answer (its state is at the step's end); None: not stepped since
        # the step's start
        self.stepped: FrictionAnswer | None = None
        self.input: float | None = None  # [m/s] the dv it holds as its input (None: unknown)

    def at(self, dv: float) -> tuple[float, float]:
        """A trial: F [N], f [1] at the relative velocity dv [m/s] with the friction's state
        where it stands (its output's direct feedthrough; no step)."""
        known = self.known if self.stepped is None else None  # (at the start state only)
        if known is not None and dv in known:
            F, f = known[dv]  # (read at this state before: no call; the input stays as it is)
        else:
            F, f = self.system.friction_outputs(dv)
            self.input = dv
            if known is not None and dv in self.remembered:
                known[dv] = (F, f)
        self.last = FrictionAnswer(dv, F, f, None)
        return F, f

    def step(self, dv: float) -> None:
        """The friction's step to dv [m/s] at the step's end (from the step's start again if
        it stepped before): its state (the lubricant's f) moves along the way."""
        stepped = self.stepped
        if stepped is not None:
            if stepped.dv == dv:
                self.last = stepped  # (it stands there already)
                return
            self.restore()
        # (the last trial's dv is still the friction's input: no second set)
        F, f, F_mean = self.system.step_friction(dv, self.t, self.h, set_input=dv != self.input)
        self.input = dv
        self.last = self.stepped = FrictionAnswer(dv, F, f, F_mean)

    def restore(self) -> None:
        """The friction back at the step's start: restored where it stepped (with the step's
        inputs, :meth:`~.system.CoupledSystem.restore_in_step`); a friction that only read
        trials holds its start state already but for its dv input, which from here is unknown
        (each evaluation sets it)."""
        if self.stepped is not None:
            self.system.restore_in_step(self.saved)
        self.stepped = self.input = None


class BlockSide:
    """The block over the step from t over h [s] with the drive at V [m/s] at its end, its
    force held at its end value or (``ramp``) ramped from F_start [N]; ``saved``: its (slave,
    state handle) pairs at the step's start; ``response``: its answers and their model;
    ``report``: where the block's velocity per unit impulse is reported (a StepReport)."""

    def __init__(self, system: CoupledSystem, saved: list, t: float, h: float, V: float, F_start: float,
                 ramp: bool, response: BlockResponse, report):
        self.system, self.saved, self.t, self.h, self.V, self.F_start = system, saved, t, h, V, F_start
        self.ramp, self.response, self.report = ramp, response, report
        self.last: BlockAnswer | None = None  # its latest answer (real or modelled)
        self.real: BlockAnswer | None = None  # its latest real step (the FMU stands there)

    def hold(self) -> None:
        """From here the force is held at its end value."""
        self.ramp = False
        self.response.hold()

    def restore(self) -> None:
        """The block back at the step's start where it stepped (a modelled answer moves nothing)."""
        if self.real is not None:
            self.system.restore_in_step(self.saved)

    def at(self, F0: float, rate: float) -> tuple[float, float]:
        """The block's relative velocity and position after the step under F0 + rate s
        (a real step of the block)."""
        last, h = self.real, self.h
        if last is not None:
            self.restore()
        x, v, a = self.system.step_block(F0, rate, self.t, h)
        if last is not None:
            # the block's velocity per unit impulse (1/M for a lone mass), from the secant
            d_impulse = (F0 - last.F0 + 0.5 * (rate - last.rate) * h) * h
            if d_impulse != 0.0 and v != last.v:
                self.report.velocity_per_impulse = abs((v - last.v) / d_impulse)
        self.last = self.real = BlockAnswer(F0 + rate * h, x, v, a, F0, rate)
        self.report.block_answers.append((F0 + rate * h, x, a))  # (what identifies the block)
        return self.V - v, x

    def ramp_at(self, F0: float, rate: float) -> tuple[float, float]:
        """The block's relative velocity and position after the step under F0 + rate s: the
        prediction's where there is one (no step; :meth:`real_at` checks the last), else a real
        step (:meth:`at`)."""
        prediction = self.response.prediction
        if prediction is None:
            return self.at(F0, rate)
        self.last = self.response.last_predicted = prediction.answer(F0, rate, F0 + rate * self.h)
        return self.V - self.last.v, self.last.x

    def under(self, F: float, real: bool = False) -> float:
        """The block's relative velocity after the step whose force ends at F: modelled from
        real steps under other end forces where it can be (:class:`~.blocks.BlockResponse`),
        else (or with real=True) stepped."""
        F0, rate = (self.F_start, (F - self.F_start) / self.h) if self.ramp else (F, 0.0)
        if not real:
            modelled = self.response.model(F, F0, rate)
            if modelled is not None:
                self.last = modelled
                return self.V - modelled.v
        dv = self.at(F0, rate)[0]
        # (the end force as the family names it: F0 + rate h can differ from F in the last bit)
        self.last = self.real = self.real._replace(F_end=F)
        self.response.samples.append(self.real)
        return dv

    def real_at(self, F: float, miss_tolerance: float) -> bool:
        """Leave the block really stepped under the end force F (if its latest answer was
        modelled, or under another force); False if the model had missed the real answer by
        more than miss_tolerance [m/s] (the model is then switched off)."""
        real, last, response = self.real, self.last, self.response
        if real is not None and real.F_end == F and last is real:
            return True
        modelled = last if last is not None and last.F_end == F else None
        seeded = modelled is not None and response.last_seeded
        predicted = modelled is not None and modelled is response.last_predicted
        if predicted:  # (the force program it predicted for: a stick ramp's is of no family)
            self.at(modelled.F0, modelled.rate)
            self.last = self.real = self.real._replace(F_end=F)
            response.samples.append(self.real)
        else:
            self.under(F, real=True)
        if modelled is not None and abs(modelled.v - self.real.v) > miss_tolerance:
            if predicted:  # the learned block is not this block (the step is solved again without it)
                response.prediction, response.prediction_missed = None, True
            else:
                # a seeded model is off by its slope's scaling: the two real answers model exactly
                # from here; a model from two real answers that misses: the block is not affine
                response.affine = seeded
            return False
        return True
