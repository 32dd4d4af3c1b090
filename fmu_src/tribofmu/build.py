"""Build the FMUs with pythonfmu, each carrying the physics package inside itself.

The copy an FMU carries is renamed: pythonfmu puts the FMU's ``resources`` folder first on
``sys.path`` of the process that loads it, so a copy named ``tribofmu`` would shadow the
installed package (``import tribofmu.api`` then fails in that process), and two FMUs built
from different sources would share whichever copy was imported first. The shipped copy is
therefore a private package, ``_tribofmu_fmu_<version>_<source hash>``, and the model
modules are ``<that name>_<FMU>``: the staged sources' ``tribofmu`` imports are rewritten
to it at build time, so a built FMU never imports the name ``tribofmu``.

Where FMUs live by default (:func:`default_fmu_dir`): a per-user cache keyed by the
package version and the hash of the shipped sources, so every working directory finds
(or builds once) the FMUs matching the installed code, and a changed source never runs a
stale FMU.

FMI 3.0 (``fmi=3``, ``tribofmu build --fmi 3``): the same adapters built with pythonfmu3. The
shipped copy is then ``_tribofmu_fmu_fmi3_<version>_<hash>`` with ``fmu/fmi_version.py``
saying 3, so :mod:`tribofmu.fmu.base` derives from pythonfmu3's ``Fmi3Slave``, and each
adapter's base-class alias ``Fmi2Slave`` is renamed ``Fmi3Slave`` (pythonfmu3 finds the
model class by that text). They go to their own cache folder, ``<version>-<hash>-fmi3``.
"""
from __future__ import annotations

import hashlib
import os
import platform
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import textwrap
import warnings
import zipfile
from functools import lru_cache
from pathlib import Path

from . import __version__
from .errors import TriboFMUError
from .fmu.registry import fmu_names

PACKAGE = Path(__file__).resolve().parent
MODELS = PACKAGE / "fmu" / "models"
# What an FMU needs at run time, as whole packages: the physics, the FMU framework and, for
# TriboPair, the coupling (which imports only the standard library and the physics).
SHIPPED = ("__init__.py", "physics", "fmu", "coupling")
FMI_VERSIONS = (2, 3)
PRIVATE_PREFIX = "_tribofmu_fmu_"
# Staging folders in the temp dir, "<prefix><pid>_...": fmu_cache removes those of killed builds.
BUILD_PREFIX = "tribofmu_build_"
CACHE_ENV = "TRIBOFMU_CACHE"  # overrides the cache folder (default: $XDG_CACHE_HOME/tribofmu)

# ``from tribofmu.x import y`` / ``import tribofmu.x`` at the start of a line (any indent).
_IMPORT = re.compile(r"^(\s*)(from|import)(\s+)tribofmu\b", re.MULTILINE)


def _shipped_sources() -> list[Path]:
    """Every file whose content ends up in an FMU: the shipped package and the model scripts."""
    files = []
    for rel in SHIPPED:
        src = PACKAGE / rel
        files += sorted(p for p in src.rglob("*.py")) if src.is_dir() else [src]
    files += [MODELS / f"{name}.py" for name in fmu_names()]
    return files


@lru_cache(maxsize=2)
def source_hash(fmi: int = 2) -> str:
    """12 hex digits of sha256 over the shipped sources (paths and contents) and the version of
    the pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0) that builds them."""
    # pythonfmu and pythonfmu3 are imported where used, only the one of the FMI version asked
    # for: 21 and 25 ms at start-up, 26 and 24 ms with their builders (-X importtime, min of 5,
    # 2026-11-26 23:59 UTC, load 5.5), which --help and 'scenes' (they load this module) skip
    if fmi == 3:
        import pythonfmu3
        digest = hashlib.sha256(f"pythonfmu3 {pythonfmu3.__version__}\n".encode())
    else:
        import pythonfmu
        digest = hashlib.sha256(f"pythonfmu {pythonfmu.__version__}\n".encode())
    digest.update(_PREAMBLE.encode() + _FIND_CLASS_GUARD.encode() + _native_digest(fmi))
    for path in _shipped_sources():
        digest.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:12]


