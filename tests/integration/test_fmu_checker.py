"""A second opinion on every built FMU (FMI 2.0 and 3.0): the FMU checker of the
fmu-manipulation-toolbox (``fmutool -input X.fmu -check``), independent of fmpy.

It validates ``modelDescription.xml`` against the FMI XSD schema it ships (offline) and
checks the rules the schema cannot express: unique names and value references, allowed
causality/variability/initial combinations, start values, and that ModelStructure lists
exactly the outputs with valid dependencies. It does not load the binaries. It exits with
a non-zero code on any error it reports.
"""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

def check(fmu: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fmu_manipulation_toolbox.cli.fmutool",
                           "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=120)


def built_fmus(folder: Path) -> list[Path]:
    fmus = sorted(folder.glob("*.fmu"))
    assert fmus, f"no FMUs in {folder}"
    return fmus


@pytest.mark.parametrize("version", [2, 3])
def test_checker_finds_no_error_in_built_fmus(fmu_dir, fmu3_dir, version):
    folder = fmu_dir if version == 2 else fmu3_dir
    for fmu in built_fmus(folder):
        result = check(fmu)
        report = result.stdout + result.stderr
        assert result.returncode == 0, f"{fmu.name} (FMI {version}):\n{report}"
        assert f"compliant with FMI-{version}.0" in report, report
        assert f"No semantic error against the FMI-{version} standard" in report, report


@pytest.mark.parametrize("version", [2, 3])
def test_checker_flags_an_output_missing_from_model_structure(fmu_dir, fmu3_dir, tmp_path, version):
    """The checker can fail: drop the first output from ModelStructure of a copy."""
    source = (fmu_dir if version == 2 else fmu3_dir) / "Drive.fmu"
    broken = tmp_path / "Drive.fmu"
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                entry = '<Unknown index="3" dependencies=""/>' if version == 2 else \
                    '<Output valueReference="3" dependencies=""/>'
                assert entry in text
                data = text.replace(entry, "", 1).encode()
            dst.writestr(item, data)
    result = check(broken)
    assert result.returncode != 0
    assert "error" in (result.stdout + result.stderr).lower()

