"""Fixtures of the native-host tests: the C programs compiled with the system compiler, the
FMUs unzipped as a native host sees them, and a clean environment to run them in."""
from __future__ import annotations

import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


# -- fixtures -----------------------------------------------------------------------------
@pytest.fixture(scope="session")
def compiler() -> str:
    from tribofmu.build import c_compiler, native_loader_supported

    if not native_loader_supported():
        pytest.skip("the native loader is built for Linux x86-64 only")
    cc = c_compiler()
    if cc is None:
        pytest.skip("no C compiler (cc, gcc or clang): .ci/run installs gcc")
    return cc


@pytest.fixture(scope="session")
def programs(compiler, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("native_hosts")
    built = {}
    for name in ("fmi2_host", "fmi2_misuse", "fmi3_host"):
        built[name] = _compile(compiler, [HERE / f"{name}.c"], out / name, ["-ldl"])
    return built


@pytest.fixture(scope="session")
def cosim_host(compiler, tmp_path_factory) -> Path:
    try:
        import libcosimpy
    except ImportError:
        pytest.skip("libcosimpy (pip install -e .[ssp]) provides libcosimc")
    libdir = Path(libcosimpy.__file__).parent / "libcosimc"
    out = tmp_path_factory.mktemp("cosim_host") / "cosim_host"
    return _compile(compiler, [HERE / "cosim_host.c"], out, [f"-L{libdir}", "-lcosimc", f"-Wl,-rpath,{libdir}"])


def _compile(cc: str, sources: list[Path], out: Path, libs: list[str]) -> Path:
    done = subprocess.run([cc, "-O1", "-Wall", "-o", str(out), *map(str, sources), *libs],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture(scope="session")
def unzipped(fmu_dir, tmp_path_factory):
    """FMU name -> (folder it is extracted to, its modelDescription root): FMI 2.0 builds."""
    return _unzipper(fmu_dir, tmp_path_factory.mktemp("unzipped"))


@pytest.fixture(scope="session")
def unzipped3(fmu3_dir, tmp_path_factory):
    """The same for the FMI 3.0 builds."""
    return _unzipper(fmu3_dir, tmp_path_factory.mktemp("unzipped3"))


def _unzipper(fmu_dir: Path, root: Path):
    cache = {}

    def get(name: str):
        if name not in cache:
            folder = root / name
            with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as archive:
                archive.extractall(folder)
            for binary in (folder / "binaries").rglob("*.so"):
                binary.chmod(0o755)
            cache[name] = folder, ET.parse(folder / "modelDescription.xml").getroot()
        return cache[name]
    return get
