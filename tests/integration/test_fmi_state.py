"""The FMI state machine, enforced: every row of the README's state table, for every FMU,
FMI 2.0 and FMI 3.0 builds, through fmpy's low-level ``FMU2Slave``/``FMU3Slave``.

Each test asserts the status the host receives, the Error-status log message naming the
call (and the variable and value), and that the refused call had no effect. The status of a
refusal is fmi2Error/fmi3Error where the FMU's binary is the native loader (it returns the
status the refusal logs); pythonfmu 0.7.0's and pythonfmu3 0.3.4's C++ wrappers alone can
only return OK for a Python method that does not raise (the refusal is then the logged error
and, where the host may believe something was set, every following doStep is refused) and
fmi2Discard / fmi3Error for a refused doStep. See :mod:`tribofmu.fmu.base` and the README.

Integration tier: the FMUs are built from the working tree (``fmu_dir``, ``fmu3_dir``).
"""
from __future__ import annotations

import json
import math
import zipfile

import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

from tribofmu.master.fmu_files import extract

from fmi_harness import FMU_NAMES

pytestmark = pytest.mark.integration

OK, DISCARD, ERROR = 0, 2, 3
LOADERS = ("binaries/linux64/libpythonfmu-export.so", "binaries/x86_64-linux/libpythonfmu-export.so")
VERSIONS = (2, 3)
CASES = [(fmi, name) for fmi in VERSIONS for name in FMU_NAMES]
IDS = [f"fmi{fmi}-{name}" for fmi, name in CASES]
# A parameter value each model refuses when initialization ends.
BAD_PARAMETER = {"Friction": ("regime", 9), "BlockSpring": ("M", -1.0), "Drive": ("omega", -1.0),
                 "Thermal": ("C", -1.0), "Load": ("program", 9), "TriboPair": ("M", -1.0)}
INPUT = {"Friction": "dv", "BlockSpring": "F", "Thermal": "P", "TriboPair": "V"}  # a Real input
H = 1e-3  # s


