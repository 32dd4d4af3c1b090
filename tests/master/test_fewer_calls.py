"""What saves the friction's calls (coupling/evaluations.py KnownTrials, the slip's predicted dv in
coupling/contact.py) through the step's contract: the same answer, fewer calls. Rigs as in
test_contact.py (fakes: in-process parts, exact closed forms)."""
from dataclasses import replace

import pytest

from tribofmu.coupling.blocks import BlockModel, ReuseCache
from tribofmu.coupling.evaluations import KnownTrials
from tribofmu.coupling.system import Contact
from tribofmu.physics import FluidLaw

from fakes import DRY_LAW, call_log, point_at, rig, settings, solve


def stuck_rig():
    K, x0, V0 = 2000.0, 1e-3, 0.05
    system = rig(DRY_LAW, M=1.0, K=K, x0=x0, v0=V0, V0=V0)
    return system, point_at(system, Contact.STUCK, 2 * K * x0, F_rate=2 * K * V0)


def test_a_stuck_step_where_the_friction_stood_before_reads_no_probe_again():
    """Dry friction stuck twice from where it stood (same n, T and state f): the second step
    takes its force bounds at +-delta from the first's trials, and steps the friction once
    (set, doStep, get) to the same answer; a step at another normal stress reads them again."""
    trials = KnownTrials()
    answers, logs = [], []
    for where in ((-20.0, 290.0, 0.0), (-20.0, 290.0, 0.0), (-30.0, 290.0, 0.0)):
        system, start = stuck_rig()
        log = call_log(system.friction)
        new, report = solve(system, start, 1e-3, block_model=BlockModel(1.0, 4000.0), known_trials=trials.at(where))
        answers.append((new.x, new.v, new.F, new.F_rate, report.bounds))
        logs.append([kind for kind in log if kind != "save"])  # (the test's own save of the start)
    first, again, elsewhere = logs
    assert first.count("get") == 3 and again == ["set", "doStep", "get"] and elsewhere == first
    assert answers[1] == answers[0]


def test_the_slip_s_predicted_dv_follows_its_curvature_into_one_friction_step():
    """A free mass dragged through F = m dv by a drive at constant speed: dv relaxes as
    exp(-m t / M), its slope -m dv / M and curvature (m/M)^2 dv at the start. A ramped step
    whose dv is extrapolated along both lands within the root's tolerance of the root at its
    first friction step (before: along the slope alone, a second step)."""
    m, M, dv0, h, root_tol = 50.0, 1.0, 0.1, 1e-3, 1e-5
    counts, roots = {}, {}
    for gain in (h * m / M,):
        for curvature in (None, (m / M) ** 2 * dv0):
            system = rig(FluidLaw(m=m, gamma=0.0), M=M, v0=0.0, V0=dv0)
            start = point_at(system, Contact.FORWARD, m * dv0)
            log = call_log(system.friction)
            step = replace(settings(gain, root_tol=root_tol), stepped_trials=True,
                           dv_slope_fit=None if curvature is None else (curvature, 0.0, 0.0))
            new, _ = solve(system, start, h, ramp=True, step_settings=step, block_model=BlockModel(1.0 / M, 0.0))
            assert new.ramped and new.mode == Contact.FORWARD
            counts[gain, curvature is not None] = log.count("doStep"), log.count("get")
            roots[gain, curvature is not None] = new.dv
    assert counts[h * m / M, True] == (1, 1)
    assert counts[h * m / M, False][0] == 2
    assert max(roots.values()) - min(roots.values()) <= 2 * root_tol


def test_the_slope_s_course_is_fitted_through_the_last_points_of_one_mode():
    """d(dv)/dt's course s(t) = s0 + c1 t + c2 t^2 through the slopes at the last three points
    steps started from (here s = -5 + 1000 t + 2e5 t^2 [t in s]): a line through two, none for
    the first, none across a change of mode, and a try again from the same point keeps it."""
    cache = ReuseCache()
    assert cache.slope_fit(0, 1, -5.0) is None
    assert cache.slope_fit(1_000_000, 1, -3.8) == pytest.approx((1200.0, 0.0, 0.0))
    assert cache.slope_fit(2_000_000, 1, -2.2) == pytest.approx((1800.0, 2e5, 0.0))
    assert cache.slope_fit(2_000_000, 1, -2.2) == pytest.approx((1800.0, 2e5, 0.0))  # (the same point again)
    assert cache.slope_fit(2_500_000, 0, 0.0) is None  # (it stuck)
    assert cache.slope_fit(3_000_000, 1, 1.0) is None  # (a slip again, from a stuck point)
    assert cache.slope_fit(500_000, 1, 1.0) is None  # (continued from an earlier point)


