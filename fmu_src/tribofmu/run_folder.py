"""This process's temporary folder, ``<tmp>/tribofmu-run-<pid>-<random>/`` (mode 0700): made
on first use, it holds everything a run keeps on disk for itself alone (the check's spools,
the unzipped FMUs), so one removal takes it all.

It is removed at exit, also after Ctrl-C, SIGTERM and SIGHUP (a closed terminal or ssh
session), which the ``tribofmu`` command turns into a clean stop
(:func:`tribofmu.progress.install_signal_handlers`). A process killed before its exit
handlers run (SIGKILL, a crash, a Dask worker stopped by its nanny) leaves its folder: the
next process that makes its own, and the ``tribofmu`` command at its exit, remove the
folders of processes that are gone: named as ours, a real folder (not a link) of this user,
its pid not alive.
"""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import threading
from pathlib import Path

from .atomic import left_by_gone_process

RUN_PREFIX = "tribofmu-run-"
_lock = threading.Lock()
_folder: tuple[int, Path] | None = None  # (pid that made it, folder)


def run_folder() -> Path:
    """This process's temporary folder (made on first use, removed at exit)."""
    global _folder
    with _lock:
        if _folder is None or _folder[0] != os.getpid():  # a forked child makes its own
            tmp = Path(tempfile.gettempdir())
            remove_gone_runs(tmp)
            folder = Path(tempfile.mkdtemp(prefix=f"{RUN_PREFIX}{os.getpid()}-", dir=tmp))
            _folder = (os.getpid(), folder)
            atexit.register(_remove, os.getpid(), folder)
        return _folder[1]


def share_with_forked_child() -> None:
    """In a child forked to work for this process (:mod:`tribofmu.forked_runs`): use the
    parent's folder as its own (made before the fork), so that what the child leaves goes
    with the parent's, and the child makes none to leave behind when it is stopped."""
    global _folder
    with _lock:
        if _folder is not None:
            _folder = (os.getpid(), _folder[1])


def remove_gone_runs(tmp: Path | None = None) -> int:
    """Remove the run folders of processes that are gone; returns how many were removed."""
    tmp = Path(tmp) if tmp is not None else Path(tempfile.gettempdir())
    removed = 0
    for folder in tmp.glob(RUN_PREFIX + "*"):
        if left_by_gone_process(folder, RUN_PREFIX) and folder.is_dir():
            shutil.rmtree(folder, ignore_errors=True)
            removed += 1
    return removed


def _remove(pid: int, folder: Path) -> None:
    if os.getpid() == pid:  # a forked child inherits the handler, not the folder
        shutil.rmtree(folder, ignore_errors=True)
        remove_gone_runs(folder.parent)  # e.g. the folders of finished worker processes
