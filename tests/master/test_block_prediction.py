"""The block's learned model (coupling/blocks.py: BlockModel, BlockIdentification) and what it
saves: with it a step predicts the block's answers and steps the block once, at the answer,
which checks the prediction; a prediction the real step contradicts sends the step back to be
solved without it. Rigs as in test_contact.py (fakes: in-process parts, exact closed forms)."""
import math

import pytest

from tribofmu.coupling.blocks import BlockIdentification, BlockModel
from tribofmu.coupling.contact import RETRY_UNPREDICTED
from tribofmu.coupling.implicit import ImplicitCoupling
from tribofmu.coupling.base import Scales
from tribofmu.coupling.system import Contact
from tribofmu.physics import BlockState, FluidLaw, acceleration, advance_block

from fakes import DRY_LAW, MU_L, point_at, rig, settings, solve


def block_steps(system) -> int:
    return system.block.calls_by_kind["doStep"]


@pytest.mark.parametrize("K", [0.0, 7000.0])
@pytest.mark.parametrize("h", [1e-7, 1e-4, 2e-3, 0.05])
@pytest.mark.parametrize("rate", [0.0, 300.0])
def test_the_model_answers_as_the_block_itself(K, h, rate):
    """Held or ramped, free or on springs, steps from far below to beyond the block's period
    (w h from 1e-5 to 7.6, through the series' switch): the block's own closed form to
    round-off."""
    M, x0, v0, F0 = 0.6, 3e-4, -0.02, 1.3
    state = advance_block(BlockState(x0, v0), F0, rate, h, M, K)
    a = acceleration(state, F0 + rate * h, M, K)
    x, v, a_model = BlockModel(1.0 / M, 2.0 * K / M).answer(x0, v0, F0, rate, h)
    assert x == pytest.approx(state.x, rel=1e-11, abs=1e-15)
    assert v == pytest.approx(state.v, rel=1e-11, abs=1e-15)
    assert a_model == pytest.approx(a, rel=1e-9, abs=1e-9)


def test_two_answers_apart_identify_the_block_and_a_stick_adds_nothing():
    """a = F/M - w2 x at the end of any step: two answers with independent (F, x) give 1/M
    and 2K/M to round-off. Answers following the drive (F proportional to x, as a stick on
    a sinusoidal drive) determine nothing together: no model from them, and they do not
    replace a pair that does."""
    M, K = 0.6, 7000.0

    def answer(F, x):
        return F, x, (F - 2 * K * x) / M

    stuck = BlockIdentification()
    for x in (1e-4, 2e-4, -3e-4):
        stuck.observe(*answer((2 * K - M * 900.0) * x, x))
    assert stuck.model() is None
    learned = BlockIdentification()
    learned.observe(*answer(1.0, 1e-4))
    learned.observe(*answer(-1.0, 1.2e-4))
    for x in (1e-4, 2e-4, -3e-4):
        learned.observe(*answer((2 * K - M * 900.0) * x, x))
    model = learned.model()
    assert model.inv_M == pytest.approx(1.0 / M, rel=1e-13)
    assert model.w2 == pytest.approx(2 * K / M, rel=1e-12)


def learned(M, K) -> BlockModel:
    return BlockModel(1.0 / M, 2.0 * K / M)


@pytest.mark.parametrize("ramp", [False, True])
def test_a_slip_step_with_the_learned_block_steps_it_once_at_the_same_root(ramp):
    """A quadratic fluid on springs: the root lands where it lands with every block answer
    real (within the root tolerance), and the block steps once, at it."""
    m, M, K, V0, tol = 2e4, 1.0, 3000.0, 0.1, 1e-12  # (loop gain 2 m dv h / M = 4: ramped)
    outcomes = {}
    for model in (None, learned(M, K)):
        system = rig(FluidLaw(m=m, gamma=1.0), M=M, K=K, x0=1e-4, v0=0.0, V0=V0)
        start = point_at(system, Contact.FORWARD, m * V0 * V0)
        before = block_steps(system)
        new, report = solve(system, start, 1e-3, ramp=ramp, step_settings=settings(root_tol=tol), block_model=model)
        outcomes[model is None] = new, block_steps(system) - before, report
    (plain, plain_steps, _), (predicted, predicted_steps, report) = outcomes[True], outcomes[False]
    assert predicted.ramped == ramp
    assert predicted_steps == 1 < plain_steps
    assert report.predicted and report.velocity_per_impulse == pytest.approx(1.0 / M, rel=1e-13)
    assert abs(predicted.dv - plain.dv) <= 2 * tol
    assert (predicted.x, predicted.v) == pytest.approx((plain.x, plain.v), abs=1e-12)


def test_a_stuck_step_with_the_learned_block_steps_it_once_and_follows_the_drive_exactly():
    """Stuck all through on springs: the stick ramp solved on the prediction ends with dv = 0
    and x - X as at the start, as exactly as with real block steps, in one block step."""
    K, x0, V0, h = 2000.0, 1e-3, 0.05, 1e-3
    results = {}
    for model in (None, learned(1.0, K)):
        system = rig(DRY_LAW, M=1.0, K=K, x0=x0, v0=V0, V0=V0)
        start = point_at(system, Contact.STUCK, 2 * K * x0, F_rate=2 * K * V0)
        before = block_steps(system)
        new, _ = solve(system, start, h, block_model=model)
        results[model is None] = new, block_steps(system) - before
    (plain, plain_steps), (new, steps) = results[True], results[False]
    assert steps == 1 < plain_steps
    assert new.mode == Contact.STUCK and new.event == 1.0
    assert abs(new.dv) <= 1e-10
    assert new.x - new.X == pytest.approx(x0, abs=1e-12 * 1e-3)
    assert new.F_start == pytest.approx(plain.F_start, rel=1e-9)
    assert new.F_rate == pytest.approx(plain.F_rate, rel=1e-6)