class Probe:
    """One instance of an FMI 2.0 or 3.0 build, every call answered with its status."""

    def __init__(self, fmu_dir, fmu3_dir, fmi: int, name: str, instance: str = "probe"):
        path = (fmu3_dir if fmi == 3 else fmu_dir) / f"{name}.fmu"
        self.fmi, self.name = fmi, name
        md = read_model_description(str(path))
        with zipfile.ZipFile(path) as archive:
            # pythonfmu's binary behind the native loader, which returns the status a refusal
            # logs (fmi2Error); pythonfmu's binary alone returns OK from all but doStep
            loader = any(name in LOADERS for name in archive.namelist())
        self.refused = ERROR if loader else OK
        self.step_refused = ERROR if loader or fmi == 3 else DISCARD  # pythonfmu3: do_step's choice
        self.vars = {v.name: v for v in md.modelVariables}
        self.messages: list[tuple[int, str]] = []
        kwargs = dict(guid=md.guid, unzipDirectory=str(extract(path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance)
        if fmi == 3:
            from fmpy.fmi3 import FMU3Slave

            self.fmu = FMU3Slave(**kwargs)
            self.fmu.instantiate(loggingOn=True, logMessage=self._log3)
        else:
            from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
            from fmpy import calloc, free
            from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE

            self.fmu = FMU2Slave(**kwargs)
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self._callbacks = callbacks
            self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.result = None

    def _log2(self, env, instance, status, category, message):
        self.messages.append((int(status), message.decode().replace("%%", "%")))

    def _log3(self, env, status, category, message):
        self.messages.append((int(status), message.decode()))

    # -- calls: each returns the status --------------------------------------------------
    def call(self, function: str, *args, **kwargs) -> int:
        try:
            self.result = getattr(self.fmu, function)(*args, **kwargs)
            return OK
        except FMICallException as exc:
            self.result = None
            return exc.status

    def errors(self, mark: int) -> list[str]:
        return [text for status, text in self.messages[mark:] if status >= ERROR]

    def logged(self, mark: int, *parts: str) -> bool:
        return any(all(p in text for p in parts) for text in self.errors(mark))

    def _typed(self, kind: str) -> str:
        if self.fmi == 3:
            return {"Real": "Float64", "Integer": "Int32"}.get(kind, kind)
        return kind

    def kind(self, name: str) -> str:
        return {"Float64": "Real", "Int32": "Integer"}.get(self.vars[name].type, self.vars[name].type)

    def set(self, name: str, value, kind: str | None = None) -> int:
        kind = self._typed(kind or self.kind(name))
        return self.call(f"set{kind}", [self.vars[name].valueReference], [value])

    def set_vr(self, vr: int, value, kind: str) -> int:
        return self.call(f"set{self._typed(kind)}", [vr], [value])

    def get(self, name: str) -> tuple[int, object]:
        status = self.call(f"get{self._typed(self.kind(name))}", [self.vars[name].valueReference])
        return status, (self.result[0] if self.result else None)

    def get_vr(self, vr: int, kind: str = "Real") -> tuple[int, object]:
        status = self.call(f"get{self._typed(kind)}", [vr])
        return status, (self.result[0] if self.result else None)

    def enter(self) -> int:
        if self.fmi == 3:
            return self.call("enterInitializationMode", startTime=0.0)
        status = self.call("setupExperiment", startTime=0.0)
        return max(status, self.call("enterInitializationMode"))

    def exit(self) -> int:
        return self.call("exitInitializationMode")

    def start(self, **parameters) -> None:
        assert self.enter() == OK
        for name, value in parameters.items():
            assert self.set(name, value) == OK
        self.exit()  # refused if a parameter is

    def step(self, t: float = 0.0, h: float = H) -> int:
        if self.fmi == 3:
            return self.call("doStep", t, h, noSetFMUStatePriorToCurrentPoint=False)
        return self.call("doStep", t, h)

    def save(self):
        assert self.call("getFMUState" if self.fmi == 3 else "getFMUstate") == OK
        return self.result

    def restore(self, state) -> int:
        return self.call("setFMUState" if self.fmi == 3 else "setFMUstate", state)

    def serialize(self, state) -> bytes:
        assert self.call("serializeFMUState" if self.fmi == 3 else "serializeFMUstate", state) == OK
        return self.result

    def deserialize(self, blob: bytes):
        assert self.call("deserializeFMUState" if self.fmi == 3 else "deSerializeFMUstate", blob) == OK
        return self.result

    def no_value(self, value) -> bool:
        """What a refused read gives: NaN with fmi2OK from pythonfmu's binary; with fmi2Error
        from the native loader, fmpy raises and hands no value on (None)."""
        return value is None if self.refused == ERROR else math.isnan(value)

    def first(self, causality: str) -> str:
        return next(n for n, v in self.vars.items() if v.causality == causality)

    def close(self) -> None:
        self.fmu.freeInstance()


@pytest.fixture
def probe(fmu_dir, fmu3_dir, request):
    made = []

    def make(fmi, name, instance="probe"):
        made.append(Probe(fmu_dir, fmu3_dir, fmi, name, instance))
        return made[-1]

    yield make
    for p in made:
        p.close()


# -- doStep outside step mode ------------------------------------------------------------------
@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_do_step_before_initialization_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    assert p.step() == p.step_refused
    assert p.logged(0, "DoStep: not allowed in instantiated")
    p.enter()
    mark = len(p.messages)
    assert p.step() == p.step_refused
    assert p.logged(mark, "DoStep: not allowed in initialization mode")
    assert p.exit() == OK
    assert p.step() == OK  # the same instance, now initialized, steps


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_do_step_after_terminate_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    assert p.step() == OK
    assert p.call("terminate") == OK
    mark = len(p.messages)
    assert p.step(H) == p.step_refused
    assert p.logged(mark, "DoStep: not allowed in terminated")


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
@pytest.mark.parametrize("h", [0.0, -H, math.nan, math.inf])
def test_do_step_with_a_bad_step_size_is_refused(probe, fmi, name, h):
    p = probe(fmi, name)
    p.start()
    assert p.step(0.0, h) == p.step_refused
    assert p.logged(0, "communication step size", str(h))
    assert p.step(0.0, H) == OK


# -- lifecycle calls in the wrong state ----------------------------------------------------
@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_lifecycle_calls_in_the_wrong_state_are_refused_without_effect(probe, fmi, name):
    p = probe(fmi, name)
    assert p.exit() == p.refused and p.logged(0, "ExitInitializationMode: not allowed in instantiated")
    mark = len(p.messages)
    assert p.call("terminate") == p.refused and p.logged(mark, "Terminate: not allowed in instantiated")
    p.start()
    mark = len(p.messages)
    if fmi == 2:
        assert p.call("enterInitializationMode") == p.refused
        assert p.logged(mark, "EnterInitializationMode: not allowed in step mode")
    assert p.exit() == p.refused and p.logged(mark, "ExitInitializationMode: not allowed in step mode")
    assert p.step() == OK  # still in step mode


# -- getters ----------------------------------------------------------------------------------
@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_get_before_initialization_mode_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    output = p.first("output")
    status, value = p.get(output)
    assert status == p.refused and p.no_value(value)
    assert p.logged(0, "Get", "not allowed before", "EnterInitializationMode")
    p.enter()
    mark = len(p.messages)
    status, value = p.get(p.first("parameter"))  # allowed from initialization mode on
    assert status == OK and not p.errors(mark)


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_unknown_value_reference_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    unknown = max(v.valueReference for v in p.vars.values()) + 1000
    for _ in range(4):  # the crash: repeated reads of an unknown reference
        status, value = p.get_vr(unknown)
        assert status == p.refused and p.no_value(value)
    assert p.logged(0, "Get", f"unknown value reference {unknown}")
    assert p.step() == OK  # reading changes nothing
    mark = len(p.messages)
    assert p.set_vr(unknown, 1.0, "Real") == p.refused
    assert p.logged(mark, "Set", f"unknown value reference {unknown}", "not set")
    mark = len(p.messages)
    assert p.step(H) == p.step_refused  # the host may believe it set something
    assert p.logged(mark, "DoStep", f"unknown value reference {unknown}")


# -- setters ---------------------------------------------------------------------------------
@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_parameters_and_inputs_are_set_where_fmi_allows(probe, fmi, name):
    p = probe(fmi, name)
    parameter = p.first("parameter")
    start = p.vars[parameter].start
    assert p.enter() == OK
    assert p.set(parameter, type(p.get(parameter)[1])(start)) == OK  # initialization mode
    assert p.exit() == OK and p.step() == OK
    if name in INPUT:  # inputs in step mode
        assert p.set(INPUT[name], 0.0) == OK
        assert p.step(H) == OK
    assert not p.errors(0), p.errors(0)


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_fixed_parameter_after_initialization_is_refused_and_not_applied(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    parameter = p.first("parameter")
    _, before = p.get(parameter)
    new = before + 1 if not isinstance(before, bool) else not before
    assert p.set(parameter, new) == p.refused
    assert p.logged(0, "Set", f"{parameter} is a fixed parameter", "ExitInitializationMode")
    assert p.get(parameter)[1] == before  # not applied mid-run
    assert p.step() == p.step_refused
    assert p.logged(0, "DoStep", f"{parameter} is a fixed parameter")
    assert p.call("reset") == OK  # the FMI route to a new parameter value
    p.start(**{parameter: new})
    assert p.get(parameter)[1] == new and p.step() == OK


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_setting_an_output_or_a_wrong_type_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    output = p.first("output")
    assert p.set(output, 1.0) == p.refused
    assert p.logged(0, "Set", f"{output} is an output")
    real = next(n for n, v in p.vars.items() if p.kind(n) == "Real" and v.causality == "parameter")
    mark = len(p.messages)
    assert p.set(real, 1, kind="Integer") == p.refused
    assert p.logged(mark, "SetInt", f"{real} (value reference", "is not a Int")
    assert p.step() == p.step_refused


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_set_after_terminate_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    assert p.call("terminate") == OK
    variable = INPUT.get(name, p.first("parameter"))
    _, before = p.get(variable)
    assert p.set(variable, before) == p.refused
    assert p.logged(0, "Set", f"{variable} cannot be set after", "Terminate")


@pytest.mark.parametrize("fmi, name", [c for c in CASES if c[1] in INPUT],
                         ids=[i for i, c in zip(IDS, CASES) if c[1] in INPUT])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused_when_set_and_never_used(probe, fmi, name, bad):
    p = probe(fmi, name)
    p.start()
    variable = INPUT[name]
    assert p.set(variable, 1e-3) == OK and p.step() == OK
    mark = len(p.messages)
    assert p.set(variable, bad) == p.refused
    assert p.logged(mark, "Set", f"{variable} must be finite, got {bad}", "refused")
    assert p.get(variable)[1] == 1e-3  # never stored
    mark = len(p.messages)
    assert p.step(H) == p.step_refused  # nor stepped with the previous value
    assert p.logged(mark, f"{variable} must be finite, got {bad}")
    assert p.set(variable, 2e-3) == OK and p.step(H) == OK  # replaced: steps again


# The outputs computed from the inputs and parameters at the time they are read.
READ_WHILE_REFUSED = [("Friction", "dv", math.nan, "F"), ("BlockSpring", "V", math.inf, "dv"),
                      ("Drive", "omega", -1.0, "X"), ("Load", "program", 9, "n")]


@pytest.mark.parametrize("fmi", VERSIONS)
@pytest.mark.parametrize("name, variable, bad, output", READ_WHILE_REFUSED,
                         ids=[case[0] for case in READ_WHILE_REFUSED])
def test_output_read_while_a_value_is_refused_is_an_error_not_a_made_up_value(
        probe, fmi, name, variable, bad, output):
    p = probe(fmi, name)
    if p.vars[variable].causality == "parameter":
        p.start(**{variable: bad})
    else:
        p.start()
        p.set(variable, bad)
    mark = len(p.messages)
    status, value = p.get(output)
    assert status == p.refused and p.no_value(value)  # never 0.0 with no word
    assert p.logged(mark, "Get", f"{output} cannot be evaluated", variable)


# -- initialization with a bad parameter ---------------------------------------------------------
@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_bad_parameter_fails_exit_initialization_mode(probe, fmi, name):
    p = probe(fmi, name)
    parameter, bad = BAD_PARAMETER[name]
    assert p.enter() == OK
    assert p.set(parameter, bad) == OK  # ranges are checked where initialization ends
    mark = len(p.messages)
    assert p.exit() == p.refused
    assert p.logged(mark, "ExitInitializationMode", parameter, str(bad))
    mark = len(p.messages)
    assert p.step() == p.step_refused
    assert p.logged(mark, parameter, str(bad))


@pytest.mark.parametrize("fmi", VERSIONS)
def test_pair_with_an_unknown_regime_fails_initialization(probe, fmi):
    p = probe(fmi, "TriboPair")
    p.enter()
    p.set("regime", 9)
    assert p.exit() == p.refused and p.logged(0, "ExitInitializationMode", "regime must be 0 (dry)", "got 9")
    assert p.step() == p.step_refused
    status, x = p.get("x")  # the pair's outputs are its state: readable, never stepped
    assert status == OK and x == float(p.vars["x0"].start)


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_non_finite_parameter_is_refused_when_set(probe, fmi, name):
    p = probe(fmi, name)
    parameter = next(n for n, v in p.vars.items() if v.causality == "parameter" and p.kind(n) == "Real")
    p.enter()
    assert p.set(parameter, math.nan) == p.refused
    assert p.logged(0, "Set", f"{parameter} must be finite, got nan", "refused")
    assert p.exit() == p.refused and p.logged(0, "ExitInitializationMode", f"{parameter} must be finite")
    assert p.step() == p.step_refused


# -- FMU states -------------------------------------------------------------------------------
OTHER = {"Friction": "BlockSpring"}  # the model whose state is offered; others get Friction's


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_state_of_another_model_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    other = probe(fmi, OTHER.get(name, "Friction"), "other")
    p.start()
    other.start()
    assert p.step() == OK
    foreign = other.save()
    mark = len(p.messages)
    assert p.restore(foreign) == p.refused
    if p.logged(mark, "SetFMU", "not an FMU state of this FMU"):
        # the native loader refused a state its binary never made: fmi2Error, nothing restored
        assert p.refused == ERROR and p.step(H) == OK
    else:  # refused by our model, which cannot tell the host but by the next step
        assert p.logged(mark, "SetFMU", "an FMU state of", OTHER.get(name, "Friction"), "not restored")
        assert p.step(H) == p.step_refused  # the host believes it restored: never step on silently


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_state_of_another_build_is_refused(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    blob = json.loads(p.serialize(p.save()))
    module, model = blob["_model"].rsplit(".", 1)
    blob["_model"] = f"{module[:-len(name) - 13]}000000000000_{name}.{model}"  # another source hash
    assert blob["_model"] != json.loads(p.serialize(p.save()))["_model"]
    mark = len(p.messages)
    assert p.restore(p.deserialize(json.dumps(blob).encode())) == p.refused
    assert p.logged(mark, "SetFMU", "not of this model and build", "not restored")
    assert p.step() == p.step_refused


@pytest.mark.parametrize("fmi, name", CASES, ids=IDS)
def test_blob_that_is_no_state_is_refused_and_a_good_state_recovers(probe, fmi, name):
    p = probe(fmi, name)
    p.start()
    good = p.save()
    garbage = p.deserialize(b"\x00not a state")  # deserializing never takes the instance down
    mark = len(p.messages)
    assert p.restore(garbage) == p.refused
    assert p.logged(mark, "SetFMU", "cannot be deserialized", "not restored")
    assert p.step() == p.step_refused
    assert p.restore(good) == OK and p.step() == OK  # a good state leaves the error state


@pytest.mark.parametrize("fmi", VERSIONS)
def test_reset_leaves_the_error_state(probe, fmi):
    p = probe(fmi, "BlockSpring")
    p.start()
    p.set("M", 2.0)
    assert p.step() == p.step_refused
    assert p.call("reset") == OK
    p.start()
    assert p.step() == OK and p.get("M")[1] == float(p.vars["M"].start)


@pytest.mark.parametrize("fmi", VERSIONS)
def test_simulate_fmu_with_a_bad_parameter_raises(fmu_dir, fmu3_dir, fmi):
    """The issue's case: fmpy's simulate_fmu with M = -1 used to return two rows and no error."""
    from fmpy import simulate_fmu

    path = (fmu3_dir if fmi == 3 else fmu_dir) / "TriboPair.fmu"
    with zipfile.ZipFile(path) as archive:
        loader = any(name in LOADERS for name in archive.namelist())
    if fmi == 2 and not loader:
        pytest.skip("pythonfmu's binary alone answers fmi2OK to exitInitializationMode and fmi2Discard "
                    "to doStep, where fmpy stops without an error (README: state table)")
    with pytest.raises(FMICallException, match="status 3"):
        simulate_fmu(str(path), start_values={"M": -1.0}, stop_time=0.01, output_interval=1e-3,
                     logger=lambda *args: None)


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_state_saved_over_is_the_new_state_and_the_same_handle(fmi, fmu_dir, fmu3_dir):
    """The master saves each communication point's state over the last point's (one call where
    a free and a save were two): behind the native loader FMI's get into a non-NULL state
    overwrites it in place. Restoring it then gives the new state exactly, the handle is the
    same, and freeing it once frees it."""
    from tribofmu.master.instance import FMUInstance

    folder = fmu_dir if fmi == 2 else fmu3_dir
    slave = FMUInstance(folder / "BlockSpring.fmu", instance="block", parameters={"M": 0.7, "K": 1300.0})
    try:
        assert slave.overwrites_states  # the native loader, not pythonfmu's own binary
        r = slave.refs
        slave.set_reals([r["F"], r["F_rate"]], [0.4, -2.0])
        slave.do_step(0.0, 1e-3)
        saved = slave.save()
        handle = saved.value
        slave.set_reals([r["F"]], [0.1])
        slave.do_step(1e-3, 2e-3)
        at_new_point = slave.get_reals([r["F"], r["x"], r["v"], r["a"]])
        assert slave.save_into(saved) and saved.value == handle
        slave.set_reals([r["F"]], [-3.0])
        slave.do_step(3e-3, 1e-3)
        slave.restore(saved)
        assert slave.get_reals([r["F"], r["x"], r["v"], r["a"]]) == at_new_point
        assert slave.calls_by_kind["free"] == 0
        slave.free_state(saved)
    finally:
        slave.close()
