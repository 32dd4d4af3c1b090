"""An archive carries its scene: ``export-ssp --pair`` of every paper scene runs right in a
master that ignores the SSD's parameter bindings.

fmpy's ``simulate_ssp`` is that master: it is given only a stop time and a step size, both read
from the archive's DefaultExperiment (the step from libcosim's annotation there), no parameter
set. The FMU copies in the archive must then start from the scene's values, and the proposed
step must be one at which the pair meets 1e-3 nRMS(v) against tribofmu's own run of the scene.

The master runs in a child process that never imports tribofmu (as in ``test_ssp``): the
FMUs run the package copy they carry.
"""
from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from scenes import PAPER_SCENES, scene

pytestmark = [pytest.mark.integration, pytest.mark.external]

TARGET = 1e-3  # nRMS(v) on the scene's window
NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations"}
# Fig. 6's boundary lubricant costs ~30 s per full run in each of the two simulators; its
# first two periods hold melting, sliding and sticking already (CI budget).
SHORTENED = {"fig6_boundary": {"time.periods": 2.0, "time.window": [0.5, 2.0]}}

CHILD = """
import json, sys
import numpy as np
from fmpy.ssp.simulation import simulate_ssp
ssp, stop, h, out = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
result = simulate_ssp(ssp, stop_time=stop, step_size=h)  # no parameter set
np.savez(out, time=result["time"] + h, v=result["TriboPair.v"])  # fmpy stamps a step's start
"""


def archive_experiment(ssp) -> tuple[float, float]:
    """(stop time, step) [s] of the archive's DefaultExperiment."""
    root = ET.fromstring(zipfile.ZipFile(ssp).read("SystemStructure.ssd"))
    default = root.find("ssd:DefaultExperiment", NS)
    step = default.find("ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", NS)
    return float(default.get("stopTime")), float(step.get("baseStepSize"))


def start_values(fmu_bytes: bytes) -> dict[str, str]:
    import io

    with zipfile.ZipFile(io.BytesIO(fmu_bytes)) as fmu:
        root = ET.fromstring(fmu.read("modelDescription.xml"))
    return {v.get("name"): next(iter(v)).get("start") for v in root.iterfind("ModelVariables/ScalarVariable")
            if next(iter(v)).get("start") is not None}


@pytest.mark.parametrize("name", PAPER_SCENES)
def test_pair_archive_runs_its_scene_without_parameter_bindings(name, fmu_dir, tmp_path):
    from tribofmu import api
    from tribofmu.scene.ssp import archive_step, export_ssp, parameter_values
    from tribofmu.studies.measures import nrms

    scenario = api.load(scene(name), SHORTENED.get(name))
    ssp = export_ssp(scenario, tmp_path / f"{name}.ssp", fmu_dir, pair=True)
    stop, h = archive_experiment(ssp)
    assert stop == scenario.stop_time and h == archive_step(scenario, pair=True)
    # the copies in the archive start from the scene, their own DefaultExperiment says the same
    with zipfile.ZipFile(ssp) as archive:
        for component, values in parameter_values(scenario, pair=True).items():
            fmu = archive.read(f"resources/{component}.fmu")
            starts = start_values(fmu)
            for variable, value in values.items():
                expected = (("true" if value else "false") if isinstance(value, bool) else
                            str(value) if isinstance(value, int) else repr(float(value)))
                assert starts[variable] == expected, (component, variable)
            md = ET.fromstring(zipfile.ZipFile(__import__("io").BytesIO(fmu)).read("modelDescription.xml"))
            assert float(md.find("DefaultExperiment").get("stepSize")) == h

    out = tmp_path / "fmpy.npz"
    run = subprocess.run([sys.executable, "-c", CHILD, str(ssp), repr(stop), repr(h), str(out)],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    fmpy_run = np.load(out)
    ours = api.simulate(scenario, fmu_dir=fmu_dir, build=False, max_wall=None)
    assert ours.ok, ours.message
    error = nrms(fmpy_run["time"], fmpy_run["v"], ours.time, ours.v, scenario.window)
    print(f"\n[archive-scene] {name}: h={h:g} s, steps={len(fmpy_run['time'])}, nrms(v)={error:.3g}")
    assert error <= TARGET


@pytest.mark.parametrize("pair", [True, False], ids=["pair", "three FMUs"])
def test_archive_fmus_pass_the_independent_checker(pair, fmu_dir, tmp_path):
    """The rewritten modelDescription.xml files stay valid: fmpy's validation and the
    fmu-manipulation-toolbox checker (see test_fmu_checker) find nothing."""
    from fmpy.validation import validate_fmu
    from tribofmu import api
    from tribofmu.scene.ssp import export_ssp

    ssp = export_ssp(api.load(scene("fig6_boundary")), tmp_path / "fig6.ssp", fmu_dir, pair=pair)
    with zipfile.ZipFile(ssp) as archive:
        members = [m for m in archive.namelist() if m.endswith(".fmu")]
        archive.extractall(tmp_path, members)
    for member in members:
        fmu = tmp_path / member
        assert validate_fmu(str(fmu)) == [], member
        check = subprocess.run([sys.executable, "-m", "fmu_manipulation_toolbox.cli.fmutool", "-input",
                                str(fmu), "-check"], capture_output=True, text=True, timeout=120)
        assert check.returncode == 0 and "No semantic error" in check.stdout + check.stderr, \
            check.stdout + check.stderr
