"""The loader's logging rules and the ``tribofmuCallStatus`` category, on a small FMU built here
with pythonfmu (the same build path as ours: :func:`tribofmu.build.install_native_loader`),
run in the C host with debug logging off:

- a message logged with category ``tribofmuCallStatus`` raises the status of the call it was
  logged in (fmi2Error here: pythonfmu alone returns fmi2OK), and reaches the host under
  ``logStatusError``;
- warnings reach the host's logger with debug logging off; OK-level debug messages do not.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile

import pytest

from native_support import run_clean, vr

pytestmark = [pytest.mark.integration, pytest.mark.native]

MODEL = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real
from pythonfmu.enums import Fmi2Status


class Gate(Fmi2Slave):
    """Logs by the value of its input u at every step."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input))

    def do_step(self, current_time, step_size):
        self.log(f"debug: stepping at u={self.u}")
        if self.u < 0:
            self.log(f"u must be >= 0, got {self.u}", Fmi2Status.error, category="tribofmuCallStatus")
        elif self.u > 100:
            self.log(f"u={self.u} is large", Fmi2Status.warning, category="tribofmuCallStatus")
        return True
'''


@pytest.fixture(scope="module")
def gate(compiler, tmp_path_factory):
    from pythonfmu.builder import FmuBuilder

    from tribofmu.build import install_native_loader

    work = tmp_path_factory.mktemp("gate")
    script = work / "Gate.py"
    script.write_text(MODEL)
    fmu = FmuBuilder.build_FMU(script, dest=work / "Gate.fmu")
    install_native_loader(fmu, 2, work)
    folder = work / "unzipped"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    for binary in (folder / "binaries").rglob("*.so"):
        binary.chmod(0o755)
    return folder, ET.parse(folder / "modelDescription.xml").getroot()


def run_gate(programs, gate, tmp_path, inputs):
    folder, description = gate
    values = tmp_path / "u.txt"
    values.write_text("\n".join(map(str, inputs)) + "\n")
    return run_clean([programs["fmi2_host"], "-h", "0.1", "-n", len(inputs), "-f", folder, "Gate",
                      description.get("guid"), "-u", 0, vr(description, "u"), values])


def test_logged_error_status_fails_the_call(programs, gate, tmp_path):
    done = run_gate(programs, gate, tmp_path, [1.0, -2.0, 1.0])
    assert done.returncode == 4, done.stderr
    assert "fmi2DoStep of FMU 0 returned fmi2Error" in done.stderr
    assert "[Error] fmu0 logStatusError: u must be >= 0, got -2.0" in done.stderr
    assert len(done.stdout.splitlines()) == 2  # t0 and after the first step; the second failed


def test_warnings_reach_the_host_and_debug_messages_do_not(programs, gate, tmp_path):
    done = run_gate(programs, gate, tmp_path, [1.0, 200.0, 1.0])
    assert done.returncode == 0, done.stderr
    assert "[Warning] fmu0 logStatusWarning: u=200.0 is large" in done.stderr
    assert "debug: stepping" not in done.stderr  # the host instantiated with loggingOn = false
    assert len(done.stdout.splitlines()) == 4
