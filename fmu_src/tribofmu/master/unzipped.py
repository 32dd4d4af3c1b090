"""What loading a pythonfmu FMU leaves in this process, and how to undo it.

fmpy unzips each FMU into the temp dir, and pythonfmu puts ``<unzipped FMU>/resources`` on
``sys.path`` for the instance's lifetime and never takes it off. That folder holds the FMU's
trimmed copy of tribofmu (physics and FMU framework, no master), which would shadow the
installed package in processes started later (Dask workers inherit ``sys.path``), and each
unzipped FMU is ~0.7 MB on disk.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path


def unzipped_fmu(entry: str) -> Path | None:
    """The unzipped FMU whose ``resources`` folder this ``sys.path`` entry is, if it is one."""
    path = Path(entry)
    if path.name == "resources" and (path.parent / "modelDescription.xml").is_file():
        return path.parent
    return None


def forget_unzipped_fmu(unzipped: Path) -> None:
    """Take the FMU's ``resources`` off ``sys.path`` and delete the unzipped copy if it is in
    the temp dir (errors lose nothing: ignored)."""
    resources = str(Path(unzipped, "resources"))
    sys.path[:] = [entry for entry in sys.path if entry != resources]
    if Path(tempfile.gettempdir()).resolve() in Path(unzipped).resolve().parents:
        shutil.rmtree(unzipped, ignore_errors=True)


def forget_fmus_loaded_since(path_before: list[str]) -> None:
    """Forget every unzipped FMU whose ``resources`` joined ``sys.path`` after ``path_before``."""
    before = set(path_before)
    for entry in [e for e in sys.path if e not in before]:
        unzipped = unzipped_fmu(entry)
        if unzipped is not None:
            forget_unzipped_fmu(unzipped)


class NoUnzippedFMUsOnSysPath:
    """While inside: no unzipped FMU's ``resources`` on ``sys.path`` (for starting processes);
    on exit the entries come back, with whatever was added meanwhile."""

    def __enter__(self) -> "NoUnzippedFMUsOnSysPath":
        self.saved = list(sys.path)
        sys.path[:] = [e for e in sys.path if unzipped_fmu(e) is None]
        return self

    def __exit__(self, *exc) -> None:
        added = [e for e in sys.path if e not in self.saved]
        sys.path[:] = self.saved + added
