"""Tier 2: the master (coupling algorithms, run loop) against fake slaves."""
import math

import numpy as np
import pytest

from tribofmu.coupling.algorithms import make_algorithm
from tribofmu.coupling.system import CoupledSystem
from tribofmu.master import run
from tribofmu.coupling.interpolation import NS
from tribofmu.physics import FluidLaw

from fakes import FakeBlock, drive_scales, exact_dry, fig2_system

OMEGA = 30.0
PERIOD = 2 * math.pi / OMEGA
SCALES = drive_scales(OMEGA)


def stick_episodes(points, start, end):
    """Number of maximal runs of stuck steps (mode 0) that begin inside [start, end)."""
    modes = [(p.t_ns / NS, p.mode) for p in points]
    count = 0
    for (t0, m0), (t1, m1) in zip(modes, modes[1:]):
        if m1 == 0 and m0 != 0 and start <= t1 < end:
            count += 1
    return count


def test_implicit_resolves_stick_four_times_per_period():
    system = fig2_system()
    out = run(system, make_algorithm("implicit", step=2e-4), 6.5 * PERIOD, SCALES)
    assert out.ok
    assert stick_episodes(out.points, 5 * PERIOD, 6 * PERIOD) == 4
    stuck = [p for p in out.points if p.mode.stuck and p.t_ns > 0]
    assert stuck and all(abs(p.dv) <= 1e-9 * SCALES.velocity for p in stuck)
    assert all(abs(p.F) <= 10.0 + 1e-9 for p in out.points)  # |F| <= mu L


def test_jacobi_chatters_where_implicit_sticks():
    out = run(fig2_system(), make_algorithm("jacobi", step=1e-4), 6.5 * PERIOD, SCALES)
    F = np.array([p.F for p in out.points])
    flips = np.count_nonzero(np.sign(F[1:]) != np.sign(F[:-1]))
    assert flips > 100  # the sign of dv flips back and forth while it should be stuck


def _dissipation_per_step(step):
    out = run(fig2_system(), make_algorithm("implicit", step=step), 3 * PERIOD, SCALES)
    # The block felt a constant force over each step: the work it took from the drive minus
    # the work it gave the block is what friction dissipated in that step [J].
    return [(p1.F_start * ((p1.X - p0.X) - (p1.x - p0.x)), p1.mode if p1.mode == p0.mode else None)
            for p0, p1 in zip(out.points, out.points[1:])]


def test_friction_dissipates_and_created_energy_vanishes_with_the_step():
    scale = 10.0 * 2e-3  # mu L * A [J]
    coarse, fine = _dissipation_per_step(1e-3), _dissipation_per_step(2.5e-4)
    for steps in (coarse, fine):
        # slipping the whole step one way: exactly dissipative
        assert min(d for d, mode in steps if mode in (-1, 1)) >= 0.0
        assert sum(d for d, _ in steps) > 0.1 * scale
    # While stuck, v = V holds at step ends only, and a step with a stick/slip transition
    # inside holds one force throughout: X - x moves a little against it, returning energy.
    # That must vanish as h -> 0.
    worst = lambda steps: -min(0.0, min(d for d, _ in steps))
    assert worst(coarse) > 0.0
    assert worst(fine) < worst(coarse) / 3


def test_integer_time_ends_exactly_at_stop():
    stop = 6.5 * PERIOD
    for name, step in (("jacobi", 3e-4), ("implicit", 7e-4), ("adaptive", None)):
        out = run(fig2_system(), make_algorithm(name, step=step), stop, SCALES)
        times = [p.t_ns for p in out.points]
        assert times[-1] == round(stop * NS)
        assert all(b > a for a, b in zip(times, times[1:]))


def test_adaptive_rolls_back_and_meets_its_tolerance():
    system = fig2_system()
    algorithm = make_algorithm("adaptive", tol=1e-4)
    out = run(system, algorithm, 2 * PERIOD, SCALES)
    assert out.ok
    assert out.counters["rejected"] > 0  # stick/slip transitions force retries
    assert out.counters["forced"] == 0
    steps = np.diff([p.t_ns for p in out.points])
    assert steps.max() > 20 * steps.min()  # large steps in smooth motion, small at transitions
    for s in system.slaves:
        assert s.live_states == 0  # every saved state was freed


@pytest.mark.parametrize("tol", [1e-3, 1e-4])
def test_adaptive_meets_its_tolerance_against_the_exact_dry_motion(tol):
    """Fig. 2's rig against its exact piecewise solution (harmonic slip under +-mu L, rigid
    stick): nRMS(v) at the communication points within 3 tol, and the coupling's own
    stuck flag agrees with the exact stick phases except at the steps holding a transition."""
    out = run(fig2_system(), make_algorithm("adaptive", tol=tol), 2 * PERIOD, SCALES)
    t = np.array([p.t_ns for p in out.points]) / NS
    _, v, stuck = exact_dry(t)
    err = (np.array([p.v for p in out.points]) - v) / SCALES.velocity
    assert np.sqrt(np.mean(err ** 2)) < 3 * tol
    assert np.mean(stuck == np.array([p.mode.stuck for p in out.points])) > 0.95


def test_gauss_seidel_and_jacobi_share_the_step_but_differ_in_order():
    law = FluidLaw(m=25.0, gamma=0.0)
    a = run(fig2_system(law, omega=50.0), make_algorithm("jacobi", step=1e-4), 0.2, SCALES)
    b = run(fig2_system(law, omega=50.0), make_algorithm("gauss-seidel", step=1e-4), 0.2, SCALES)
    # Static law: the friction's step input does not matter, so the block sees the same forces.
    assert [p.v for p in a.points] == pytest.approx([p.v for p in b.points], abs=1e-15)


def test_failure_is_a_result_naming_the_instance():
    system = fig2_system()
    system.friction.fail_at = 0.05
    out = run(system, make_algorithm("implicit", step=1e-3), 0.2, SCALES)
    assert not out.ok
    assert "friction" in out.message and "fmi2Discard" in out.message and "scripted failure" in out.message
    assert out.points[-1].t_ns <= 0.05 * NS


def test_dry_scene_never_touches_the_kinetics():
    system = fig2_system()
    run(system, make_algorithm("adaptive"), PERIOD, SCALES)
    assert system.friction.kinetics_steps == 0


def test_unknown_algorithm_names_the_known_ones():
    with pytest.raises(ValueError, match="jacobi, gauss-seidel, implicit, adaptive"):
        make_algorithm("newton")


def test_no_friction_gives_the_free_oscillator():
    system = CoupledSystem(FakeBlock(x0=1e-3))
    out = run(system, make_algorithm("adaptive"), 0.3, SCALES)
    w0 = math.sqrt(2 * 7000.0 / 0.6)
    for p in out.points:
        assert p.x == pytest.approx(1e-3 * math.cos(w0 * p.t_ns / NS), abs=1e-12)
