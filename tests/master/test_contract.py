"""What the adaptive coupling promises, checked through its public contract only (a run of
``make_algorithm("adaptive")`` on fake slaves: its points, its counters, the calls the slaves
counted), never its attributes: events on time against the exact dry motion, stick exact,
the FMU calls an accepted step costs. (Error within its estimate: test_estimate.py; state
export and import: test_state.py.)"""
from dataclasses import replace

import numpy as np

import pytest

from tribofmu.coupling.algorithms import make_algorithm
from tribofmu.coupling.system import Contact
from tribofmu.master.run import run
from tribofmu.physics.laws.mixed import MixedLaw

from fakes import MU_L, N_STRESS, drive_scales, exact_dry, exact_dry_segments, fig2_system


def located_events(points):
    """The run's events: (kind, time [s]) of each change of contact between two points. A stick
    onset is located inside its step (the step's ``event`` fraction); a breakaway is landed on,
    at the last stuck point."""
    events = []
    for a, b in zip(points, points[1:]):
        if a.mode.slipping and b.mode.stuck:
            events.append(("stick", (a.t_ns + b.event * (b.t_ns - a.t_ns)) * 1e-9))
        elif a.mode.stuck and b.mode.slipping:
            events.append(("slip", a.t_ns * 1e-9))
    return events


def exact_events(t_end, omega):
    """The exact dry motion's events: (kind, time [s]) where its phase changes."""
    _, segments = exact_dry_segments(t_end, omega=omega)
    return [(kind, t) for (t, kind, *_), (_, before, *_) in zip(segments[1:], segments) if kind != before]


@pytest.mark.parametrize("omega", [13.0, 30.0, 80.0])
@pytest.mark.parametrize("tol, within", [(1e-3, 5e-5), (1e-4, 5e-5)])
def test_stick_onsets_and_breakaways_are_located_on_time(omega, tol, within):
    """Fig. 2's rig over two periods: the run sticks and breaks away as often and in the same
    order as the exact motion, each event located within a small fraction of the period (a
    step that passed over an event unlocated would miss by up to its length, T/20). A
    breakaway is as late as the run's error in x at it makes the stick force (2K dx over its
    rate). Over 22 frequencies from 10 to 88.9 rad/s (`python benchmarks/bench_events.py`,
    2026-11-28 10:35 UTC, again at 12:17 UTC) the largest misses are 7.9e-5 T at per-step 1e-3
    and 3.1e-5 T at 1e-4 (2.8e-5 T with the step-size rule before the trend on rejected tries,
    session 17), medians 2.8e-5 and 1.7e-5 T; at these three frequencies (`--omegas 13,30,80`,
    10:36 UTC) at most 4.5e-5 and 3.9e-5 T (the rule before: 4.5e-5 and 1.7e-5 T). The bound
    this test had at 1e-4, 2.5e-5 T, was its three frequencies' (1.9e-5 T measured 2026-11-26):
    four of the 22 miss it with either rule."""
    scales = drive_scales(omega)
    stop = 2 * scales.period
    out = run(fig2_system(omega=omega), make_algorithm("adaptive", tol=tol), stop, scales)
    assert out.ok, out.message
    located, exact = located_events(out.points), exact_events(stop, omega)
    assert len(exact) >= 6
    assert [kind for kind, _ in located] == [kind for kind, _ in exact]
    for (_, t), (_, t_exact) in zip(located, exact):
        assert abs(t - t_exact) <= within * scales.period


def test_events_unlanded_would_be_late():
    """The bound above can fail: with breakaways not landed on (every breakaway accepted
    inside its step), the located breakaways miss the exact ones by far more."""
    omega, tol = 30.0, 1e-3
    scales = drive_scales(omega)
    algorithm = make_algorithm("adaptive", tol=tol)
    algorithm.settings = replace(algorithm.settings, event_margin=2.0)
    out = run(fig2_system(omega=omega), algorithm, 2 * scales.period, scales)
    located, exact = located_events(out.points), exact_events(2 * scales.period, omega)
    misses = [abs(t - t_exact) / scales.period for (kind, t), (_, t_exact) in zip(located, exact) if kind == "slip"]
    assert max(misses) > 5e-5


