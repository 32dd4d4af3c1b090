"""The adaptive coupling's accept / reject / landing logic and its counters (the shared
bookkeeping on the step-doubling coupling, which benchmarks/doubling.py keeps for comparison:
two points an accepted step make its halves and landings visible)."""
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from tribofmu.coupling.algorithms import Scales
from tribofmu.coupling.system import Contact
from tribofmu.physics import FluidLaw
from tribofmu.coupling.settings import LIMITS, STEP_CONTROL as COUPLING_STEPS

from fakes import DRY_LAW, MU_L, drive_scales, fig2_system, point_at, rig

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from doubling import StepDoublingCoupling as AdaptiveCoupling  # noqa: E402

SCALES = Scales(position=1e-3, velocity=0.1, period=0.1)  # min step 10 ns, max 5 ms


class RecordingController:
    """The coupling's controller, with every call it answers kept."""

    def __init__(self):
        self.calls = []
        self.previous_errors = []  # what it was told of the last accepted step (the PI term)
        self.trends = []  # and for its predictive term

    def factor(self, error, order, after_reject=False, previous_error=1.0, trend=None):
        value = COUPLING_STEPS.factor(error, order, after_reject, previous_error, trend)
        self.calls.append((error, order, after_reject, value))
        self.previous_errors.append(previous_error)
        self.trends.append(trend)
        return value


def adaptive(system, tol=1e-3, step=1e-3, scales=SCALES):
    algorithm = AdaptiveCoupling(step=step, tol=tol)
    algorithm.controller = RecordingController()
    algorithm.prepare(system, scales)
    return algorithm


def slipping_fluid(m=20.0, M=1.0, K=500.0):
    """A block on soft springs dragged through a linear fluid at 0.1 m/s: smooth slip."""
    system = rig(FluidLaw(m=m), M=M, K=K, V0=0.1)
    return system, point_at(system, Contact.FORWARD, m * 0.1)


def states(system):
    return [s.save() for s in system.slaves]


def test_prepare_bounds_the_step_by_the_period():
    algorithm = adaptive(slipping_fluid()[0], step=1.0)
    # the scene's period here is 0.1 s: the step between 1e-7 of it and a whole period (Limits)
    assert algorithm.min_ns == 10 and algorithm.max_ns == 100_000_000 == round(0.1 * LIMITS.max_step_periods * 1e9)
    assert algorithm.h_ns == algorithm.max_ns  # a first try beyond the bound is clipped
    assert adaptive(slipping_fluid()[0], step=1e-12).h_ns == algorithm.min_ns


def test_accepted_step_returns_both_halves_and_grows_by_the_controller():
    system, start = slipping_fluid()
    algorithm = adaptive(system, tol=1e-2, step=1e-3)
    points = algorithm.advance(system, start, 10**9)
    assert [p.t_ns for p in points] == [500_000, 1_000_000]
    assert algorithm.counters.steps == 2 and algorithm.counters.rejected == 0
    (error, order, after_reject, factor), = algorithm.controller.calls
    assert error <= 1.0 and not after_reject
    assert order == (2 if points[-1].ramped else 1)
    assert algorithm.h_ns == int(min(1_000_000 * factor, algorithm.max_ns))
    assert algorithm.h_ns > 1_000_000  # an easy step grows the next
    # the halves' own estimate: one step against two halves, in v
    assert points[-1].est_error > 0.0


def test_rejected_step_rolls_back_shrinks_and_holds_growth_after():
    system, start = slipping_fluid()
    algorithm = adaptive(system, tol=1e-9, step=5e-3)
    before = states(system)
    assert algorithm.advance(system, start, 10**9) == []
    assert states(system) == before  # every slave back where it was
    assert algorithm.counters.rejected == 1 and algorithm.counters.steps == 0
    assert algorithm.rejected_last
    (error, order, after_reject, factor), = algorithm.controller.calls
    assert error > 1.0 and not after_reject and factor < 1.0
    assert algorithm.h_ns == int(5_000_000 * factor)
    # retried until accepted; the first accepted step after a rejection does not grow
    point = start
    while True:
        h_ns = algorithm.h_ns
        new = algorithm.advance(system, point, 10**9)
        if new:
            break
    assert algorithm.controller.calls[-1][2]  # told it follows a rejection
    assert algorithm.h_ns <= h_ns and not algorithm.rejected_last