def test_a_breakaway_with_the_learned_block_is_where_the_stick_ramp_leaves_the_bound():
    """Stuck, the spring force reaching mu L inside the step: the same event as with real
    block steps."""
    K, V0, h = 2000.0, 0.05, 1e-3
    x0 = (MU_L - 2 * K * V0 * 0.6 * h) / (2 * K)  # the bound is reached at 0.6 h
    events = []
    for model in (None, learned(1.0, K)):
        system = rig(DRY_LAW, M=1.0, K=K, x0=x0, v0=V0, V0=V0)
        start = point_at(system, Contact.STUCK, 2 * K * x0, F_rate=2 * K * V0)
        new, _ = solve(system, start, h, block_model=model)
        events.append(new.event)
    assert events[1] == pytest.approx(events[0], abs=1e-9) and events[0] == pytest.approx(0.6, abs=1e-6)


def test_a_wrong_model_is_caught_by_the_real_step_and_the_step_solved_without_it():
    """A learned mass 1 % off: the real step at the predicted root disagrees, the step says
    so (RETRY_UNPREDICTED); the coupling then forgets what it learned and solves the step
    with real block answers, landing where a coupling that never learned lands."""
    m, M, K, V0 = 2e5, 1.0, 3000.0, 0.1
    system = rig(FluidLaw(m=m, gamma=1.0), M=M, K=K, x0=1e-4, V0=V0)
    start = point_at(system, Contact.FORWARD, m * V0 * V0)
    outcome, _ = solve(system, start, 1e-3, step_settings=settings(root_tol=1e-12),
                       block_model=BlockModel(1.01 / M, 2 * K / M))
    assert outcome is RETRY_UNPREDICTED
    ends = []
    for wrong in (False, True):
        system = rig(FluidLaw(m=m, gamma=1.0), M=M, K=K, x0=1e-4, V0=V0)
        start = point_at(system, Contact.FORWARD, m * V0 * V0)
        algorithm = ImplicitCoupling(step=1e-3, tol=1e-6)
        algorithm.prepare(system, Scales(position=1e-3, velocity=0.1, period=0.1))
        if wrong:  # two answers of a block 1 % lighter than this one
            for F, x in ((1.0, 1e-4), (-1.0, 1.2e-4)):
                algorithm.reuse.block.observe(F, x, (F - 2 * K * x) * 1.01 / M)
        ends.append(algorithm.solve_step(system, start, 1_000_000))
        if wrong:
            assert algorithm.reuse.block.model() is None or algorithm.reuse.block.model().inv_M == \
                pytest.approx(1.0 / M, rel=1e-9)
    assert ends[1].v == pytest.approx(ends[0].v, abs=1e-12)
    assert ends[1].x == pytest.approx(ends[0].x, abs=1e-15)


def test_the_adaptive_coupling_steps_the_block_about_once_a_step_on_fig2_s_rig():
    """On fig. 2's rig (stick, breakaway, slip, reversal) the learned block leaves one real
    block step per accepted step, about (the first steps learn it): a try that is landed or
    rejected never stepped it (its real step waits for the step to be kept)."""
    from fakes import drive_scales, fig2_system
    from tribofmu.coupling.embedded import EmbeddedCoupling
    from tribofmu.master import run

    system, scales = fig2_system(), drive_scales()
    stepped = []
    do_step = system.block.do_step
    system.block.do_step = lambda t, h: stepped.append(t) or do_step(t, h)
    algorithm = EmbeddedCoupling(tol=1e-4)
    run(system, algorithm, scales.period, scales)
    counters = algorithm.counters
    assert counters.rejected + counters.landed > 0
    assert counters.steps <= len(stepped) <= 1.1 * counters.steps
    assert algorithm.reuse.block.model().inv_M == pytest.approx(1 / 0.6, rel=1e-12)


def test_a_wrong_model_in_the_adaptive_coupling_rolls_its_step_back_and_solves_it_without():
    """In the adaptive coupling the block's real step waits until the step is to be kept; where
    it then disagrees (a learned mass 1 % off), the step is rolled back and solved again
    without the model, in the same advance: the point a coupling that never learned reaches,
    every slave standing there."""
    from fakes import drive_scales, fig2_system
    from tribofmu.coupling.embedded import EmbeddedCoupling

    scales = drive_scales()
    stop = int(scales.period * 1e9)
    ends = []
    for wrong in (False, True):
        system = fig2_system()
        algorithm = EmbeddedCoupling(tol=1e-4)
        algorithm.prepare(system, scales)
        if wrong:  # two answers of a block 1 % lighter than fig. 2's (M = 0.6 kg, K = 7000 N/m)
            for F, x in ((1.0, 1e-4), (-1.0, 1.2e-4)):
                algorithm.reuse.block.observe(F, x, (F - 2 * 7000.0 * x) * 1.01 / 0.6)
        new = algorithm.advance(system, system.start_point(), stop)
        assert len(new) == 1 and algorithm.counters.rejected == algorithm.counters.landed == 0
        assert all(s.time == pytest.approx(new[0].t_ns * 1e-9, abs=1e-15) for s in system.slaves)
        ends.append(new[0])
    assert (ends[1].t_ns, ends[1].x, ends[1].v, ends[1].F) == (ends[0].t_ns, ends[0].x, ends[0].v, ends[0].F)
