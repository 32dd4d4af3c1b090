"""An FMU file as this process opens it: unzipped once per content into the process's own
folder (removed at exit, with the folders of processes that are gone), and its model description
read once per content. :class:`~tribofmu.master.instance.FMUInstance` opens every FMU through
these; the sweep's workers unpack their FMUs into the same folder.
"""
from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import tempfile
import threading
from pathlib import Path
from typing import Any

from ..atomic import left_by_gone_process
from ..run_folder import remove_gone_runs, run_folder

# fmpy is imported in the functions that call it (its start-up cost: see master.instance)

# -- where FMUs are unzipped -------------------------------------------------------------
# One folder per process, ``<tmp>/tribofmu-fmus-<pid>-<random>``, removed at exit; each FMU
# file is unzipped into it once (keyed by its content) and shared by all its instances.
# A process killed before its exit handlers run leaves its folder behind: the next process
# that unzips an FMU, and every process that exits after unzipping one (or the tribofmu
# command, whose Dask workers unzip), removes the folders of processes that no longer exist.
EXTRACT_PREFIX = "tribofmu-fmus-"
_extract_lock = threading.Lock()
_extract_root: tuple[int, Path] | None = None  # (pid that made it, folder)
_extracted: dict[str, Path] = {}


def remove_orphan_extractions(tmp: Path | None = None) -> None:
    """Remove the extraction folders of processes that are gone (killed, crashed, or
    terminated without exit handlers, as Dask stops its worker processes)."""
    tmp = Path(tmp) if tmp is not None else Path(tempfile.gettempdir())
    remove_gone_runs(tmp)  # the run folders the unzipped FMUs live in now
    for folder in tmp.glob(EXTRACT_PREFIX + "*"):  # straight in the temp dir: earlier versions
        if left_by_gone_process(folder, EXTRACT_PREFIX):  # (an all-digit hash is no pid: not ours)
            shutil.rmtree(folder, ignore_errors=True)


def _remove_root(pid: int, folder: Path) -> None:
    if os.getpid() == pid:  # a forked child inherits the handler, not the folder
        shutil.rmtree(folder, ignore_errors=True)
        remove_orphan_extractions(folder.parent)  # e.g. the folders of finished worker processes


def extraction_root() -> Path:
    """This process's folder of unzipped FMUs (made on first use, removed at exit)."""
    global _extract_root
    with _extract_lock:
        if _extract_root is None or _extract_root[0] != os.getpid():
            remove_orphan_extractions()
            folder = Path(tempfile.mkdtemp(prefix=f"{EXTRACT_PREFIX}{os.getpid()}-", dir=run_folder()))
            _extract_root = (os.getpid(), folder)
            _extracted.clear()
            atexit.register(_remove_root, os.getpid(), folder)
        return _extract_root[1]


def share_extractions_with_forked_child() -> None:
    """In a child forked to work for this process (:mod:`tribofmu.forked_runs`): use the FMUs
    the parent unzipped (and its folder for more), instead of unzipping them all again."""
    global _extract_root
    with _extract_lock:
        if _extract_root is not None:
            _extract_root = (os.getpid(), _extract_root[1])


def content_digest(path: Path) -> str:
    """What names an FMU file's content in this process (what is unzipped or read once per content)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


_descriptions: dict[str, Any] = {}  # content digest -> fmpy's model description (under _extract_lock)


def model_description(path: Path, digest: str | None = None):
    """fmpy's model description of an FMU file, read (and validated) once per content in this
    process: 1.4 ms a file, every run's instances (2026-11-27)."""
    import fmpy

    digest = digest or content_digest(path)
    with _extract_lock:
        md = _descriptions.get(digest)
    if md is None:
        md = fmpy.read_model_description(str(path))
        with _extract_lock:
            _descriptions[digest] = md
    return md


def extract(path: Path, digest: str | None = None) -> Path:
    """The unzipped copy of an FMU file for this process (unzipped once per content; digest:
    :func:`content_digest` of the file, when the caller has it)."""
    import fmpy

    digest = digest or content_digest(path)
    root = extraction_root()
    with _extract_lock:
        folder = _extracted.get(digest)
        if folder is None or not folder.is_dir():
            folder = root / f"{Path(path).stem}-{digest}"
            partial = Path(tempfile.mkdtemp(prefix=".partial-", dir=root))
            try:
                fmpy.extract(str(path), unzipdir=str(partial))
                os.replace(partial, folder) if not folder.exists() else None
            finally:
                shutil.rmtree(partial, ignore_errors=True)
            _extracted[digest] = folder
        return folder
