"""OMSimulator (OpenModelica's co-simulation environment) runs our archives as exported.

Its command line and its Python API, from the build in the repository's sibling folder
``../shared/tools/omsimulator`` (see the README there), run ``tribofmu export-ssp`` archives of
Fig. 2 (the pair and the three FMUs) and Fig. 5 pseudoplastic (the pair) unchanged; their
nRMS(v) on the scene's window against tribofmu's own run of the scene must be <= 1e-3 for the
pairs and <= 5e-3 for the three FMUs (an explicit master's first-order error at the archive's
step; OMSimulator finds the algebraic loop Friction-BlockSpring and solves it).

The command line gets the root system's type and the step from the archive's
``org.openmodelica`` annotation (without it, it aborts with exit 134); the stop time from
``--stopTime`` (it ignores the archive's DefaultExperiment). It exits 0 even when a phase
failed, so the tests also read its log for errors and check that the result reached the stop
time. Both run in child processes that never import tribofmu: the FMUs run the package copy
they carry (the command line's process has no Python: the FMUs load one themselves).

Needs Debian's libicu72 (both) and lxml (the Python API); ``bash .ci/run`` installs them.
"""
from __future__ import annotations

import csv
import subprocess
import sys
import zipfile
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from scenes import ROOT, scene

pytestmark = [pytest.mark.integration, pytest.mark.external]

OMS_DIR = ROOT.parent / "shared" / "tools" / "omsimulator"
if not (OMS_DIR / "bin" / "OMSimulator").is_file():
    pytest.skip(f"OMSimulator is not in {OMS_DIR} (the repository's sibling folder shared/tools/omsimulator)",
                allow_module_level=True)

# (scene, pair, the component whose v is compared, target nRMS(v))
CASES = {
    "fig2_dry pair": ("fig2_dry", True, "TriboPair", 1e-3),
    "fig2_dry three FMUs": ("fig2_dry", False, "BlockSpring", 5e-3),
    "fig5_pseudoplastic pair": ("fig5_pseudoplastic", True, "TriboPair", 1e-3),
}
NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"}

API_CHILD = """
import sys
sys.path.insert(0, sys.argv[1])
from OMSimulator import SSP
ssp, out, h, stop = sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
model = SSP(ssp, temp_dir="oms-tmp")  # reads the SSD itself (lxml)
im = model.instantiate()
im.setResultFile(out)
im.setFixedStepSize(h)
im.setLoggingInterval(h)
im.setStopTime(stop)
im.initialize()
im.simulate()
im.terminate()
im.delete()
"""


def oms_step(ssp) -> float:
    """The step of the archive's OMSimulator annotation (the root system's fixed-step master)."""
    root = ET.fromstring(zipfile.ZipFile(ssp).read("SystemStructure.ssd"))
    system = root.find("ssd:System", NS)
    assert system[-1].tag == f"{{{NS['ssd']}}}Annotations", "the annotation must be the system's last child"
    master = system.find("ssd:Annotations/ssc:Annotation[@type='org.openmodelica']/oms:Annotations/"
                         "oms:SimulationInformation/oms:FixedStepMaster", NS)
    assert master is not None and master.get("description"), "no org.openmodelica FixedStepMaster"
    return float(master.get("stepSize"))


def read_v(path, component: str) -> tuple[np.ndarray, np.ndarray]:
    """time and ``component.v`` of an OMSimulator result file; of rows at the same time (event
    iterations), the last."""
    with open(path, newline="") as handle:
        rows = csv.reader(handle)
        header = [name.strip().strip('"') for name in next(rows)]
        data = np.array([[float(x) for x in row] for row in rows if row])
    column = next(i for i, name in enumerate(header) if name.endswith(f".{component}.v"))
    t, v = data[:, 0], data[:, column]
    last = np.append(np.diff(t) > 0, True)
    return t[last], v[last]


@pytest.fixture(scope="module")
def archives(fmu_dir, tmp_path_factory):
    """case -> (scenario, archive, our run's (time, v))."""
    from tribofmu import api
    from tribofmu.scene.ssp import archive_step, export_ssp

    folder = tmp_path_factory.mktemp("oms-archives")
    out, ours = {}, {}
    for case, (name, pair, _, _) in CASES.items():
        scenario = api.load(scene(name))
        ssp = export_ssp(scenario, folder / f"{case.replace(' ', '_')}.ssp", fmu_dir, pair=pair)
        assert oms_step(ssp) == archive_step(scenario, pair)
        if name not in ours:
            run = api.simulate(scenario, fmu_dir=fmu_dir, build=False, max_wall=None)
            assert run.ok, run.message
            ours[name] = (run.time, run.v)
        out[case] = (scenario, ssp, ours[name])
    return out


def check(case, archives, result, log: str, returncode: int):
    from tribofmu.studies.measures import nrms

    scenario, _, (t_ours, v_ours) = archives[case]
    _, _, component, target = CASES[case]
    assert returncode == 0, log[-3000:]
    errors = [line for line in log.splitlines() if line.startswith("error:")]
    assert not errors, "\n".join(errors[:20])
    t, v = read_v(result, component)
    assert t[-1] == pytest.approx(scenario.stop_time, abs=1e-9), f"the result stops at {t[-1]}"
    error = nrms(t, v, t_ours, v_ours, scenario.window)
    return error, target


@pytest.mark.parametrize("case", list(CASES))
def test_omsimulator_command_line_runs_the_archive_as_exported(case, archives, tmp_path):
    scenario, ssp, _ = archives[case]
    result = tmp_path / "oms.csv"
    proc = subprocess.run([str(OMS_DIR / "bin" / "OMSimulator"), str(ssp), f"--resultFile={result}",
                           f"--stopTime={scenario.stop_time!r}"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=900)
    error, target = check(case, archives, result, proc.stdout + proc.stderr, proc.returncode)
    print(f"\n[omsimulator] command line, {case}: h={oms_step(ssp):g} s, nrms(v)={error:.3g} (target {target:g})")
    assert error <= target


@pytest.mark.parametrize("case", list(CASES))
def test_omsimulator_python_api_runs_the_archive_as_exported(case, archives, tmp_path):
    scenario, ssp, _ = archives[case]
    result = tmp_path / "oms.csv"
    proc = subprocess.run([sys.executable, "-c", API_CHILD, str(OMS_DIR / "lib"), str(ssp), str(result),
                           repr(oms_step(ssp)), repr(scenario.stop_time)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=900)
    error, target = check(case, archives, result, proc.stdout + proc.stderr, proc.returncode)
    print(f"\n[omsimulator] Python API, {case}: h={oms_step(ssp):g} s, nrms(v)={error:.3g} (target {target:g})")
    assert error <= target