def private_package_name(fmi: int = 2) -> str:
    """The name the shipped copy of the physics has inside the FMUs built from this source."""
    version = "fmi3_" if fmi == 3 else ""  # FMI 2.0 and 3.0 FMUs may share a process
    return f"{PRIVATE_PREFIX}{version}{__version__.replace('.', '_')}_{source_hash(fmi)}"


def fmu_source(path: Path) -> str | None:
    """The source an FMU built by tribofmu carries: the name of its private package
    (``_tribofmu_fmu_<version>_<source hash>``), read from the archive; None if not ours."""
    try:
        with zipfile.ZipFile(path) as archive:
            for name in archive.namelist():
                parts = name.split("/")
                if len(parts) > 2 and parts[0] == "resources" and parts[1].startswith(PRIVATE_PREFIX):
                    return parts[1]
    except (OSError, zipfile.BadZipFile):
        pass
    return None


def cache_root() -> Path:
    """The per-user cache folder: ``$TRIBOFMU_CACHE``, else ``$XDG_CACHE_HOME/tribofmu``."""
    root = os.environ.get(CACHE_ENV)
    if not root:
        root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "tribofmu"
    return Path(root).absolute()


def default_fmu_dir(fmi: int = 2) -> Path:
    """Per-user cache of the FMUs built from this exact source: ``<cache>/fmus/<version>-<hash>``
    (FMI 3.0: ``<version>-<hash>-fmi3``); see :mod:`tribofmu.fmu_cache` for how it is checked."""
    suffix = "-fmi3" if fmi == 3 else ""
    return cache_root() / "fmus" / f"{__version__}-{source_hash(fmi)}{suffix}"


def rewrite_imports(text: str, private: str) -> str:
    return _IMPORT.sub(lambda m: f"{m.group(1)}{m.group(2)}{m.group(3)}{private}", text)


def _stage_package(root: Path, private: str, fmi: int = 2) -> Path:
    target = root / private
    for rel in SHIPPED:
        src, dst = PACKAGE / rel, target / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(src, dst)
    for path in target.rglob("*.py"):
        path.write_text(rewrite_imports(path.read_text(), private))
    if fmi == 3:
        version_file = target / "fmu" / "fmi_version.py"
        text, count = re.subn(r"^FMI_VERSION = 2$", "FMI_VERSION = 3", version_file.read_text(), flags=re.M)
        if count != 1:
            raise RuntimeError(f"{version_file.name} has no line 'FMI_VERSION = 2' to switch to FMI 3.0")
        version_file.write_text(text)
    return target


# Put before a model script's imports. FMUs of one build share the private package's name, and
# a host may have imported it from another FMU's folder that is gone by now (fmpy removes an
# FMU's extraction when simulate_fmu returns): modules that FMU did not need would then not
# be found. Each FMU adds its own copy to the packages already imported.
_PREAMBLE = """import os as _os, sys as _sys
for _name, _module in list(_sys.modules.items()):
    if (_name == {private!r} or _name.startswith({private!r} + ".")) and hasattr(_module, "__path__"):
        _mine = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), *_name.split("."))
        if _mine not in _module.__path__:
            _module.__path__.append(_mine)
"""


