"""The saved states of a slave the system alone steps (coupling/step_log.py): checkpoints every
m saves, m the whole number that costs the fewest calls a point, and replays that save nothing."""
from __future__ import annotations

from tribofmu.coupling.step_log import StepLog


class CountingSlave:
    """A slave whose state is the list of steps made; every call counted."""

    def __init__(self):
        self.state, self.calls = [], {"save": 0, "restore": 0, "doStep": 0, "set": 0, "free": 0}

    def save(self):
        self.calls["save"] += 1
        return list(self.state)

    def restore(self, state):
        self.calls["restore"] += 1
        self.state = list(state)

    def do_step(self, t, h):
        self.calls["doStep"] += 1
        self.state.append((t, h))

    def set_reals(self, refs, values):
        self.calls["set"] += 1

    def free_state(self, state):
        self.calls["free"] += 1


def calls_a_point(m: int, r: float, c: int) -> float:
    return 1.0 / m + r * (1.0 + c * (m - 1) / 2.0)


def test_the_checkpoint_interval_is_the_whole_number_of_fewest_calls_a_point():
    for inputs, c in ((None, 1), ((7,), 2)):
        for restores, saves in ((0, 0), (5, 40), (517, 3719), (7, 3202), (40, 40), (90, 10)):
            log = StepLog(CountingSlave(), inputs)
            log.restores, log.saves = restores, saves
            r = (restores + 1) / (saves + 1)
            best = min(range(1, 200), key=lambda m: calls_a_point(m, r, c))
            assert log._interval() == best, (inputs, restores, saves)


def test_a_restore_replays_to_the_same_state_and_saves_nothing():
    slave = CountingSlave()
    log = StepLog(slave, None)
    log.restores, log.saves = 1, 400  # (few restores so far: a checkpoint every several saves)
    states = []
    for k in range(6):
        states.append((log.save(), list(slave.state)))
        slave.do_step(float(k), 1.0)
        log.stepped(None, float(k), 1.0)
    interval = log._interval()
    assert interval > 2 and slave.calls["save"] == 1 + (5 // interval)
    logged, expected = states[4]
    before = dict(slave.calls)
    log.restore(logged)
    assert slave.state == expected
    assert slave.calls["save"] == before["save"] and slave.calls["restore"] == before["restore"] + 1
    assert slave.calls["doStep"] - before["doStep"] == len(logged.steps) > 0
    log.restore(logged)  # (it stands there already: no call)
    assert slave.calls["restore"] == before["restore"] + 1
    slave.do_step(9.0, 1.0)
    log.stepped(None, 9.0, 1.0)
    log.restore(logged)  # (a second restore of the same state replays again)
    assert slave.state == expected and slave.calls["restore"] == before["restore"] + 2