def test_the_controller_hears_the_last_accepted_step_s_error_not_a_rejected_one():
    """The PI term's memory: the error of the last accepted step (1 before any), kept across
    rejections, replaced by each acceptance."""
    system, point = slipping_fluid()
    algorithm = adaptive(system, tol=1e-4, step=5e-3)
    accepted = [1.0]
    for _ in range(12):
        new = algorithm.advance(system, point, 10**9)
        error = algorithm.controller.calls[-1][0]
        assert algorithm.controller.previous_errors[-1] == accepted[-1]
        if new:
            point = new[-1]
            accepted.append(error)
    assert algorithm.counters.rejected >= 1 and len(accepted) >= 5  # (both kinds were seen)
    assert algorithm.accepted_error == accepted[-1]


def test_a_rejected_try_is_retried_with_the_trend_since_the_last_accepted_step_of_its_order():
    """The predictive term's memory: the last accepted step's length and error (none before
    any), kept across rejections, replaced by each acceptance; read for a rejected try of that
    step's order only (a held step's error constant is not a ramped one's), never for a step
    that is accepted (its successor is sized as before)."""
    system, point = slipping_fluid()
    algorithm = adaptive(system, tol=1e-4, step=5e-3)
    last, read = None, 0  # (h_ns, error, order) of the last accepted step
    for _ in range(30):
        if last is not None and algorithm.accepted_h_ns == last[0] and not algorithm.rejected_last:
            algorithm.h_ns *= 8  # (right after an acceptance, a try far longer: rejected, a trend to read)
        h_ns = algorithm.h_ns
        new = algorithm.advance(system, point, 10**9)
        error, order, _, _ = algorithm.controller.calls[-1]
        trend = algorithm.controller.trends[-1]
        if new or last is None or last[2] != order:
            assert trend is None
        else:
            assert trend == (h_ns / last[0], last[1])
            read += 1
        if new:
            point = new[-1]
            last = (h_ns, error, order)
    assert read >= 1 and len([c for c in algorithm.controller.trends if c is None]) >= 5
    assert (algorithm.accepted_h_ns, algorithm.accepted_error, algorithm.accepted_order) == last


def test_no_trend_before_an_accepted_step_across_orders_or_for_a_stuck_step():
    """The trend is (h over the last accepted step's, its error) for a step of that step's
    order; none before any, none across orders, none for a stuck step (order 3: its error is
    its breakaway's, weighed by how near the bound the force is)."""
    algorithm = adaptive(slipping_fluid()[0])
    assert algorithm.trend(1000, 2) is None
    algorithm.accepted_h_ns, algorithm.accepted_error, algorithm.accepted_order = 500, 0.4, 2
    assert algorithm.trend(1000, 2) == (2.0, 0.4)
    assert algorithm.trend(1000, 1) is None
    algorithm.accepted_order = 3
    assert algorithm.trend(1000, 3) is None


def test_the_minimum_step_is_forced_through_and_counted():
    system, start = slipping_fluid()
    algorithm = adaptive(system, tol=1e-15)
    algorithm.h_ns = 2 * algorithm.min_ns
    points = algorithm.advance(system, start, 10**9)
    assert [p.t_ns for p in points] == [algorithm.min_ns, 2 * algorithm.min_ns]
    assert algorithm.counters.forced == 1 and algorithm.counters.rejected == 0
    assert algorithm.controller.calls[-1][0] > 1.0


def test_a_last_sliver_of_time_is_one_plain_step_to_the_stop():
    system, start = slipping_fluid()
    algorithm = adaptive(system)
    points = algorithm.advance(system, start, 1)
    assert [p.t_ns for p in points] == [1]
    assert algorithm.counters.steps == 1 and algorithm.controller.calls == []


def test_steps_split_in_integer_halves_and_end_on_the_stop():
    system, start = slipping_fluid()
    algorithm = adaptive(system, tol=1e-2, step=1e-3)
    algorithm.h_ns = 1_000_001  # odd: halves need an even step
    points = algorithm.advance(system, start, 10**9)
    assert [p.t_ns for p in points] == [500_000, 1_000_000]
    point, stop = points[-1], 3_333_333
    while point.t_ns < stop:
        new = algorithm.advance(system, point, stop)
        point = new[-1] if new else point
        assert point.t_ns <= stop
    assert point.t_ns == stop