# FMI 2.0: pythonfmu 0.7's fmi2Instantiate imports the model script and then executes the
# whole file again (its findClass, with a new locals dict) to find the model class among the
# classes that execution defines. Every class it sees is leaked there (a list of its MRO that
# is never released, two strings per MRO entry), and with it everything each new class holds:
# about 12 kB per instantiation (+47.7 MB over 4,000 instantiate/free cycles). So the script is
# the model only when imported; executed again it only names a prepared class whose MRO has
# three entries, with short names (the model class's name bound to it; findClass then takes the real class from
# the module by that name). findClass also releases the module's dict once more than it
# acquires it (a borrowed reference): that execution adds the reference back, as the classes
# it no longer defines did. And it drops the duplicate of the resources folder that every
# fmi2Instantiate puts in front of sys.path.
_FIND_CLASS_GUARD = """if locals() is globals():  # imported: the model
{body}
    class _Fmi2SlaveName:  # what pythonfmu's findClass looks for in a class's MRO
        pass
    _Fmi2SlaveName.__name__ = _Fmi2SlaveName.__qualname__ = "Fmi2Slave"
    _Fmi2SlaveName.__module__ = "p"  # short names: findClass leaks a copy of each repr

    class _Found(_Fmi2SlaveName):
        pass
    _Found.__module__, _Found.__qualname__ = "m", "F"
    import ctypes as _ctypes
    _incref = _ctypes.pythonapi.Py_IncRef
    _incref.argtypes, _incref.restype = [_ctypes.py_object], None
else:  # pythonfmu's findClass executing this file again (see tribofmu/build.py)
    {cls} = _Found
    _incref(globals())
    if _sys.path and _sys.path[0] in _sys.path[1:]:
        del _sys.path[0]
"""


def _stage_model(root: Path, name: str, private: str, fmi: int = 2) -> Path:
    """The model script under its private module name, importing the private package."""
    text = rewrite_imports((MODELS / f"{name}.py").read_text(), private)
    first_import = re.search(r"^(from|import) ", text, re.MULTILINE).start()
    if fmi == 3:
        text = text[:first_import] + _PREAMBLE.format(private=private) + text[first_import:]
        text = re.sub(r"\bFmi2Slave\b", "Fmi3Slave", text)
    else:
        cls = re.search(r"^class (\w+)\(Fmi2Slave\):", text, re.MULTILINE).group(1)
        body = textwrap.indent(_PREAMBLE.format(private=private) + text[first_import:], "    ")
        text = text[:first_import] + _FIND_CLASS_GUARD.format(body=body, cls=cls)
    if re.search(r"\btribofmu\.", "\n".join(l for l in text.splitlines() if "import" in l)):
        raise RuntimeError(f"{name}.py imports tribofmu in a form the build cannot rename")
    script = root / f"{private}_{name}.py"
    script.write_text(text)
    return script


def build_fmus(out_dir: str | Path | None = None, names: tuple[str, ...] | None = None,
               fmi: int = 2) -> list[Path]:
    """Build ``out_dir/<Name>.fmu`` (default: :func:`default_fmu_dir`) for each name (default:
    every FMU of :func:`tribofmu.fmu.registry.fmu_names`) as FMI 2.0 or (fmi=3) FMI 3.0
    co-simulation FMUs; returns their paths.

    Each file appears whole or not at all (built aside, then renamed into place).
    """
    if fmi not in FMI_VERSIONS:
        raise ValueError(f"FMI version must be 2 or 3, got {fmi!r}")
    if fmi == 3:  # build-time only dependencies (see source_hash)
        from pythonfmu3.builder import FmuBuilder
        options = dict(canGetAndSetFMUState=True, canSerializeFMUState=True,
                       canHandleVariableCommunicationStepSize=True)
    else:
        from pythonfmu.builder import FmuBuilder
        options = dict(canGetAndSetFMUstate=True, canSerializeFMUstate=True)

    names = fmu_names() if names is None else names
    out_dir = Path(out_dir) if out_dir is not None else default_fmu_dir(fmi)
    out_dir.mkdir(parents=True, exist_ok=True)
    private = private_package_name(fmi)
    built = []
    path_before = list(sys.path)
    try:
        # named by pid: the next run removes the folder of a build that was killed
        with tempfile.TemporaryDirectory(prefix=f"{BUILD_PREFIX}{os.getpid()}_") as tmp:
            package = _stage_package(Path(tmp), private, fmi)
            for name in names:
                _forget_private_modules()  # imported by the previous build from a folder now gone
                # pythonfmu3 takes a folder as dest and names the file after the model
                dest = Path(tmp) / f"{name}.fmu" if fmi == 2 else Path(tmp) / f"fmi3-{name}"
                partial = FmuBuilder.build_FMU(
                    _stage_model(Path(tmp), name, private, fmi), dest=dest,
                    project_files=[package], **options)
                install_native_loader(Path(partial), fmi, Path(tmp))
                final = out_dir / f"{name}.fmu"
                # same file system: an atomic rename; otherwise copy beside the target first
                aside = out_dir / f".{name}.fmu.partial-{os.getpid()}"
                shutil.copyfile(partial, aside)
                os.replace(aside, final)
                built.append(final)
    finally:
        # The builder imported the staged modules from a folder that is now gone: forget them,
        # so an FMU loaded later in this process imports its own copy.
        sys.path[:] = path_before
        _forget_private_modules()
    return built


