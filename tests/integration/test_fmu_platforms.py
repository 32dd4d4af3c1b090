"""An FMU declares the platforms it runs on by its binaries/ folders: the built FMUs carry
Linux x86-64 only (the native loader's platform); pythonfmu's win64 DLL, untested and without
the loader (docs/hosts.md, Windows), is left out."""
import zipfile

import pytest

pytestmark = pytest.mark.integration


def test_the_built_fmus_declare_only_the_platform_they_run_on(fmu_dir):
    fmus = sorted(fmu_dir.glob("*.fmu"))
    assert fmus
    for fmu in fmus:
        folders = {name.split("/")[1] for name in zipfile.ZipFile(fmu).namelist()
                   if name.startswith("binaries/") and name.count("/") >= 2}
        assert folders == {"linux64"}, (fmu.name, folders)