def stuck_to_a_steady_drive(t_break, K=2000.0, V0=0.05, M=1.0):
    """The block stuck to a drive at constant V0: the stick force 2K (x0 + V0 t) reaches
    mu L at t_break [s]."""
    x0 = (MU_L - 2 * K * V0 * t_break) / (2 * K)
    system = rig(DRY_LAW, M=M, K=K, x0=x0, v0=V0, V0=V0)
    return system, point_at(system, Contact.STUCK, 2 * K * x0, F_rate=2 * K * V0)


def test_breakaway_inside_a_step_is_landed_on():
    """A step of 1 ms over a breakaway at 0.3137 ms is rolled back and cut to end there
    (counted as landed, not rejected); the step taken then ends stuck at the breakaway (to
    the even nanosecond below), and the one after slips."""
    t_break_ns = 313_700
    system, start = stuck_to_a_steady_drive(t_break_ns * 1e-9)
    algorithm = adaptive(system, tol=1e-3, step=1e-3)
    before = states(system)
    assert algorithm.advance(system, start, 10**9) == []
    assert states(system) == before
    assert algorithm.counters.landed == 1 and algorithm.counters.rejected == 0
    assert t_break_ns - 4 <= algorithm.h_ns <= t_break_ns
    points = algorithm.advance(system, start, 10**9)
    assert points and t_break_ns - 4 <= points[-1].t_ns <= t_break_ns
    assert all(p.mode == Contact.STUCK for p in points)
    assert points[-1].F == pytest.approx(MU_L, rel=1e-5)  # the stick force at the bound
    assert algorithm.counters.landed == 1
    after = algorithm.advance(system, points[-1], 10**9)
    while not after:
        after = algorithm.advance(system, points[-1], 10**9)
    assert after[0].mode == Contact.FORWARD
    assert algorithm.counters.landed == 1  # no second landing for the same breakaway


def test_a_breakaway_too_close_to_the_start_is_not_landed():
    """Below a hundredth of the step a landing would make a sliver step: the step is judged
    by its error instead."""
    system, start = stuck_to_a_steady_drive(4e-6)
    algorithm = adaptive(system, tol=1e-3, step=1e-3)
    algorithm.advance(system, start, 10**9)
    assert algorithm.counters.landed == 0


@pytest.mark.parametrize("controlled", ["doubling", "adaptive"])
def test_counters_of_a_run_count_what_happened(controlled):
    """Over fig. 2's rig (fakes): accepted steps are the points after the start; the
    implicit coupling's stuck steps are the points that ended stuck; an error-controlled
    coupling's (step doubling's, the package's adaptive) rejections and landings are the
    advances that returned nothing."""
    from tribofmu.coupling.algorithms import ImplicitCoupling, make_algorithm
    from tribofmu.master import run

    scales, fig2 = drive_scales(), fig2_system

    implicit = run(fig2(), ImplicitCoupling(step=5e-4), scales.period, scales)
    stuck = sum(p.mode == Contact.STUCK for p in implicit.points[1:])
    assert implicit.counters["steps"] == len(implicit.points) - 1
    assert implicit.counters["stick_steps"] == stuck > 0

    system = fig2()
    algorithm = AdaptiveCoupling(tol=1e-4) if controlled == "doubling" else make_algorithm("adaptive", tol=1e-4)
    algorithm.prepare(system, scales)
    point, empty, accepted = system.start_point(), 0, 0
    stop = round(scales.period * 1e9)
    while point.t_ns < stop:
        new = algorithm.advance(system, point, stop)
        empty += not new
        accepted += len(new)
        point = new[-1] if new else point
    c = algorithm.counters
    assert c.steps == accepted and c.rejected + c.landed == empty
    assert c.landed > 0 and c.rejected > 0


