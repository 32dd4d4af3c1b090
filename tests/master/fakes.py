"""Fake slaves: the physics modules behind the master's slave interface, no FMI involved."""
from __future__ import annotations

import copy

from tribofmu.master.instance import FMUCallError
from tribofmu.physics import BlockState, DryLaw, FrictionLaw, acceleration, advance_block, drive


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
        self.refresh()  # (its outputs at the step's end, as an FMU's doStep leaves them)

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


class SwingingLoad(FakeSlave):
    """A Load whose n [Pa] swings between -15 and -75 at the drive's frequency (omega = 30)."""

    names = ("n",)

    def __init__(self):
        super().__init__("load", n=-45.0)

    def advance(self, t, h):
        import math

        self.values["n"] = -45.0 - 30.0 * math.sin(30.0 * (t + h))


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
        if self.law.has_state:
            self.kinetics_steps += 1
            v["f"] = self.law.advance_f(v["f"], v["dv"], v["n"], v["T"], h)


# -- in-process rigs for single implicit steps -------------------------------------------------
# The coupling's own in-process parts (the TriboPair FMU's) on a drive that moves at a constant
# acceleration: every quantity a step should produce has a closed form.

import math as _math

from tribofmu.coupling.contact import StepSettings, solve_step
from tribofmu.coupling.inprocess import BlockPart, FollowedDrive, FrictionPart
from tribofmu.coupling.interpolation import NS
from tribofmu.coupling.system import Contact, CoupledSystem, Point

N_STRESS = -20.0  # Pa: with S = 1 m^2 and mu = 0.5 the dry bound mu L is 10 N
MU_L = 10.0  # N
DRY_LAW = DryLaw(mu_friction=0.5, S=1.0)  # dry, mu L = 10 N at N_STRESS


def fig2_system(law: FrictionLaw | None = None, omega: float = 30.0, A: float = 2e-3, M: float = 0.6,
                K: float = 7000.0) -> CoupledSystem:
    """Fig. 2's rig on fakes (drive X = A cos(omega t), block M, K), dry unless told."""
    return CoupledSystem(FakeBlock(M=M, K=K), FakeDrive(A=A, omega=omega), FakeFriction(law or DRY_LAW),
                         {"n": N_STRESS, "T": 290.0})


def drive_scales(omega: float = 30.0, A: float = 2e-3):
    """The scales a scene gives the coupling: the drive's amplitude, velocity, period."""
    from tribofmu.coupling.algorithms import Scales

    return Scales(A, A * omega, 2 * _math.pi / omega)


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
             position_scale: float = 1e-3) -> StepSettings:
    return StepSettings(expected_gain, root_tol, delta, position_scale)


def solve(system: CoupledSystem, point: Point, h: float, ramp: bool = False,
          step_settings: StepSettings | None = None, block_slope=None, stick_jacobian=None, block_model=None,
          known_trials=None):
    """One implicit step of h [s] from point through the step's contract
    (:func:`~tribofmu.coupling.contact.solve_step`), set up as ImplicitCoupling.solve_step does:
    (the new point or RETRY_HELD, the step's report)."""
    h_ns = int(round(h * NS))
    drive_end = system.step_drive(point.t_ns / NS, h_ns / NS)
    saved = system.save(system.block, system.friction)
    return solve_step(step_settings or settings(), system, point, saved, h_ns, drive_end, ramp, block_slope,
                      stick_jacobian, block_model, known_trials)


def call_log(slave) -> list[str]:
    """The kinds of the calls made to an in-process part from now on, in order (set, get,
    doStep, save, restore, free)."""
    log = []
    for method, kind in (("set_reals", "set"), ("get_reals", "get"), ("do_step", "doStep"),
                         ("save", "save"), ("restore", "restore"), ("free_state", "free")):
        original = getattr(slave, method)

        def logged(*args, _original=original, _kind=kind):
            log.append(_kind)
            return _original(*args)

        setattr(slave, method, logged)
    return log


def start_state_reads(log: list[str]) -> int:
    """The reads of the friction's force at its state of the step's start (trials: a get with
    no doStep since the step began or since the last restore)."""
    reads, stepped = 0, False
    for kind in log:
        if kind == "doStep":
            stepped = True
        elif kind == "restore":
            stepped = False
        elif kind == "get" and not stepped:
            reads += 1
    return reads


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


# -- the exact dry-friction motion (fig. 2's rig), piecewise in closed form ----------------------

def exact_dry(t_eval, M=0.6, K=7000.0, A=2e-3, omega=30.0, bound=MU_L):
    """x [m], v [m/s] and stuck (bool) of the block under dry friction of bound mu L [N] and
    the drive X = A cos(w t), from rest at x = 0, at the sorted times t_eval [s].

    Slip: the oscillator under +-mu L in closed form (:func:`block_after`), until dv = 0;
    then stuck (v = V, x - X constant) while the force that keeps it so, M V' + 2K x, stays
    within mu L, else slipping on the other way. Events are found by a scan at 1/512 of the
    shorter period and brentq to 1e-15 s (:func:`exact_dry_segments`)."""
    import numpy as np

    X, segments = exact_dry_segments(float(t_eval[-1]), M, K, A, omega, bound)
    starts = np.array([s[0] for s in segments])
    index = np.clip(np.searchsorted(starts, t_eval, side="right") - 1, 0, len(segments) - 1)
    x_out, v_out, stuck = np.empty(len(t_eval)), np.empty(len(t_eval)), np.zeros(len(t_eval), bool)
    V = lambda t: -A * omega * _math.sin(omega * t)  # noqa: E731
    for i, (t, j) in enumerate(zip(t_eval, index)):
        t0, kind, a, b, s0 = segments[j]
        if kind == "stick":
            x_out[i], v_out[i], stuck[i] = a + X(t) - b, V(t), True
        else:
            x_out[i], v_out[i] = block_after(M, K, a, b, s0 * bound, 0.0, t - t0)
    return x_out, v_out, stuck


