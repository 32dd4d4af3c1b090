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
import re
import shutil
import sys
import tempfile
from functools import lru_cache
from pathlib import Path

from . import __version__

PACKAGE = Path(__file__).resolve().parent
MODELS = PACKAGE / "fmu" / "models"
FMU_NAMES = ("Friction", "Drive", "BlockSpring", "Thermal", "Load", "TriboPair")
# What an FMU needs at run time: the physics, the FMU framework and, for TriboPair, the
# master's coupling on in-process parts; nothing that imports fmpy.
SHIPPED = ("__init__.py", "physics", "fmu/__init__.py", "fmu/base.py", "fmu/fmi_version.py",
           "fmu/parameters.py", "master/algorithms.py", "master/system.py", "master/interpolation.py",
           "master/inprocess.py", "master/pair.py")
# Package files shipped in place of the source's: master/__init__.py imports the fmpy-based
# parts of the master (instance.py, run.py), which an FMU must not load.
STUBS = {"master/__init__.py": '"""The part of the tribofmu master that TriboPair runs in-process."""\n'}
FMI_VERSIONS = (2, 3)
PRIVATE_PREFIX = "_tribofmu_fmu_"
CACHE_ENV = "TRIBOFMU_CACHE"  # overrides the cache folder (default: $XDG_CACHE_HOME/tribofmu)

# ``from tribofmu.x import y`` / ``import tribofmu.x`` at the start of a line (any indent).
_IMPORT = re.compile(r"^(\s*)(from|import)(\s+)tribofmu\b", re.MULTILINE)


def _shipped_sources() -> list[Path]:
    """Every file whose content ends up in an FMU: the shipped package and the model scripts."""
    files = []
    for rel in SHIPPED:
        src = PACKAGE / rel
        files += sorted(p for p in src.rglob("*.py")) if src.is_dir() else [src]
    files += [MODELS / f"{name}.py" for name in FMU_NAMES]
    return files


@lru_cache(maxsize=2)
def source_hash(fmi: int = 2) -> str:
    """12 hex digits of sha256 over the shipped sources (paths and contents) and the version of
    the pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0) that builds them."""
    if fmi == 3:
        import pythonfmu3
        digest = hashlib.sha256(f"pythonfmu3 {pythonfmu3.__version__}\n".encode())
    else:
        import pythonfmu
        digest = hashlib.sha256(f"pythonfmu {pythonfmu.__version__}\n".encode())
    digest.update(_stub_digest() + _PREAMBLE.encode())
    for path in _shipped_sources():
        digest.update(path.relative_to(PACKAGE).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:12]


def _stub_digest() -> bytes:
    return "".join(f"{rel}\0{text}\0" for rel, text in sorted(STUBS.items())).encode()


def private_package_name(fmi: int = 2) -> str:
    """The name the shipped copy of the physics has inside the FMUs built from this source."""
    version = "fmi3_" if fmi == 3 else ""  # FMI 2.0 and 3.0 FMUs may share a process
    return f"{PRIVATE_PREFIX}{version}{__version__.replace('.', '_')}_{source_hash(fmi)}"


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
    for rel, text in STUBS.items():
        (target / rel).write_text(text)
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


def _stage_model(root: Path, name: str, private: str, fmi: int = 2) -> Path:
    """The model script under its private module name, importing the private package."""
    text = rewrite_imports((MODELS / f"{name}.py").read_text(), private)
    first_import = re.search(r"^(from|import) ", text, re.MULTILINE).start()
    text = text[:first_import] + _PREAMBLE.format(private=private) + text[first_import:]
    if fmi == 3:
        text = re.sub(r"\bFmi2Slave\b", "Fmi3Slave", text)
    if re.search(r"\btribofmu\.", "\n".join(l for l in text.splitlines() if "import" in l)):
        raise RuntimeError(f"{name}.py imports tribofmu in a form the build cannot rename")
    script = root / f"{private}_{name}.py"
    script.write_text(text)
    return script


def build_fmus(out_dir: str | Path | None = None, names: tuple[str, ...] = FMU_NAMES,
               fmi: int = 2) -> list[Path]:
    """Build ``out_dir/<Name>.fmu`` for each name (default: :func:`default_fmu_dir`) as FMI 2.0
    or (fmi=3) FMI 3.0 co-simulation FMUs; returns their paths.

    Each file appears whole or not at all (built aside, then renamed into place).
    """
    if fmi not in FMI_VERSIONS:
        raise ValueError(f"FMI version must be 2 or 3, got {fmi!r}")
    if fmi == 3:  # build-time only dependencies
        from pythonfmu3.builder import FmuBuilder
        options = dict(canGetAndSetFMUState=True, canSerializeFMUState=True,
                       canHandleVariableCommunicationStepSize=True)
    else:
        from pythonfmu.builder import FmuBuilder
        options = dict(canGetAndSetFMUstate=True, canSerializeFMUstate=True)

    out_dir = Path(out_dir) if out_dir is not None else default_fmu_dir(fmi)
    out_dir.mkdir(parents=True, exist_ok=True)
    private = private_package_name(fmi)
    built = []
    path_before = list(sys.path)
    try:
        # named by pid: the next run removes the folder of a build that was killed
        with tempfile.TemporaryDirectory(prefix=f"tribofmu_build_{os.getpid()}_") as tmp:
            package = _stage_package(Path(tmp), private, fmi)
            for name in names:
                _forget_private_modules()  # imported by the previous build from a folder now gone
                # pythonfmu3 takes a folder as dest and names the file after the model
                dest = Path(tmp) / f"{name}.fmu" if fmi == 2 else Path(tmp) / f"fmi3-{name}"
                partial = FmuBuilder.build_FMU(
                    _stage_model(Path(tmp), name, private, fmi), dest=dest,
                    project_files=[package], **options)
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
