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
    for name in ("fmi2_host", "fmi2_misuse", "fmi2_hostile", "fmi3_host", "fmi3_hostile"):
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


GATE_MODEL = '''
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


@pytest.fixture(scope="session")
def gate(compiler, tmp_path_factory):
    """A small plain pythonfmu FMU (not ours) behind our loader: (folder, modelDescription root).
    Plain pythonfmu answers an unknown value reference with fmi2Fatal, which ours never do."""
    from pythonfmu.builder import FmuBuilder

    from tribofmu.build import install_native_loader

    work = tmp_path_factory.mktemp("gate")
    script = work / "Gate.py"
    script.write_text(GATE_MODEL)
    fmu = FmuBuilder.build_FMU(script, dest=work / "Gate.fmu")
    install_native_loader(fmu, 2, work)
    folder = work / "unzipped"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    for binary in (folder / "binaries").rglob("*.so"):
        binary.chmod(0o755)
    return folder, ET.parse(folder / "modelDescription.xml").getroot()
