"""FMI 3.0 builds (``tribofmu build --fmi 3``): the same adapters on pythonfmu3, checked
against the FMI 2.0 builds and driven by the master's :class:`~tribofmu.master.instance.FMUInstance`.

Integration tier: both versions are built from the working tree (``fmu_dir``, ``fmu3_dir``).
"""
from __future__ import annotations

import math
import struct
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi3 import FMU3Slave

from tribofmu import api
from tribofmu.build import private_package_name
from tribofmu.master.instance import FMUCallError, FMUInstance, extract

from fmi_harness import FMU_NAMES
from scenes import PAPER_SCENES, scene

pytestmark = pytest.mark.integration

# Fig. 6 takes ~30 s per full run: one period still covers melting and sticking.
SHORTENED = {"fig6_boundary": {"time.periods": 1.0, "time.window": [0.0, 1.0]}}


def _bits(values) -> list[bytes]:
    return [struct.pack("<d", float(v)) for v in values]


def _variables(md) -> dict[str, tuple]:
    """What a host sees of each variable, in version-neutral terms."""
    kinds = {"Real": "float", "Float64": "float", "Integer": "int", "Int32": "int", "Boolean": "bool"}
    return {v.name: (kinds[v.type], v.causality, v.variability, v.initial, v.start, v.unit, v.description)
            for v in md.modelVariables if v.causality != "independent"}


def _dependencies(md) -> dict[str, set[str]]:
    return {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}


@pytest.mark.parametrize("name", FMU_NAMES)
def test_fmi3_build_declares_what_the_fmi2_build_declares(fmu_dir, fmu3_dir, name):
    md2 = read_model_description(str(fmu_dir / f"{name}.fmu"))
    md3 = read_model_description(str(fmu3_dir / f"{name}.fmu"))  # validates, as fmpy does
    assert (md2.fmiVersion, md3.fmiVersion) == ("2.0", "3.0")
    assert _variables(md3) == _variables(md2)
    assert _dependencies(md3) == _dependencies(md2)
    assert [v.name for v in md3.modelVariables if v.causality == "independent"] == ["time"]
    assert md3.coSimulation.canGetAndSetFMUstate and md3.coSimulation.canSerializeFMUstate
    assert (md3.description, md3.author, md3.version) == (md2.description, md2.author, md2.version)
    assert md3.defaultExperiment.stepSize == md2.defaultExperiment.stepSize


def test_fmi3_fmus_ship_their_own_private_package(fmu3_dir):
    private = private_package_name(fmi=3)
    assert private != private_package_name(fmi=2)  # both versions may share one process
    with zipfile.ZipFile(fmu3_dir / "Drive.fmu") as archive:
        version_file = archive.read(f"resources/{private}/fmu/fmi_version.py").decode()
        script = archive.read(f"resources/{private}_Drive.py").decode()
    assert "\nFMI_VERSION = 3\n" in version_file
    assert "(Fmi3Slave)" in script and "tribofmu." not in script


@pytest.mark.parametrize("name", PAPER_SCENES)
def test_fmi3_and_fmi2_builds_agree_on_paper_scene(fmu_dir, fmu3_dir, name):
    overrides = SHORTENED.get(name)
    r2 = api.simulate(scene(name), overrides, fmu_dir=fmu_dir, build=False, max_wall=None)
    r3 = api.simulate(scene(name), overrides, fmu_dir=fmu3_dir, build=False, max_wall=None)
    assert r2.ok and r3.ok, (r2.message, r3.message)
    assert r3.stats["communication_steps"] == r2.stats["communication_steps"]
    nrms_v = math.sqrt(np.mean((r3.v - r2.v) ** 2)) / np.max(np.abs(r2.v))
    assert nrms_v <= 1e-9
    for key in ("x", "v", "F", "f", "stuck"):
        a, b = getattr(r2, key), getattr(r3, key)
        assert np.max(np.abs(b - a)) <= 1e-9 * max(1.0, np.max(np.abs(a))), key


def test_slave_drives_fmi3_with_typed_errors_and_state(fmu3_dir):
    slave = FMUInstance(fmu3_dir / "BlockSpring.fmu", instance="block%s", parameters={"M": 0.7, "K": 1300.0})
    try:
        assert slave.fmi_version == 3
        r = slave.refs
        slave.set_reals([r["F"], r["F_rate"]], [0.4, -2.0])
        slave.do_step(0.0, 1e-3)
        saved = slave.save()
        slave.set_reals([r["F"]], [0.1])
        slave.do_step(1e-3, 2e-3)
        after = slave.get_reals([r["x"], r["v"], r["a"]])
        slave.restore(saved)  # the state holds the inputs too: F is 0.4 again
        assert slave.get_reals([r["F"]]) == [0.4]
        slave.set_reals([r["F"]], [0.1])
        slave.do_step(1e-3, 2e-3)
        assert _bits(slave.get_reals([r["x"], r["v"], r["a"]])) == _bits(after)
        slave.free_state(saved)

        before = slave.get_reals([r["x"], r["v"]])
        with pytest.raises(FMUCallError) as caught:
            slave.set_reals([r["F"]], [math.nan])  # refused here behind the native loader,
            slave.do_step(3e-3, 1e-3)  # else the step is
        error = caught.value
        # a bad value is the host's to fix: fmi3Error (pythonfmu3 lets doStep choose its
        # status; a step that fails numerically is fmi3Discard)
        assert error.status == 3 and error.call in ("fmi3SetFloat64", "fmi3DoStep")
        assert "fmi3Error" in str(error)
        # FMI 3.0 messages are plain text: the instance name's "%s" arrives unescaped
        assert any(m.startswith("block%s: ") and "F must be finite, got nan" in m for m in error.messages), \
            error.messages
        assert _bits(slave.get_reals([r["x"], r["v"]])) == _bits(before)  # refused step: untouched
    finally:
        slave.close()


def test_fmi3_serialized_state_continues_bit_identically(fmu3_dir):
    """Boundary friction keeps f and the last dv as state: serialize, deserialize, go on."""
    path = fmu3_dir / "Friction.fmu"
    md = read_model_description(str(path))
    ref = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=str(extract(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="friction")
    fmu.instantiate(logMessage=lambda *args: None)
    try:
        fmu.enterInitializationMode()
        fmu.setInt32([ref["regime"]], [2])
        fmu.setFloat64([ref[k] for k in ("S", "m", "gamma")], [3e-9, 0.05, -2.0 / 3.0])
        fmu.exitInitializationMode()

        def steps(first, count):
            out = []
            for k in range(first, first + count):
                fmu.setFloat64([ref["dv"], ref["n"]], [1e-3 * math.sin(0.9 * k), -1e6])
                fmu.doStep(k * 1e-3, 1e-3, noSetFMUStatePriorToCurrentPoint=False)
                out += _bits(fmu.getFloat64([ref["F"], ref["f"]]))
            return out

        steps(0, 5)
        blob = fmu.serializeFMUState(fmu.getFMUState())
        first = steps(5, 5)
        fmu.setFMUState(fmu.deserializeFMUState(blob))
        assert steps(5, 5) == first
    finally:
        fmu.terminate()
        # fmpy's freeInstance also unloads the library: with FMUs built in this process that
        # made the test process abort at exit now and then (see FMUInstance.close)
        fmu.fmi3FreeInstance(fmu.component)
