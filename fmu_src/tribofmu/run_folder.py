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
import pickle
import shutil
import tempfile
import threading
from pathlib import Path
from typing import Callable

import numpy as np

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


class Spool:
    """The check's output samples of one run (checked.py), held in this folder until the run is
    chosen (memory stays bounded whatever the span); :meth:`replay` hands them to the real sink
    in order."""

    def __init__(self):
        # in this process's run folder, which goes with it (killed runs' by the next run)
        fd, self.path = tempfile.mkstemp(prefix="tribofmu-spool-", suffix=".pickle", dir=run_folder())
        self._file = os.fdopen(fd, "wb")

    def __call__(self, start: int, signals: dict) -> None:
        pickle.dump((start, {k: np.array(v) for k, v in signals.items()}), self._file,
                    protocol=pickle.HIGHEST_PROTOCOL)

    def finish(self) -> None:
        """Everything written reaches the file (a forked run's last act: its parent replays it)."""
        if not self._file.closed:
            self._file.close()

    def replay(self, sink: Callable[[int, dict], None]) -> None:
        if not self._file.closed:
            self._file.flush()
        with open(self.path, "rb") as fh:
            while True:
                try:
                    start, signals = pickle.load(fh)
                except EOFError:
                    return
                sink(start, signals)

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()
        try:
            os.unlink(self.path)
        except OSError:
            pass