@pytest.mark.parametrize("algorithm", ["implicit", "adaptive"])
@pytest.mark.parametrize("omega", [13.0, 30.0, 80.0])
def test_dry_runs_keep_coulomb_s_law_at_every_point(algorithm, omega):
    """At every communication point of a dry run: stuck means dv = 0 (to the coupling's
    "zero", 1e-10 of the velocity scale) with |F| <= mu L; slipping means F = +-mu L exactly,
    on the side of dv."""
    from tribofmu.coupling.algorithms import make_algorithm
    from tribofmu.master import run

    scales = drive_scales(omega)
    out = run(fig2_system(omega=omega), make_algorithm(algorithm, step=2e-4, tol=1e-4), 2 * scales.period, scales)
    assert out.ok
    modes = set()
    for p in out.points[1:]:
        modes.add(p.mode)
        if p.mode == Contact.STUCK:
            assert abs(p.dv) <= 1e-10 * scales.velocity and abs(p.F) <= MU_L * (1 + 1e-12)
        else:
            assert p.F == p.mode * MU_L and p.dv * p.mode > 0
    assert modes == {Contact.STUCK, Contact.FORWARD, Contact.BACKWARD}


@pytest.mark.parametrize("tol", [1e-4, 4e-7])
def test_a_run_starting_stuck_is_not_charged_a_slip_into_stick_on_its_first_step(tol):
    """Fig. 2's rig starts at rest, stuck: the first step from the start point (mode UNKNOWN,
    F = 0, a force no block felt) is exact in v and needs no rejection. Charged the jump from
    F = 0 to the stick force as a slip into stick, it shrank to the step floor, where the stick
    ramp's force is round-off that the breakaway term rejected step after step (a tight
    per-step tolerance then spent thousands of steps in the first stick)."""
    from tribofmu.coupling.embedded import EmbeddedCoupling

    scales, system = drive_scales(), fig2_system()
    algorithm = EmbeddedCoupling(step=1e-4, tol=tol)
    algorithm.prepare(system, scales)
    new = algorithm.advance(system, system.start_point(), round(scales.period * 1e9))
    assert [p.t_ns for p in new] == [100_000] and new[0].mode == Contact.STUCK  # the first step asked
    assert algorithm.counters.rejected == 0 and algorithm.counters.forced == 0


def test_no_stuck_point_holds_a_block_that_needed_more_than_the_friction_can_give():
    """Fig. 2's rig at a slow drive (omega = 3 rad/s) sticks for moments shorter than a step
    (micro-sticks right after the block reaches the drive's velocity). A stuck step's force is
    a chord; the force that kept the block on the drive at its end is the chord's plus
    M (aX - a). Where that was past the bound the contact broke away inside the step, and the
    step is landed there: no accepted stuck point may need more than the bound (beyond the
    last 1 % of a step, which the next step breaks away from). Before: 0.7 % past it, the
    breakaway passed over (true nRMS(v) 1.1e-3 at per-step 3.1e-5, where 6.3e-5 gave 1.6e-4)."""
    import math

    from tribofmu.coupling.embedded import EmbeddedCoupling
    from tribofmu.master.run import run

    omega = 3.0
    system = fig2_system(omega=omega)
    algorithm = EmbeddedCoupling(step=1e-4, tol=3.125e-5)
    outcome = run(system, algorithm, 3 * 2 * math.pi / omega, drive_scales(omega=omega))
    assert outcome.ok, outcome.message
    M = system.block.M
    needed = [abs(p.F + (p.aX - p.a) * M) / MU_L for p in outcome.points if p.mode.stuck]
    assert len(needed) > 100 and max(needed) - 1.0 < 1e-3
    assert algorithm.counters.landed > 0


def test_a_step_that_breaks_away_at_its_start_is_held_to_the_interpolation_bound():
    """A stuck step that slips at its end broke away at its start and slips all through:
    its samples are interpolated like any slip step's, so it is planned and checked as one
    (at most ErrorSettings.block_period_fraction of the block's period, within the interpolation bound).
    Before, it was neither: 0.19 of the block's period on Fig. 2's rig at omega = 3 rad/s,
    and its samples missed by 0.35 % of max|v|."""
    import math

    from tribofmu.coupling.embedded import EmbeddedCoupling
    from tribofmu.coupling.settings import ERROR_SETTINGS
    from tribofmu.master.run import run

    omega = 3.0
    system = fig2_system(omega=omega)
    algorithm = EmbeddedCoupling(step=1e-4, tol=6.25e-5)
    outcome = run(system, algorithm, 3 * 2 * math.pi / omega, drive_scales(omega=omega))
    assert outcome.ok, outcome.message
    block_period = 2 * math.pi / math.sqrt(2 * system.block.K / system.block.M)
    lengths = [(b.t_ns - a.t_ns) * 1e-9 / block_period for a, b in zip(outcome.points, outcome.points[1:])
               if a.mode.stuck and b.mode.slipping]
    assert len(lengths) > 10 and max(lengths) <= ERROR_SETTINGS.block_period_fraction


