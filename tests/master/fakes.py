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


# -- in-process rigs for single implicit steps -------------------------------------------------
# The coupling's own in-process parts (the TriboPair FMU's) on a drive that moves at a constant
# acceleration: every quantity a step should produce has a closed form.

import math as _math

from tribofmu.coupling.contact import ImplicitStep, StepSettings
from tribofmu.coupling.inprocess import BlockPart, FollowedDrive, FrictionPart
from tribofmu.coupling.interpolation import NS
from tribofmu.coupling.system import Contact, CoupledSystem, Point

N_STRESS = -20.0  # Pa: with S = 1 m^2 and mu = 0.5 the dry bound mu L is 10 N
MU_L = 10.0  # N


def rig(law: FrictionLaw, M: float = 1.0, K: float = 0.0, x0: float = 0.0, v0: float = 0.0,
        V0: float = 0.0, a_drive: float = 0.0) -> CoupledSystem:
    """Block (M [kg], K [N/m] per spring, x0 [m], v0 [m/s]) under a drive at V0 [m/s]
    accelerating at a_drive [m/s^2], coupled through the law (n = -20 Pa, T = 290 K)."""
    friction = FrictionPart("friction", law, 0.0, N_STRESS, 290.0)
    return CoupledSystem(BlockPart("block", M, K, x0, v0), FollowedDrive("drive", 0.0, V0, a_drive),
                         friction, {"n": N_STRESS, "T": 290.0})


def point_at(system: CoupledSystem, mode: Contact, F: float, F_rate: float = 0.0) -> Point:
    """The point at t = 0 of a rig whose block last felt F [N] (ramping at F_rate [N/s])."""
    block = system.block
    X, V, aX = system.drive_outputs()
    a = (F - 2.0 * block.K * block.x) / block.M
    return Point(0, X, V, aX, block.x, block.v, a, F, 0.0, F_start=F, F_rate=F_rate, mode=mode)


def settings(expected_gain: float = 0.0, root_tol: float = 1e-12, delta: float = 1e-10,
             position_scale: float = 1e-3, max_ramp_gain: float = 30.0) -> StepSettings:
    return StepSettings(expected_gain, max_ramp_gain, root_tol, delta, 60, position_scale)


def implicit_step(system: CoupledSystem, point: Point, h: float, ramp: bool = False,
                  step_settings: StepSettings | None = None) -> ImplicitStep:
    """One ImplicitStep of h [s] from point, set up as ImplicitCoupling.solve_step does."""
    h_ns = int(round(h * NS))
    drive_end = system.step_drive(point.t_ns / NS, h_ns / NS)
    saved = system.save(system.block, system.friction)
    return ImplicitStep(step_settings or settings(), system, point, saved, h_ns, drive_end, ramp)


def block_after(M: float, K: float, x0: float, v0: float, F: float, F_rate: float, t: float):
    """The block's x [m], v [m/s] after t [s] under F + F_rate s, by the textbook formulas
    (written out here, not taken from the physics module)."""
    if K == 0.0:
        return (x0 + v0 * t + F * t * t / (2 * M) + F_rate * t ** 3 / (6 * M),
                v0 + F * t / M + F_rate * t * t / (2 * M))
    w = _math.sqrt(2.0 * K / M)
    # particular solution (F + F_rate s) / 2K plus the free oscillation
    y0, dy0 = x0 - F / (2 * K), v0 - F_rate / (2 * K)
    y = y0 * _math.cos(w * t) + dy0 / w * _math.sin(w * t)
    dy = -y0 * w * _math.sin(w * t) + dy0 * _math.cos(w * t)
    return y + (F + F_rate * t) / (2 * K), dy + F_rate / (2 * K)
