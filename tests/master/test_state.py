"""Rollback, the algorithm's exported state and the pair model's snapshot."""
import copy
import json

import pytest

from tribofmu.coupling.algorithms import AdaptiveCoupling, ImplicitCoupling, Scales
from tribofmu.coupling.interpolation import NS
from tribofmu.coupling.pair import PairModel, PairParameters
from tribofmu.master import FMUCallError
from tribofmu.physics import BoundaryLaw, FluidLaw, drive

from fakes import DRY_LAW, drive_scales, fig2_system

OMEGA = 30.0
SCALES = drive_scales(OMEGA)


def slave_states(system):
    """Each slave's variables and time, without counting a saved state."""
    return [(s.instance, copy.deepcopy(s.values), s.time) for s in system.slaves]


def same_points(a, b):
    """Bit-identical points (repr: floats exactly, nan equal to nan)."""
    return [repr(p) for p in a] == [repr(p) for p in b]


# -- rollback -------------------------------------------------------------------------------

def test_states_are_held_once_per_point_freed_by_finish_and_a_rollback_leaves_every_slave_in_place():
    system = fig2_system()
    algorithm = AdaptiveCoupling(tol=1e-4)
    algorithm.prepare(system, SCALES)
    point, stop = system.start_point(), round(0.5 * SCALES.period * NS)
    outcomes = {"accepted": 0, "rejected": 0, "landed": 0}
    while point.t_ns < stop:
        before, counters = slave_states(system), copy.copy(algorithm.counters)
        new = algorithm.advance(system, point, stop)
        # the states at the point tried from, kept for its retries (saved once per point)
        assert all(s.live_states == 1 for s in system.slaves)
        if new:
            outcomes["accepted"] += 1
            point = new[-1]
            assert all(s.time == pytest.approx(point.t_ns / NS, abs=1e-15) for s in system.slaves)
        else:
            assert slave_states(system) == before
            kind = "rejected" if algorithm.counters.rejected > counters.rejected else "landed"
            assert getattr(algorithm.counters, kind) == getattr(counters, kind) + 1
            outcomes[kind] += 1
    assert min(outcomes.values()) > 0  # every path was taken
    algorithm.finish(system)
    assert all(s.live_states == 0 for s in system.slaves)


def test_a_failing_slave_mid_step_leaves_no_state_allocated():
    for algorithm in (ImplicitCoupling(step=1e-3), AdaptiveCoupling()):
        system = fig2_system()
        algorithm.prepare(system, SCALES)
        system.friction.fail_at = 0.0  # every friction step fails
        with pytest.raises(FMUCallError, match="scripted failure"):
            algorithm.advance(system, system.start_point(), NS)
        algorithm.finish(system)  # (the run loop calls it however the run ends)
        assert all(s.live_states == 0 for s in system.slaves)


# -- the algorithm's state ---------------------------------------------------------------------

def advance_n(algorithm, system, point, n, stop_ns):
    points = []
    for _ in range(n):
        new = algorithm.advance(system, point, stop_ns)
        points += new
        point = new[-1] if new else point
    return point, points


def clone_slaves(system):
    """A fresh fig2 system whose slaves continue from this one's (as FMU states would)."""
    twin = fig2_system(system.friction.law)
    for mine, theirs in zip(system.slaves, twin.slaves):
        state = mine.save()
        theirs.restore(state)
        mine.free_state(state)
    return twin


@pytest.mark.parametrize("name", ["implicit", "adaptive"])
def test_an_imported_state_continues_bit_identically(name):
    cls = {"implicit": ImplicitCoupling, "adaptive": AdaptiveCoupling}[name]
    stop = round(2 * SCALES.period * NS)
    system = fig2_system()
    original = cls(step=1e-3 if name == "implicit" else None, tol=1e-4)
    original.prepare(system, SCALES)
    point, _ = advance_n(original, system, system.start_point(), 40, stop)
    state = json.loads(json.dumps(original.export_state()))
    twin_system = clone_slaves(system)
    imported = cls(step=1e-3 if name == "implicit" else None, tol=1e-4)
    imported.prepare(twin_system, Scales(1.0, 1.0, SCALES.period))  # overridden by the state
    imported.import_state(state)
    _, ahead = advance_n(original, system, point, 60, stop)
    _, again = advance_n(imported, twin_system, point, 60, stop)
    # (60 advances: 60 points of the implicit; 60 steps, some rejected or landed, of the adaptive)
    assert len(ahead) >= 40 and same_points(ahead, again)
    assert imported.counters == original.counters
    # and the state is what makes it so: a fresh algorithm on the same slaves goes elsewhere
    fresh_system = clone_slaves(twin_system)
    fresh = cls(step=1e-3 if name == "implicit" else None, tol=1e-4)
    fresh.prepare(fresh_system, SCALES)
    if name == "adaptive":
        _, other = advance_n(fresh, fresh_system, again[-1], 10, stop)
        _, ahead2 = advance_n(original, system, ahead[-1], 10, stop)
        assert not same_points(other, ahead2)


