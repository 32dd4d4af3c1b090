"""Write results whole or not at all.

A result set (the files of one run: stats.json, result.csv, the plots) is written into a
sibling folder ``.<name>.partial-<pid>-<random>`` and swapped in as a whole
(:func:`result_set`): on Linux the two folders are exchanged in one ``renameat2`` call
(``RENAME_EXCHANGE``), so every observer of ``<out>`` sees the old set or the new one, never
a mix. Where the exchange is not available, the old folder is renamed aside and the new
one into place; a kill between the two renames leaves ``<out>`` missing and the old set in
``.<name>.old-<pid>-<random>``, which the next run moves back (:func:`clean_leftovers`).

Every other file is written beside its target and renamed over it (:func:`atomic_write_bytes`).
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import shutil
import stat
import tempfile
from pathlib import Path

from . import __version__
from .build import fmu_source

# A folder a command keeps writing into across runs (plot, sweep, figures) holds this
# marker, naming the command: the proof that the folder is tribofmu's (a file's name is
# none: a user's time.png is named as ours). Read within MARKER_BYTES, never through a link
# or from a FIFO. Result sets (simulate, accuracy) and FMU folders (build) carry no marker:
# their own files are the proof (:data:`RECORDS`).
MARKER = ".tribofmu-output"
MARKER_BYTES = 4096
# What a run may find in its output folder and replace; anything else there is the user's,
# and a result set never replaces a folder holding it.
RESULT_NAMES = frozenset({"stats.json", "result.csv", "columns.json", "time.png", "phase.png", "friction.png",
                          "kinetics.png"})
ACCURACY_NAMES = frozenset({"accuracy.png", "accuracy.csv", "summary.json"})
RECORD_BYTES = 16_000_000  # the largest JSON record read to see whether a folder is ours
FMU_BYTES = 50_000_000  # the largest .fmu looked into (ours are < 1 MB)
PARTIAL, OLD = "partial", "old"
_RENAME_EXCHANGE = 2
_published: list[Path] = []  # result sets this process has swapped in (for the Ctrl-C message)


def published() -> list[Path]:
    """The result sets this process has swapped in since :func:`forget_published`."""
    return list(_published)


def forget_published() -> None:
    _published.clear()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux ``renameat2``); False where that is not available."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):  # file system or kernel without it
        return False
    raise OSError(err, os.strerror(err), str(b))


def _sibling(out: Path, kind: str) -> Path:
    return Path(tempfile.mkdtemp(prefix=f".{out.name}.{kind}-{os.getpid()}-", dir=out.parent))


def _pid_of(name: str, prefix: str, separator: str = "-") -> int | None:
    """The process id in ``<prefix><pid><separator>...`` (None: not such a name)."""
    pid = name[len(prefix):].split(separator, 1)[0]
    if pid.isdigit() and len(pid) <= 9:
        return int(pid)
    return None


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):  # someone else's process / not a pid at all
        return True
    return True


def left_by_gone_process(path: Path, prefix: str, separator: str = "-") -> bool:
    """Whether ``path``, named ``<prefix><pid><separator>...``, is what a process of this user
    that no longer exists left behind: a real file or folder (not a link), this user's, its
    pid not this process and not alive. Anything else is not ours to remove."""
    pid = _pid_of(path.name, prefix, separator)
    if pid is None or pid == os.getpid():
        return False
    try:
        info = os.lstat(path)
    except OSError:
        return False
    if stat.S_ISLNK(info.st_mode) or (hasattr(os, "getuid") and info.st_uid != os.getuid()):
        return False
    return not pid_alive(pid)


def clean_leftovers(out: Path) -> None:
    """Remove what killed runs left beside ``out`` (partial sets of processes that are gone),
    and move an old set back where a kill came between the two renames of a swap."""
    out = Path(out)
    if not out.parent.is_dir():
        return
    if out.is_dir() and not out.is_symlink():  # earlier versions staged inside the folder
        for path in out.glob(".partial-*"):
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path, ignore_errors=True)
    for kind in (OLD, PARTIAL):
        prefix = f".{out.name}.{kind}-"
        for path in sorted(out.parent.glob(prefix + "*")):
            pid = _pid_of(path.name, prefix)
            if pid is None or pid == os.getpid() or pid_alive(pid) or path.is_symlink():
                continue
            if kind == OLD and not out.exists():
                with contextlib.suppress(OSError):
                    os.rename(path, out)  # the swap was cut between its renames: the old set back
                    continue
            shutil.rmtree(path, ignore_errors=True)


def _read_small(path: Path, limit: int) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (not a link, FIFO or device; checked
    before it is opened, and opened without blocking) of at most ``limit`` bytes; else None."""
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return None
            data = fh.read(limit + 1)
    except OSError:
        return None
    return data if len(data) <= limit else None


def json_object(path: Path, limit: int) -> dict | None:
    """The JSON object in ``path`` (read as :func:`_read_small` reads), or None."""
    data = _read_small(path, limit)
    try:
        value = json.loads(data) if data is not None else None
    except ValueError:
        return None
    return value if isinstance(value, dict) else None