def stribeck_law():
    return MixedLaw(mu_friction=0.4, mu_static=0.6, v_stribeck=0.03, stribeck_exponent=1.0, m=5.0, S=1.0)


@pytest.mark.parametrize("law", [None, stribeck_law()], ids=["dry", "stribeck"])
def test_stick_is_exact_and_its_force_within_the_friction_s_bounds(law):
    """Every stuck point of an adaptive run: dv = 0 to the coupling's "zero" (1e-10 of the
    velocity scale), and the force that keeps it stuck within the friction's static bound
    (mu L dry, the static limit of a Stribeck law); every slipping point moves with the
    friction's own force on the side of dv (to the loop's root tolerance)."""
    scales = drive_scales()
    system = fig2_system(law=law)
    friction = system.friction.law
    bound = friction.static_limit(N_STRESS)
    assert bound >= MU_L
    tol = 1e-4
    out = run(system, make_algorithm("adaptive", tol=tol), 2 * scales.period, scales)
    assert out.ok, out.message
    stuck = [p for p in out.points[1:] if p.mode == Contact.STUCK]
    slipping = [p for p in out.points[1:] if p.mode.slipping]
    assert len(stuck) > 20 and len(slipping) > 20
    for p in stuck:
        assert abs(p.dv) <= 1e-10 * scales.velocity and abs(p.F) <= bound * (1 + 1e-12)
    # (the force is the friction's at the loop's root, which the point's dv meets to the root
    # tolerance, 1e-3 of the per-step tol times the largest |v|, plus as much again where the
    # block's answer was modelled: the real step checks the model to one root tolerance)
    root_tol = 2 * 1e-3 * tol * max(abs(p.v) for p in out.points)
    for p in slipping:
        assert p.dv * p.mode > 0
        # (on the slip branch of the point's side: at dv -> 0 the branch's limit, the static force)
        side = float(p.mode)
        F_low, F_high = sorted(friction.slip_force(side * max(abs(p.dv) + s * root_tol, 0.0), N_STRESS, side)
                               for s in (-1, 1))
        assert F_low <= p.F <= F_high


@pytest.mark.parametrize("omega", [13.0, 30.0, 80.0])
def test_fmu_calls_per_accepted_step(omega):
    """What an accepted step costs in slave calls (get, set, doStep, save, restore, free, all
    slaves; rejected and landed tries included) on Fig. 2's rig at per-step tol 1e-3: measured
    2026-11-26 at 26.1-26.7 (24.4-24.7 at 1e-4), the drive's share 4.4-4.6 (it steps once a try,
    and is read and restored); a bound that a slower solve fails."""
    scales = drive_scales(omega)
    out = run(fig2_system(omega=omega), make_algorithm("adaptive", tol=1e-3), 2 * scales.period, scales)
    assert out.ok, out.message
    steps = out.counters["steps"]
    assert sum(out.calls.values()) / steps <= 28.0
    assert out.calls["drive"] / steps <= 5.0


@pytest.mark.parametrize("omega", [13.0, 80.0])
def test_a_run_says_at_what_power_of_its_tolerance_its_error_falls(omega):
    """convergence_order(): the mean over the accepted steps of p/(p + 1), p each step's order
    (held 1, ramped 2, stick ramp 3), so between 1/2 and 3/4; and the run's error falls at least
    at that power of its tolerance, which the check's plan takes it to (a dry block's falls
    faster: at 8x tighter, 14x and 35x closer to the exact motion where the order says 4x;
    a plan from it then lands below its aim, not above)."""
    scales = drive_scales(omega)
    stop = 2 * scales.period
    errors, orders = [], []
    for tol in (1e-3, 1.25e-4):
        algorithm = make_algorithm("adaptive", tol=tol)
        out = run(fig2_system(omega=omega), algorithm, stop, scales)
        assert out.ok, out.message
        order = algorithm.convergence_order()
        assert 0.5 <= order <= 0.75
        orders.append(order)
        t = np.array([p.t_ns * 1e-9 for p in out.points])
        _, v_exact, _ = exact_dry(t, omega=omega)
        errors.append(float(np.max(np.abs(np.array([p.v for p in out.points]) - v_exact))))
    assert errors[0] / errors[1] >= 8.0 ** max(orders)