def _forget_private_modules() -> None:
    for module in [m for m in sys.modules if m.startswith(PRIVATE_PREFIX)]:
        del sys.modules[module]


# -- the native loader: FMUs that load in hosts without Python ------------------------------
#
# pythonfmu's binary leaves the Python C API undefined (it has no DT_NEEDED entry for
# libpython), so it only loads into a process that already holds a Python. The FMU's binary
# becomes instead a small C loader (native/*_loader.c), compiled here with the system C
# compiler: it uses the host's Python when there is one, otherwise loads the libpython of the
# interpreter that built the FMU (or $TRIBOFMU_LIBPYTHON) with RTLD_GLOBAL, then opens
# pythonfmu's binary, shipped beside it as libpythonfmu-export.so, and forwards every call.
NATIVE = PACKAGE / "native"
LOADER_SOURCES = {2: "fmi2_loader.c", 3: "fmi3_loader.c"}
LOADER_PLATFORM_DIRS = {2: "binaries/linux64", 3: "binaries/x86_64-linux"}
WRAPPER_FILE = "libpythonfmu-export.so"  # the name loader_common.h opens


def native_loader_supported() -> bool:
    """The loader is built for Linux x86-64 only (see docs/hosts.md, native hosts)."""
    return sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")


def recorded_python() -> dict[str, str]:
    """What the loader records about the building interpreter: its shared libpython (absolute
    path and soname) and its executable (so an embedded interpreter sees the same prefix,
    virtual environment and site-packages)."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    soname = sysconfig.get_config_var("INSTSONAME") or ""
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        # A static-only build (no libpython*.so): record the soname a packaged shared
        # library of the same version would have; the loader then searches the loader path.
        soname = f"libpython{sysconfig.get_python_version()}.so.1.0"
    path = os.path.join(libdir, soname) if libdir and soname else ""
    return {"libpython": path if path and os.path.exists(path) else "",
            "soname": soname, "executable": sys.executable or ""}


def _native_digest(fmi: int) -> bytes:
    if not native_loader_supported():
        return b""
    parts = [(NATIVE / "loader_common.h").read_bytes(), (NATIVE / LOADER_SOURCES[fmi]).read_bytes()]
    # what the loader binds to (libpython, its soname, the environment the embedded interpreter
    # starts in, sys.prefix), not the name the interpreter was started by: `tribofmu` and
    # `python -m tribofmu` in one venv share one cache
    parts += [f"{k}={v}".encode() for k, v in sorted(recorded_python().items()) if k != "executable"]
    parts.append(f"prefix={sys.prefix} abi={sys.implementation.cache_tag}{getattr(sys, 'abiflags', '')}".encode())
    parts.append(b"loader" if c_compiler() else b"no compiler: pythonfmu's binary only")
    return b"\0".join(parts)


def c_compiler() -> str | None:
    """$CC, else cc, gcc or clang on PATH."""
    if os.environ.get("CC"):
        return os.environ["CC"]
    return next((shutil.which(c) for c in ("cc", "gcc", "clang") if shutil.which(c)), None)


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def compile_native_loader(fmi: int, out: Path) -> Path:
    """Compile the loader for FMI ``fmi`` into ``out`` (a shared library); raises
    :class:`~tribofmu.errors.TriboFMUError` naming the compiler and its message on failure."""
    compiler = c_compiler()
    if compiler is None:
        raise TriboFMUError("no C compiler (cc, gcc or clang on PATH, or $CC) to build the FMUs' "
                            "native loader; install one, e.g. apt-get install gcc")
    python = recorded_python()
    required = "pythonfmu3,numpy" if fmi == 3 else "pythonfmu,numpy"
    defines = {"TRIBOFMU_LIBPYTHON": python["libpython"], "TRIBOFMU_LIBPYTHON_SONAME": python["soname"],
               "TRIBOFMU_PYTHON_EXECUTABLE": python["executable"], "TRIBOFMU_REQUIRED_MODULES": required}
    command = [compiler, "-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-Wl,-Bsymbolic",
               *(f"-D{k}={_c_string(v)}" for k, v in defines.items()),
               "-o", str(out), str(NATIVE / LOADER_SOURCES[fmi]), "-ldl", "-lpthread"]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except OSError as exc:
        raise TriboFMUError(f"cannot run the C compiler {compiler!r} to build the FMUs' native "
                            f"loader: {exc.strerror or exc}") from None
    if done.returncode != 0:
        raise TriboFMUError(f"{compiler} failed to build the FMUs' native loader "
                            f"({LOADER_SOURCES[fmi]}): {done.stderr.strip()}")
    return out


TOKEN_FILE = "tribofmu-guid.txt"  # in resources/: the FMU's GUID (FMI 3.0: instantiation token)


def install_native_loader(fmu: Path, fmi: int, work: Path) -> None:
    """Rewrite ``fmu`` (a pythonfmu-built archive) so its Linux binary is the native loader and
    pythonfmu's binary sits beside it as libpythonfmu-export.so. Other platforms' binaries
    (pythonfmu's win64 DLL) are left out: an FMU declares only the platforms it runs on.

    Without a C compiler the FMU keeps pythonfmu's binary, with a warning: it then runs in
    Python hosts only (fmpy, libcosimpy, ecospy, this package's master)."""
    if not native_loader_supported():
        return
    if c_compiler() is None:
        warnings.warn(f"{fmu.stem}: no C compiler (cc, gcc or clang, or $CC): built without the "
                      "native loader, so the FMU loads only in hosts that already run Python; "
                      "install one (e.g. apt-get install gcc) and build again", stacklevel=2)
        return
    loader = work / f"loader-fmi{fmi}.so"
    if not loader.exists():  # one compilation per build
        compile_native_loader(fmi, loader)
    platform_dir = LOADER_PLATFORM_DIRS[fmi]
    rewritten = fmu.with_name(fmu.name + ".loader")
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as target:
        binaries = [i for i in source.infolist()
                    if i.filename.startswith(platform_dir + "/") and i.filename.endswith(".so")]
        if len(binaries) != 1:
            raise RuntimeError(f"{fmu.name}: expected one binary in {platform_dir}, "
                               f"found {[i.filename for i in binaries]}")
        # the loader checks the host's GUID (instantiation token) against this: hosts such as
        # fmpy's simulate_fmu extract only binaries/ and resources/, not modelDescription.xml
        token = re.search(rb'<fmiModelDescription[^>]*?\s(?:guid|instantiationToken)="([^"]*)"',
                          source.read("modelDescription.xml"))
        if token is None:
            raise RuntimeError(f"{fmu.name}: modelDescription.xml has no guid / instantiationToken")
        target.writestr(f"resources/{TOKEN_FILE}", token.group(1) + b"\n")
        for item in source.infolist():
            data = source.read(item)
            if item.filename == f"resources/{TOKEN_FILE}":
                continue
            if item.filename.startswith("binaries/") and not item.filename.startswith(platform_dir + "/"):
                continue  # (a platform without the loader: not run, not tested, not declared)
            if item.filename == binaries[0].filename:
                wrapper = zipfile.ZipInfo(f"{platform_dir}/{WRAPPER_FILE}", date_time=item.date_time)
                wrapper.external_attr, wrapper.compress_type = item.external_attr, zipfile.ZIP_DEFLATED
                target.writestr(wrapper, data)
                target.write(loader, item.filename)
            else:
                target.writestr(item, data)
    os.replace(rewritten, fmu)
