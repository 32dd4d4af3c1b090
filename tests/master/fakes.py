"""Fake slaves: the physics modules behind the master's slave interface, no FMI involved."""
from __future__ import annotations

import copy

from tribofmu.master.instance import FMUCallError
from tribofmu.physics import BlockState, FrictionLaw, acceleration, advance_block, drive


class FakeSlave:
    """Variables by value reference, copyable state, call counting, scripted failures."""

    names: tuple[str, ...] = ()

    def __init__(self, instance: str, **values):
        self.instance = instance
        self.calls = 0
        self.refs = {n: i for i, n in enumerate(self.names)}
        self.values = {n: 0.0 for n in self.names}
        self.values.update(values)
        self.time = 0.0
        self.fail_at: float | None = None  # discard every step starting at this time [s]
        self.live_states = 0

    def set_reals(self, refs, values):
        self.calls += 1
        for r, v in zip(refs, values):
            self.values[self.names[r]] = v

    def get_reals(self, refs):
        self.calls += 1
        self.refresh()
        return [self.values[self.names[r]] for r in refs]

    def do_step(self, t, h):
        self.calls += 1
        if self.fail_at is not None and t + h > self.fail_at:
            raise FMUCallError(self.instance, "fmi2DoStep", 2, [f"{self.instance}: scripted failure"])
        self.advance(t, h)
        self.time = t + h

    def save(self):
        self.calls += 1
        self.live_states += 1
        return copy.deepcopy((self.values, self.time, self.extra()))

    def restore(self, state):
        self.calls += 1
        values, self.time, extra = copy.deepcopy(state)
        self.values = values
        self.set_extra(extra)

    def free_state(self, state):
        self.calls += 1
        self.live_states -= 1

    def refresh(self):
        pass

    def advance(self, t, h):
        pass

    def extra(self):
        return None

    def set_extra(self, extra):
        pass


class FakeDrive(FakeSlave):
    names = ("X", "V", "a")

    def __init__(self, A=2e-3, omega=30.0):
        super().__init__("drive")
        self.A, self.omega = A, omega

    def refresh(self):
        X, V, a = drive(self.time, self.A, self.omega)
        self.values.update(X=X, V=V, a=a)


class FakeBlock(FakeSlave):
    names = ("F", "F_rate", "V", "x", "v", "a", "dv")

    def __init__(self, M=0.6, K=7000.0, x0=0.0):
        super().__init__("block", x=x0)
        self.M, self.K = M, K

    def advance(self, t, h):
        s = advance_block(BlockState(self.values["x"], self.values["v"]), self.values["F"],
                          self.values["F_rate"], h, self.M, self.K)
        self.values.update(x=s.x, v=s.v,
                           a=acceleration(s, self.values["F"] + self.values["F_rate"] * h, self.M, self.K))


class FakeFriction(FakeSlave):
    names = ("dv", "n", "T", "F", "f")

    def __init__(self, law: FrictionLaw):
        super().__init__("friction", n=-20.0, T=290.0)
        self.law = law
        self.kinetics_steps = 0

    def refresh(self):
        v = self.values
        v["F"] = self.law.force(v["dv"], v["n"], v["f"])

    def advance(self, t, h):
        v = self.values
        if self.law.regime == 2:
            self.kinetics_steps += 1
            v["f"] = self.law.advance_f(v["f"], v["dv"], v["n"], v["T"], h)
