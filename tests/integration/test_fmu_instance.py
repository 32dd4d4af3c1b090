"""The master's hot path (:class:`tribofmu.master.instance.FMUInstance`: set and get reals, do a
step, restore a state) calls the FMU library's functions itself: a refused call still arrives as
one :class:`FMUCallError` naming the instance, the FMI function, the status and the FMU's own
messages, FMI 2.0 and 3.0. A closed instance's fmpy object makes the next instance of the same
FMU, never one still open.

Integration tier: the FMUs are built from the working tree (``fmu_dir``, ``fmu3_dir``).
"""
from __future__ import annotations

import ctypes
import math

import pytest

from tribofmu.master.instance import FMUCallError, FMUInstance, check_arguments

pytestmark = pytest.mark.integration


@pytest.fixture(params=[2, 3], ids=["fmi2", "fmi3"])
def block(request, fmu_dir, fmu3_dir):
    folder = fmu3_dir if request.param == 3 else fmu_dir
    slave = FMUInstance(folder / "BlockSpring.fmu", instance="block", parameters={"M": 0.6})
    yield slave
    slave.close()


def refused(call, *args) -> FMUCallError:
    with pytest.raises(FMUCallError) as caught:
        call(*args)
    return caught.value


def test_each_hot_path_call_that_is_refused_names_its_function_status_and_reason(block):
    fmi = f"fmi{block.fmi_version}"
    real = "Float64" if block.fmi_version == 3 else "Real"
    r = block.refs
    good = block.save()
    unknown = max(r.values()) + 1000
    error = refused(block.get_reals, [unknown])
    assert (error.call, error.status) == (f"{fmi}Get{real}", 3)
    assert any(f"unknown value reference {unknown}" in m for m in error.messages), error.messages

    error = refused(block.do_step, 0.0, 0.0)
    assert (error.call, error.status) == (f"{fmi}DoStep", 3)
    assert any("communication step size" in m for m in error.messages), error.messages

    error = refused(block.set_reals, [r["F"]], [math.nan])
    assert (error.call, error.status) == (f"{fmi}Set{real}", 3)
    assert any("F must be finite, got nan" in m for m in error.messages), error.messages

    block.restore(good)  # a good state leaves the error state the refused set left
    block.do_step(0.0, 1e-3)
    block.free_state(good)
    assert block.calls_by_kind == {**block.calls_by_kind, "get": 1, "set": 1, "doStep": 2, "save": 1,
                                   "restore": 1, "free": 1}


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_closed_instance_makes_the_next_and_closing_it_again_leaves_that_one_alone(fmi, fmu_dir, fmu3_dir):
    path = (fmu3_dir if fmi == 3 else fmu_dir) / "BlockSpring.fmu"
    first = FMUInstance(path, instance="block", parameters={"M": 0.6})
    first.close()
    second = FMUInstance(path, instance="block", parameters={"M": 0.6})  # made by first's fmpy object
    third = FMUInstance(path, instance="block", parameters={"M": 0.6})  # second is open: a new one
    try:
        first.close()  # again: must not terminate or free the instance its object made since
        for slave in (second, third):
            slave.set_reals([slave.refs["F"]], [1.0])
            slave.do_step(0.0, 1e-3)
            assert slave.get_reals([slave.refs["v"]])[0] > 0.0  # pushed by F = 1 N
    finally:
        second.close()
        third.close()


def test_a_restore_of_the_state_the_instance_holds_makes_no_call_and_any_change_makes_it_one(block):
    """Restoring the state the FMU stands in (saved or restored, and neither set nor stepped
    since; a get only reads) is no call, as a rejected try's block that never stepped; a set, a
    step or a refused call in between makes the restore a call, which puts the state back."""
    r = block.refs
    restores = lambda: block.calls_by_kind["restore"]  # noqa: E731
    start = block.save()
    x0 = block.get_reals([r["x"], r["v"]])
    block.restore(start)
    assert restores() == 0
    block.set_reals([r["F"], r["F_rate"]], [3.0, 0.0])
    block.restore(start)
    block.restore(start)  # (it holds start again)
    assert restores() == 1
    block.set_reals([r["F"], r["F_rate"]], [3.0, 0.0])
    block.do_step(0.0, 1e-2)
    assert block.get_reals([r["x"], r["v"]]) != x0
    block.restore(start)
    assert restores() == 2 and block.get_reals([r["x"], r["v"]]) == x0
    later = block.save()
    block.restore(start)
    assert restores() == 3
    refused(block.get_reals, [max(r.values()) + 1000])
    block.restore(start)
    assert restores() == 4
    for state in (start, later):
        block.free_state(state)


def test_get_and_set_reals_take_only_arguments_of_their_c_types(block):
    """Get and set reals are called without ctypes' per-call conversion, with arguments made
    once per set of references and checked then against the C signature: a Python int for the
    instance handle or the count (ctypes would pass it as a C int), an array of another type or
    a missing FMI 3.0 nValues is refused by name."""
    r = block.refs
    assert block.get_reals((r["x"], r["v"])) == block.get_reals([r["x"], r["v"]])  # tuple or list
    signature, made = block._real_signature, block._buffer((r["x"],))[1]
    check_arguments(signature, made)  # what the calls are made with
    wrong = {0: block._fmu.component, 1: (ctypes.c_int64 * 1)(r["x"]), 2: 1}
    for index, arg in wrong.items():
        with pytest.raises(TypeError, match="is not a"):
            check_arguments(signature, made[:index] + (arg,) + made[index + 1:])
    with pytest.raises(TypeError, match="arguments for"):
        check_arguments(signature, made[:-1])
