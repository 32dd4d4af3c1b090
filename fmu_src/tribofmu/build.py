"""Build the three FMUs with pythonfmu, each carrying the physics package inside itself."""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
SLAVES = PACKAGE / "fmu" / "slaves"
FMU_NAMES = ("Friction", "Drive", "BlockSpring", "Thermal", "Load")
# What an FMU needs at run time: the physics and the FMU framework, nothing that imports fmpy.
SHIPPED = ("__init__.py", "physics", "fmu/__init__.py", "fmu/base.py")


def _stage_package(root: Path) -> Path:
    target = root / "tribofmu"
    for rel in SHIPPED:
        src, dst = PACKAGE / rel, target / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(src, dst)
    return target


def build_fmus(out_dir: str | Path = "build", names: tuple[str, ...] = FMU_NAMES) -> list[Path]:
    """Build ``out_dir/<Name>.fmu`` for each name; returns their paths.

    Each file appears whole or not at all (built aside, then renamed into place).
    """
    from pythonfmu.builder import FmuBuilder  # build-time only dependency

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    built = []
    with tempfile.TemporaryDirectory(prefix="tribofmu_build_") as tmp:
        package = _stage_package(Path(tmp))
        for name in names:
            partial = FmuBuilder.build_FMU(
                SLAVES / f"{name}.py", dest=Path(tmp) / f"{name}.fmu", project_files=[package],
                canGetAndSetFMUstate=True, canSerializeFMUstate=True)
            final = out_dir / f"{name}.fmu"
            os.replace(partial, final) if Path(partial).stat().st_dev == out_dir.stat().st_dev \
                else shutil.move(str(partial), final)
            built.append(final)
    return built