def test_an_imported_implicit_state_continues_bit_identically_after_a_stick():
    """A Stribeck law (its loop has a gain, so slip steps predict their root) stuck before the
    export: the friction's bounds at that stick are carried state too (they turn the stepped
    trials off), and the imported coupling continues bit-identically. Before, the implicit
    coupling did not export them and went on with the stepped trials on (other points
    within the root tolerance, other counters)."""
    from tribofmu.physics.laws.mixed import MixedLaw

    law = MixedLaw(mu_friction=0.4, mu_static=0.6, v_stribeck=0.03, stribeck_exponent=1.0, m=5.0, S=1.0)
    stop = round(2 * SCALES.period * NS)
    system = fig2_system(law)
    original = ImplicitCoupling(step=1e-3, tol=1e-4)
    original.prepare(system, SCALES)
    point, before = advance_n(original, system, system.start_point(), 40, stop)
    assert any(p.mode.stuck for p in before)
    state = json.loads(json.dumps(original.export_state()))
    assert state["stick_bounds"] is not None
    twin_system = clone_slaves(system)
    imported = ImplicitCoupling(step=1e-3, tol=1e-4)
    imported.prepare(twin_system, Scales(1.0, 1.0, SCALES.period))
    imported.import_state(state)
    _, ahead = advance_n(original, system, point, 60, stop)
    _, again = advance_n(imported, twin_system, point, 60, stop)
    assert same_points(ahead, again) and imported.counters == original.counters


def test_export_state_is_plain_json_that_round_trips_exactly():
    system = fig2_system()
    algorithm = AdaptiveCoupling(tol=1e-4)
    algorithm.prepare(system, SCALES)
    advance_n(algorithm, system, system.start_point(), 30, round(SCALES.period * NS))
    state = algorithm.export_state()
    assert json.loads(json.dumps(state, allow_nan=False)) == state
    assert state["counters"]["steps"] == algorithm.counters.steps > 0
    # what it exports is what it carries: imported into a fresh coupling, exported again alike
    fresh = AdaptiveCoupling(tol=1e-4)
    fresh.prepare(clone_slaves(system), Scales(1.0, 1.0, SCALES.period))
    fresh.import_state(json.loads(json.dumps(state)))
    assert fresh.export_state() == state


@pytest.mark.parametrize("missing", [*AdaptiveCoupling.state_names, "scales", "counters"])
def test_a_state_without_one_of_its_names_is_refused_naming_it(missing):
    system = fig2_system()
    algorithm = AdaptiveCoupling()
    algorithm.prepare(system, SCALES)
    state = algorithm.export_state()
    del state[missing]
    with pytest.raises(ValueError, match=missing):
        AdaptiveCoupling().import_state(state)


def test_a_state_without_its_error_estimate_is_refused_naming_it():
    system = fig2_system()
    algorithm = AdaptiveCoupling()
    algorithm.prepare(system, SCALES)
    state = algorithm.export_state()
    del state["estimate"]
    fresh = AdaptiveCoupling()
    fresh.prepare(system, SCALES)
    with pytest.raises(ValueError, match="estimate"):
        fresh.import_state(state)


# -- the pair model's snapshot -----------------------------------------------------------------

def host_steps(model, t_ns, count, h_ns, A, omega=OMEGA):
    """Host steps of h_ns with the drive of eqs. (1)-(2) given at each step's start."""
    points = []
    for _ in range(count):
        t = t_ns / NS
        _, V, a = drive(t, A, omega)
        points.append(model.step(t, h_ns / NS, V, a, model.friction.n, 290.0))
        t_ns += h_ns
    return t_ns, points


# (law, M, K, A, n): fig. 2's rig, a shear-thinning fluid, fig. 6's boundary lubricant
PAIRS = {"dry": (DRY_LAW, 0.6, 7000.0, 2e-3, -20.0),
         "fluid": (FluidLaw(m=25.0, gamma=-0.5), 0.6, 7000.0, 2e-3, -20.0),
         "boundary": (BoundaryLaw(m=0.05, gamma=-2 / 3, S=3e-9), 0.7, 1300.0, 1.4e-6, -1e6)}


@pytest.mark.parametrize("pair", PAIRS)
def test_pair_snapshot_through_json_continues_identically(pair):
    law, M, K, A, n = PAIRS[pair]
    parameters = PairParameters(M=M, K=K, x0=0.0, v0=0.0, law=law, f0=0.0, tol=1e-3)
    model = PairModel(parameters, 0.0, 0.0, drive(0.0, A, OMEGA)[2], n, 290.0)
    h_ns = 2_000_000
    t_ns, _ = host_steps(model, 0, 25, h_ns, A)
    snapshot = json.loads(json.dumps(model.snapshot()))
    if pair == "boundary":  # the lubricant's state is part of it
        assert model.friction.f != 0.0 and model.friction.dv_previous is not None
    copy_model = PairModel.from_snapshot(parameters, snapshot)
    _, ahead = host_steps(model, t_ns, 15, h_ns, A)
    _, again = host_steps(copy_model, t_ns, 15, h_ns, A)
    assert same_points(ahead, again)
    assert copy_model.algorithm.counters == model.algorithm.counters
    # a host's set-FMU-state: rewind the model itself to the snapshot and redo
    rewound = PairModel.from_snapshot(parameters, json.loads(json.dumps(snapshot)))
    _, redo = host_steps(rewound, t_ns, 15, h_ns, A)
    assert same_points(redo, ahead)