def test_the_last_step_s_miss_of_its_extrapolation_lands_the_next_in_one_friction_step():
    """The same rig, two ramped steps, each extrapolated along the slope's exact course: the
    root misses that by the trapezoidal rule's own local error (~(m h / M)^3 dv / 12), which
    the first step measures (per h^3); the second, told it, lands at its first friction step
    (untold, a second), within the root's tolerance of the same root."""
    m, M, dv0, h, root_tol = 50.0, 1.0, 0.1, 1e-3, 2e-7
    k = m / M

    def step_settings(dv, miss_rate):  # (s(t) = -k dv e^(-k t): c1 = k^2 dv, c2 = -k^3 dv / 2)
        return replace(settings(h * k, root_tol=root_tol), stepped_trials=True,
                       dv_slope_fit=(k * k * dv, -k ** 3 * dv / 2, miss_rate))

    system = rig(FluidLaw(m=m, gamma=0.0), M=M, v0=0.0, V0=dv0)
    first, report = solve(system, point_at(system, Contact.FORWARD, m * dv0), h, ramp=True,
                          step_settings=step_settings(dv0, 0.0), block_model=BlockModel(1.0 / M, 0.0))
    assert report.guess_miss == pytest.approx(-(k ** 3) * dv0 / 12, rel=0.2)
    steps, roots = [], []
    for miss_rate in (0.0, report.guess_miss):
        system = rig(FluidLaw(m=m, gamma=0.0), M=M, v0=first.v, V0=dv0)
        log = call_log(system.friction)
        new, _ = solve(system, point_at(system, Contact.FORWARD, m * first.dv), h, ramp=True,
                       step_settings=step_settings(first.dv, miss_rate), block_model=BlockModel(1.0 / M, 0.0))
        steps.append(log.count("doStep"))
        roots.append(new.dv)
    assert steps == [2, 1]
    assert abs(roots[1] - roots[0]) <= 2 * root_tol


def test_the_miss_carries_to_the_next_point_of_its_mode_only():
    """The last try's miss per h^3 comes with the slope's course from its own point and the
    next one, of its mode; not across a change of mode, nor two points on."""
    cache = ReuseCache()
    cache.slope_fit(0, 1, -5.0)
    cache.slope_fit(1_000_000, 1, -3.8)
    cache.guess_miss = (1_000_000, 1, -900.0)
    assert cache.slope_fit(1_000_000, 1, -3.8)[2] == -900.0  # (a try again from its point)
    assert cache.slope_fit(2_000_000, 1, -2.2)[2] == -900.0  # (the next point)
    assert cache.slope_fit(3_000_000, 1, -1.0)[2] == 0.0  # (two points on)
    cache.guess_miss = (3_000_000, 1, -800.0)
    assert cache.slope_fit(4_000_000, -1, 1.0) is None  # (another mode)


def test_a_ramped_try_rolled_back_to_be_solved_held_restores_no_friction_that_only_read_trials():
    """A ramped step that meets a reversal is rolled back and solved again held (RETRY_HELD): its
    friction only read trials at its start state (set dv, get F), which move no state, so the
    held solve starts from it unrestored (every evaluation sets dv again) and gives the held
    step's answer in the held step's own friction calls (the try's trial is kept, KnownTrials;
    before: a restore more); the block, which stepped, is restored."""
    from test_contact import reversing_rig

    from tribofmu.coupling.algorithms import Scales
    from tribofmu.coupling.implicit import ImplicitCoupling

    answers, friction_calls, block_restores = {}, {}, {}
    for ramp_allowed in (True, False):
        system, start = reversing_rig()
        coupling = ImplicitCoupling(step=1e-3, tol=1e-3)
        coupling.prepare(system, Scales(1e-3, 1e-2, 0.1))
        friction_log, block_log = call_log(system.friction), call_log(system.block)
        new = coupling.solve_step(system, start, 1_000_000, ramp_allowed=ramp_allowed)
        answers[ramp_allowed] = (new.ramped, new.mode, new.x, new.v, new.F, new.f)
        friction_calls[ramp_allowed], block_restores[ramp_allowed] = friction_log, block_log.count("restore")
    assert answers[True] == answers[False] and answers[True][1] == Contact.BACKWARD
    assert "restore" not in friction_calls[True] and "doStep" in friction_calls[True]
    assert friction_calls[True] == friction_calls[False]
    assert block_restores[True] == block_restores[False] + 1


def test_the_block_the_drive_and_the_load_saved_at_checkpoints_replay_to_the_same_run_in_fewer_calls():
    """The drive, the block and the load are stepped by the system only, so a state of theirs is a
    checkpoint and the steps made since, which a restore replays (coupling/step_log.py): the
    same run to the bit (an FMU is deterministic) as with a real save of each at every point,
    the block saved at fewer than half the points (its predicted answers step it once a point,
    after the step is kept, and it is restored where a stick ramp steps it in the solve), all
    slaves' calls fewer; every state freed."""
    from fakes import FakeBlock, FakeDrive, FakeFriction, SwingingLoad, drive_scales
    from tribofmu.coupling.algorithms import make_algorithm
    from tribofmu.coupling.system import CoupledSystem
    from tribofmu.master.run import run

    points, calls, saves = {}, {}, {}
    for replayed in (True, False):
        block, drive, friction = FakeBlock(M=0.6, K=7000.0), FakeDrive(A=2e-3, omega=30.0), FakeFriction(DRY_LAW)
        load = SwingingLoad()
        if not replayed:  # (as slaves whose states are plain copies: saved at every point)
            block.states_are_copies = drive.states_are_copies = load.states_are_copies = True
        slaves = (block, drive, friction, load)
        logs = {slave.instance: call_log(slave) for slave in slaves}
        system = CoupledSystem(block, drive, friction, {"T": 290.0}, load=load)
        scales = drive_scales()
        out = run(system, make_algorithm("adaptive", tol=1e-3), 2 * scales.period, scales)
        assert out.ok, out.message
        points[replayed] = [repr(p) for p in out.points]
        calls[replayed] = sum(len(log) for log in logs.values())
        saves[replayed] = {name: logs[name].count("save") / out.counters["steps"] for name in ("block", "load")}
        assert all(slave.live_states == 0 for slave in slaves)
    assert points[True] == points[False]
    assert saves[False]["block"] >= 1.0 and saves[True]["block"] <= 0.5  # (0.45 on this rig: its stick ramps step the block in the solve)
    assert saves[True]["load"] < saves[False]["load"]
    assert calls[True] < calls[False]  # (6234 against 6664)
