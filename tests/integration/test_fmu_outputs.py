"""Outputs computed from the state are computed once per state and never outlive it.

The framework (:mod:`tribofmu.fmu.base`) keeps the value of an output computed on demand (the
friction force, the drive's X, V, a, ...) until a call changes what it is computed from: a
doStep, setting an input or a parameter, restoring an FMU state. These tests read the outputs
through FMI (fmpy, FMI 2.0 and FMI 3.0 builds) right after each such call and compare them
with the value the physics gives for the new state; the last one counts the computations
in process.

Integration tier: the FMUs are built from the working tree (``fmu_dir``, ``fmu3_dir``).
"""
from __future__ import annotations

import math

import pytest

from tribofmu.master.instance import FMUCallError, FMUInstance

pytestmark = pytest.mark.integration

VERSIONS = (2, 3)
M_FLUID = 25.0  # N s/m: Newtonian fluid friction, F = m dv exactly
FLUID = dict(regime=1, m=M_FLUID, gamma=0.0)
BOUNDARY = dict(regime=2)  # the lubricant's f evolves: F depends on the state, not only on dv


@pytest.fixture
def instance(fmu_dir, fmu3_dir):
    made = []

    def make(fmi, name, **parameters):
        folder = fmu3_dir if fmi == 3 else fmu_dir
        made.append(FMUInstance(folder / f"{name}.fmu", instance=name.lower(), parameters=parameters))
        return made[-1]

    yield make
    for slave in made:
        slave.close()


def read(slave, *names):
    values = slave.get_reals([slave.refs[n] for n in names])
    return values[0] if len(values) == 1 else values


def set_(slave, **values):
    slave.set_reals([slave.refs[n] for n in values], list(values.values()))


@pytest.mark.parametrize("fmi", VERSIONS)
def test_an_output_read_after_setting_an_input_without_a_step_is_of_the_new_input(instance, fmi):
    friction = instance(fmi, "Friction", **FLUID)
    set_(friction, dv=0.01)
    friction.do_step(0.0, 1e-3)
    assert read(friction, "F") == M_FLUID * 0.01  # the value doStep computed, read
    for dv in (0.02, -0.03, 0.0):
        set_(friction, dv=dv)
        assert read(friction, "F") == M_FLUID * dv
        assert read(friction, "F") == M_FLUID * dv  # read again: the same


@pytest.mark.parametrize("fmi", VERSIONS)
def test_an_output_read_after_a_restore_is_of_the_restored_state(instance, fmi):
    friction = instance(fmi, "Friction", **BOUNDARY)
    set_(friction, n=-1e6, dv=0.05)
    for k in range(5):  # f evolves away from f0
        friction.do_step(k * 1e-3, 1e-3)
    saved = friction.save()
    at_save = read(friction, "F", "f", "F_mean")
    friction.do_step(5e-3, 1e-3)
    set_(friction, dv=0.2)
    moved_on = read(friction, "F", "f", "F_mean")
    assert moved_on != at_save
    friction.restore(saved)
    assert read(friction, "F", "f", "F_mean") == at_save
    set_(friction, dv=0.2)  # the restored state at the other input: as an instance never moved on
    friction.restore(saved)
    friction.free_state(saved)
    twin = instance(fmi, "Friction", **BOUNDARY)
    set_(twin, n=-1e6, dv=0.05)
    for k in range(5):
        twin.do_step(k * 1e-3, 1e-3)
    assert read(friction, "F", "f", "F_mean") == read(twin, "F", "f", "F_mean")


@pytest.mark.parametrize("fmi", VERSIONS)
def test_the_drive_reads_the_time_of_its_state(instance, fmi):
    drive = instance(fmi, "Drive", A=2e-3, omega=30.0)
    start = read(drive, "X", "V", "a")
    saved = drive.save()
    drive.do_step(0.0, 0.01)
    stepped = read(drive, "X", "V", "a")
    assert stepped[0] == pytest.approx(2e-3 * math.cos(30.0 * 0.01), rel=1e-12)
    drive.restore(saved)
    assert read(drive, "X", "V", "a") == start
    drive.do_step(0.0, 0.01)
    assert read(drive, "X", "V", "a") == stepped
    drive.free_state(saved)


@pytest.mark.parametrize("fmi", VERSIONS)
def test_a_refused_step_leaves_no_output_of_the_state_it_undid(instance, fmi):
    """Drive's X and V are finite at t = 1 s and computed there before a (A omega^2) is found
    to overflow: the step is refused, and X reads the start's value again, not the undone one."""
    amplitude = 1e300
    drive = instance(fmi, "Drive", A=amplitude, omega=13408.0)
    with pytest.raises(FMUCallError, match="outputs would not be finite"):
        drive.do_step(0.0, 1.0)
    assert read(drive, "X") == amplitude  # A cos(omega 0)


def test_each_output_is_computed_once_a_state():
    """In process: the force a doStep computed (its outputs must be finite) is the one the host
    reads; after setting dv, one read computes it once more, and further reads reuse it."""
    from tribofmu.fmu.models.Friction import Friction

    slave = Friction(instance_name="friction")
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    refs = {v.name: vr for vr, v in slave.vars.items()}
    slave.set_integer([refs["regime"]], [FLUID["regime"]])
    slave.exit_initialization_mode()
    law = slave.law()
    calls = []
    force = law.force
    object.__setattr__(law, "force", lambda *args: calls.append(args) or force(*args))
    F = [refs["F"]]
    slave.set_real([refs["dv"]], [0.01])
    assert slave.do_step(0.0, 1e-3) is True
    stepped = len(calls)  # the step's own (the mean force over the step) and its check of F
    first = slave.get_real(F)
    assert slave.get_real(F) == first and len(calls) == stepped
    slave.set_real([refs["dv"]], [0.02])
    second = slave.get_real(F)
    assert slave.get_real(F) == second != first and len(calls) == stepped + 1
    slave._set_fmu_state(slave._get_fmu_state())  # a restore: computed again when read
    assert slave.get_real(F) == second and len(calls) == stepped + 2


@pytest.mark.parametrize("fmi", VERSIONS)
def test_a_state_taken_before_a_reset_brings_its_parameters_back(instance, fmi):
    """A state refers to its parameter values instead of copying them each save; restored
    into the instance after fmi2Reset (other parameters), it sets them again."""
    block = instance(fmi, "BlockSpring", M=0.7, K=1300.0)
    set_(block, F=0.4)
    block.do_step(0.0, 1e-3)
    saved = block.save()
    block.do_step(1e-3, 1e-3)
    after = read(block, "x", "v", "a")
    block.call("reset")
    if fmi == 3:
        block.call("enterInitializationMode", startTime=0.0)
    else:
        block.call("setupExperiment", startTime=0.0)
        block.call("enterInitializationMode")
    block.call("exitInitializationMode")  # the default M and K
    assert read(block, "M", "K") != [0.7, 1300.0]
    block.restore(saved)
    assert read(block, "M", "K") == [0.7, 1300.0]
    block.do_step(1e-3, 1e-3)
    assert read(block, "x", "v", "a") == after
    block.free_state(saved)