def test_a_stick_from_rest_far_from_the_bound_is_not_held_to_the_breakaway_timing():
    """Mixed friction (mu_s = 0.6, delta = 1) on Fig. 2's rig starts at rest, stuck, its stick
    force ~1 N against a bound of 12 N and ramping at a few N/s. The breakaway-timing term
    divides by that rate and read the stick ramp's round-off as error: at per-step 2e-7 the
    first 1 % of a period took 987 steps, 257 rejected, down to the 20 ns floor. Far out of
    the bound's reach the term counts as little as the breakaway is near: a handful of steps."""
    from tribofmu.coupling.embedded import EmbeddedCoupling
    from tribofmu.master.run import run
    from tribofmu.physics.laws.mixed import MixedLaw

    law = MixedLaw(mu_friction=0.4, mu_static=0.6, v_stribeck=0.03, stribeck_exponent=1.0, m=5.0, S=1.0)
    system, scales = fig2_system(law=law), drive_scales()
    algorithm = EmbeddedCoupling(step=1e-4, tol=2e-7)
    outcome = run(system, algorithm, 0.01 * scales.period, scales)
    assert outcome.ok, outcome.message
    assert len(outcome.points) < 20 and algorithm.counters.rejected == 0
    assert all(p.mode == Contact.STUCK for p in outcome.points[1:])


def test_stepped_trials_follow_a_lubricant_in_fewer_calls():
    """Fig. 6's boundary lubricant on in-process parts (the block dragged at 1e-4 m/s): a slip
    going on sought with the friction stepped from its first trial (the default while the law
    has not stuck) reaches the same motion over 20 ms as the trials at the friction's start
    state, whose root the lubricant's state then moved, in at most 85 % of the friction's
    calls. (The block's calls, counted here before, no longer depend on how the root is
    sought: its learned model predicts every trial's answer and it steps once, at the root.)"""
    from tribofmu.coupling.embedded import EmbeddedCoupling
    from tribofmu.coupling.inprocess import BlockPart, FollowedDrive, FrictionPart
    from tribofmu.coupling.system import CoupledSystem
    from tribofmu.physics import BoundaryLaw

    law, n, V, tol, stop_ns = BoundaryLaw(m=0.05, gamma=-2 / 3, S=3e-9), -1e6, 1e-4, 1e-3, 20_000_000
    runs = {}
    for stepped in (False, True):
        system = CoupledSystem(BlockPart("block", 0.7, 1300.0, 0.0, 0.0), FollowedDrive("drive", 0.0, V, 0.0),
                               FrictionPart("friction", law, 0.0, n, 290.0), {"n": n, "T": 290.0})
        algorithm = EmbeddedCoupling(tol=tol)
        algorithm.switches = replace(algorithm.switches, stepped_trials=stepped)
        algorithm.prepare(system, Scales(position=1e-6, velocity=V, period=0.1))
        points = [system.start_point()]
        while points[-1].t_ns < stop_ns:
            points += algorithm.advance(system, points[-1], stop_ns)
        calls = sum(system.friction.calls_by_kind.values())
        runs[stepped] = (points, calls)
    (trials, trial_calls), (stepped, stepped_calls) = runs[False], runs[True]
    assert all(p.mode.slipping for p in trials[1:]) and trials[-1].f > 1.0  # (the lubricant moved)
    end, other = stepped[-1], trials[-1]
    assert end.t_ns == other.t_ns == stop_ns
    assert abs(end.v - other.v) <= 1e-2 * tol * V and abs(end.f - other.f) <= 1e-2 * tol * other.f
    assert stepped_calls <= 0.85 * trial_calls
