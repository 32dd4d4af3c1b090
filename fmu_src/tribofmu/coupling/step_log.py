"""The saved states of a slave that only the coupled system steps, kept as a checkpoint and
the steps made since, which a restore replays (:class:`StepLog`)."""
from __future__ import annotations

from typing import Any


class Logged:
    """A saved state of a slave whose steps the system logs (:class:`StepLog`): a checkpoint
    (a real FMU state) and the steps made from it to this state."""

    __slots__ = ("checkpoint", "steps")

    def __init__(self, checkpoint: Any, steps: tuple):
        self.checkpoint, self.steps = checkpoint, steps


class StepLog:
    """The saved states of a slave that only the system steps (all but the friction), each a
    checkpoint (a real FMU state) and the steps made from it since (its input values, t, h),
    which a restore replays: the same calls from the same state, so the same state to the bit
    (an FMU is deterministic). A slave the coupling saves at every point and restores at few
    (a block whose answers are predicted steps once a point, after its step is kept; the drive
    of a rejected try) needs a real save every m points only. A checkpoint every m saves costs
    1/m of a save a point; a restore costs one call and replays (m - 1)/2 steps on average, c
    calls each (a doStep, and a set where the steps set inputs). With r the slave's restores
    per save so far (1 before any save: a real save at every point), the calls a point, 1/m +
    r (1 + c (m - 1)/2), are fewest near m = sqrt(2 / (r c)) (:meth:`_interval`). A replayed
    state is not saved again: that save would spare a second restore of the same state its
    replay, which costs no more than the save and comes at one restore in several.

    ``inputs``: the references of the inputs its steps set (None: its steps set none)."""

    def __init__(self, slave, inputs: tuple[int, ...] | None):
        self.slave, self.inputs = slave, inputs
        self.checkpoint: Any = None  # the real state the slave's present state was stepped from
        self.steps: tuple = ()  # the steps made from it since: (input values, t [s], h [s])
        self.users: dict[int, list] = {}  # id(checkpoint) -> [checkpoint, the saved states on it]
        self.saves = self.restores = 0
        self.calls_per_replayed_step = 1 if inputs is None else 2  # (c: a doStep, and a set of its inputs)

    def stepped(self, values, t: float, h: float) -> None:
        """The slave was stepped by h from t with these input values (set just before)."""
        self.steps += ((values, t, h),)

    def save(self) -> Logged:
        self.saves += 1
        if self.checkpoint is None or len(self.steps) >= self._interval():
            self._new_checkpoint()
        self.users[id(self.checkpoint)][1] += 1
        return Logged(self.checkpoint, self.steps)

    def _interval(self) -> int:
        """m, the saves a checkpoint: of the whole numbers either side of sqrt(2 / (r c)), the one
        whose calls a point, 1/m + r (1 + c (m - 1)/2), are fewer."""
        r, c = (self.restores + 1) / (self.saves + 1), self.calls_per_replayed_step
        low = max(1, int((2.0 / (r * c)) ** 0.5))
        return min((low, low + 1), key=lambda m: 1.0 / m + r * (1.0 + c * (m - 1) / 2.0))

    def _new_checkpoint(self) -> None:
        """A real save of the present state, the checkpoint from here: into the last one where
        no saved state stands on it and the slave can (``save_into``: one call), else new (the
        last one then freed where none stands on it)."""
        old = self.checkpoint
        unused = old is not None and self.users[id(old)][1] == 0
        save_into = getattr(self.slave, "save_into", None)
        if unused and save_into is not None and save_into(old):
            self.steps = ()
            return
        self.checkpoint, self.steps = self.slave.save(), ()
        self.users[id(self.checkpoint)] = [self.checkpoint, 0]
        if unused:
            self._free_checkpoint(old)

    def _free_checkpoint(self, checkpoint: Any) -> None:
        del self.users[id(checkpoint)]
        if checkpoint is self.checkpoint:
            self.checkpoint, self.steps = None, ()
        self.slave.free_state(checkpoint)

    def restore(self, logged: Logged) -> None:
        """The slave back in the state saved as ``logged``: no call where it stands there."""
        if logged.checkpoint is self.checkpoint and logged.steps == self.steps:
            return
        self.restores += 1
        self.slave.restore(logged.checkpoint)
        for values, t, h in logged.steps:
            if self.inputs is not None:
                self.slave.set_reals(self.inputs, values)
            self.slave.do_step(t, h)
        self.checkpoint, self.steps = logged.checkpoint, logged.steps

    def save_over(self, logged: Logged) -> Logged:
        """:meth:`save`, in place of ``logged`` (freed; its checkpoint may be saved into)."""
        checkpoint = logged.checkpoint
        self.users[id(checkpoint)][1] -= 1
        new = self.save()
        entry = self.users.get(id(checkpoint))
        if entry is not None and entry[1] == 0 and checkpoint is not self.checkpoint:
            self._free_checkpoint(checkpoint)
        return new

    def free(self, logged: Logged) -> None:
        """A saved state no longer held; its checkpoint freed where none stands on it any more."""
        entry = self.users[id(logged.checkpoint)]
        entry[1] -= 1
        if entry[1] == 0:
            self._free_checkpoint(logged.checkpoint)