def exact_dry_segments(t_end, M=0.6, K=7000.0, A=2e-3, omega=30.0, bound=MU_L):
    """The drive's X(t), and the exact dry motion's phases up to t_end [s] (see
    :func:`exact_dry`): (t0 [s], "stick" or "slip", x0 [m], X0 or v0, slip direction) each; a
    phase's t0 is its event's exact time (a stick onset or a breakaway)."""
    from scipy.optimize import brentq

    def X(t):
        return A * _math.cos(omega * t)

    def V(t):
        return -A * omega * _math.sin(omega * t)

    def first_root(g, t0, t1, dt):
        a, ga = t0, g(t0)
        while a < t1:
            b = min(a + dt, t1)
            gb = g(b)
            if ga * gb <= 0.0 and gb != ga:
                return brentq(g, a, b, xtol=1e-15, rtol=1e-15)
            a, ga = b, gb
        return None

    dt = min(2 * _math.pi / omega, 2 * _math.pi / _math.sqrt(2 * K / M)) / 512
    segments = []  # (t0, kind, x0, v0, sign)
    t, x, v, sign = 0.0, 0.0, 0.0, 0
    kind = "stick"
    while t < t_end and len(segments) < 10_000:
        if kind == "stick":
            x0, X0 = x, X(t)
            need = lambda s: M * (-A * omega * omega * _math.cos(omega * s)) + 2 * K * (x0 + X(s) - X0)  # noqa: E731
            segments.append((t, "stick", x0, X0, 0))
            start = t + 1e-12 if abs(need(t)) >= bound else t  # leaving a stick at once
            t_next = first_root(lambda s: bound - abs(need(s)), start, t_end, dt)
            if t_next is None:
                break
            t, x, v, sign = t_next, x0 + X(t_next) - X0, V(t_next), (1 if need(t_next) > 0 else -1)
            kind = "slip"
        else:
            t0, x0, v0, s0 = t, x, v, sign
            segments.append((t0, "slip", x0, v0, s0))
            dv = lambda s: s0 * (V(s) - block_after(M, K, x0, v0, s0 * bound, 0.0, s - t0)[1])  # noqa: E731
            t_next = first_root(dv, t0 + 1e-12, t_end, dt)
            if t_next is None:
                break
            x = block_after(M, K, x0, v0, s0 * bound, 0.0, t_next - t0)[0]
            t, v = t_next, V(t_next)
            need = M * (-A * omega * omega * _math.cos(omega * t)) + 2 * K * x
            if abs(need) <= bound:
                kind = "stick"
            else:
                sign = 1 if need > 0 else -1
    return X, segments


def mixed_rig_estimate(overrides: dict, tol: float) -> tuple[float, float]:
    """Mixed (Stribeck) friction on fig. 2's rig (:func:`fig2_system`, mu_c 0.4, m 5, S 1;
    mu_s, v_s, delta and omega from overrides, keyed as the mixed_stribeck scene's) run by the
    adaptive coupling at per-step tol over 4 periods: the run's own estimate of its nRMS(v)
    over the last 1.5 periods, and its true nRMS(v) there against the independent reference
    (studies.reference on the mixed_stribeck scene with the same values)."""
    import numpy as np

    from tribofmu.coupling.algorithms import AdaptiveCoupling
    from tribofmu.coupling.window_error import WindowError
    from tribofmu.coupling.interpolation import sample
    from tribofmu.master import run
    from tribofmu.physics import MixedLaw
    from tribofmu.scene.library import resolve_scene
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import reference_solution

    law = MixedLaw(mu_friction=0.4, mu_static=overrides.get("friction.mu_static", 0.6),
                   v_stribeck=overrides.get("friction.v_stribeck", 0.01),
                   stribeck_exponent=overrides.get("friction.stribeck_exponent", 2.0), m=5.0, S=1.0)
    omega, periods = overrides.get("drive.omega", 30.0), 4
    scales = drive_scales(omega)
    out = run(fig2_system(law, omega=omega), AdaptiveCoupling(tol=tol), periods * scales.period, scales)
    window = ((periods - 1.5) * scales.period, periods * scales.period)
    scenario = load_scenario(resolve_scene("mixed_stribeck"),
                             {**overrides, "time.periods": periods, "time.window": [periods - 1.5, periods]})
    grid = np.linspace(*window, 3001)
    reference = reference_solution(scenario, t_eval=grid)
    assert reference.ok
    true = _math.sqrt(np.mean((sample(out.points, grid)["v"] - reference.v) ** 2)) / np.abs(reference.v).max()
    audit = WindowError(window)
    audit.add(out.points)
    return audit.nrms(), true