def made_by(folder: Path) -> str | None:
    """The command whose marker ``folder`` holds (None: no marker, or not a readable one)."""
    marker = json_object(Path(folder) / MARKER, MARKER_BYTES)
    command = marker.get("command") if marker else None
    return command if isinstance(command, str) else None


def mark(folder: Path, command: str) -> None:
    """Write ``command``'s marker into ``folder`` (one it made)."""
    atomic_write_bytes(Path(folder) / MARKER, (json.dumps({"command": command, "tribofmu": __version__})
                                               + "\n").encode())


def _has_record(name: str, key: str):
    """A folder whose JSON object ``name`` (at most RECORD_BYTES) has ``key``: what the
    command writes there (and wrote before markers existed)."""
    def check(folder: Path) -> bool:
        record = json_object(Path(folder) / name, RECORD_BYTES)
        return record is not None and key in record
    return check


def _fmus_of_ours(folder: Path) -> bool:
    """A folder holding only FMUs built by tribofmu (and leftovers of a killed build)."""
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.name.startswith(".") and ".fmu.partial-" in entry.name:
                continue
            if not (entry.name.endswith(".fmu") and entry.is_file(follow_symlinks=False)
                    and entry.stat(follow_symlinks=False).st_size <= FMU_BYTES
                    and fmu_source(Path(entry.path)) is not None):
                return False
    return True


# How a folder made by each command is known without a marker.
RECORDS = {"simulate": _has_record("stats.json", "provenance"),
           "accuracy": _has_record("summary.json", "columns"),
           "sweep": _has_record("sweep.json", "fmu_source"),  # a sweep of an earlier version
           "build": _fmus_of_ours}


def ours(folder: Path, commands: tuple[str, ...]) -> bool:
    """Whether ``folder`` was made by one of ``commands``: its marker names one, or (without
    a marker) its own files show it (:data:`RECORDS`)."""
    if made_by(folder) in commands:
        return True
    if os.path.lexists(Path(folder) / MARKER):
        return False  # another command's, or not a marker at all
    return any(command in RECORDS and RECORDS[command](folder) for command in commands)


def first_entries(folder: Path, count: int = 4) -> list[str]:
    """Up to ``count`` names in ``folder`` (a folder of millions is not listed whole)."""
    names = []
    with os.scandir(folder) as entries:
        for entry in entries:
            names.append(entry.name)
            if len(names) >= count:
                break
    return sorted(names)


def check_output_folder(out: Path, commands: tuple[str, ...]) -> None:
    """The output rule every command keeps: ``out`` is new, an empty folder, or a folder one
    of ``commands`` made (:func:`ours`); a symbolic link, a file or any other folder raises
    FileExistsError (one line) and nothing is written."""
    out = Path(out)
    if out.is_symlink():
        raise FileExistsError(f"{out} is a symbolic link; give the folder it points to, or a new one")
    if not os.path.lexists(out):
        return
    if not out.is_dir():
        raise FileExistsError(f"{out} is a file, not a folder")
    names = first_entries(out)
    if not names or ours(out, commands):
        return
    shown = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
    raise FileExistsError(f"{out} holds files that tribofmu {commands[0]} did not write ({shown}); "
                          f"give a new or empty folder")


def check_replaceable(out: Path, names=RESULT_NAMES) -> None:
    """Raise FileExistsError unless ``out`` is new, empty, or a result set of the command that
    writes ``names`` (:func:`check_output_folder`) holding no other files (a result set
    replaces the whole folder, and must never take the user's files with it)."""
    out = Path(out)
    check_output_folder(out, (_command_of(names),))
    if not out.is_dir():
        return
    foreign = sorted(name for name in os.listdir(out) if name not in names)
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise FileExistsError(f"{out} holds files that are not a tribofmu result ({shown}); "
                              f"give a new or empty folder")


def _command_of(names) -> str:
    return "accuracy" if names == ACCURACY_NAMES else "simulate"


@contextlib.contextmanager
def result_set(out: Path, names=RESULT_NAMES):
    """Yield a new, empty folder beside ``out``; on success it becomes ``out`` as a whole
    (the previous set is removed), on failure or interruption ``out`` stays as it was.

    ``out`` must not hold files other than result files (:func:`check_replaceable`)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    clean_leftovers(out)
    check_replaceable(out, names)
    tmp = _sibling(out, PARTIAL)
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp made it private; results are as readable as any file
        _swap_in(tmp, out)
        _published.append(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # the unfinished set, or the previous one after the swap


def _swap_in(new: Path, out: Path) -> None:
    """``new`` becomes ``out``; what ``out`` held is left at ``new`` (to be removed)."""
    if not out.exists():
        try:
            os.rename(new, out)
            return
        except OSError as exc:
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY):  # another run made it meanwhile
                raise
    if _exchange(new, out):
        return
    aside = _sibling(out, OLD)
    os.rmdir(aside)
    os.rename(out, aside)
    os.rename(new, out)
    os.rename(aside, new)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write a file whole or not at all (readable as the umask allows, like any new file)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise

