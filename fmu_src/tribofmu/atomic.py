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
import os
import shutil
import stat
import tempfile
from pathlib import Path

# What a run may find in its output folder and replace; anything else there is the user's,
# and a result set never replaces a folder holding it.
RESULT_NAMES = frozenset({"stats.json", "result.csv", "columns.json", "time.png", "phase.png", "friction.png",
                          "kinetics.png"})
ACCURACY_NAMES = frozenset({"accuracy.png", "accuracy.csv", "summary.json"})
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


def check_replaceable(out: Path, names=RESULT_NAMES) -> None:
    """Raise FileExistsError when ``out`` holds files other than ``names`` (a result set
    replaces the whole folder, and must never take the user's files with it)."""
    out = Path(out)
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise FileExistsError(f"{out} is {'a symbolic link' if out.is_symlink() else 'a file'}, not a folder")
    if not out.is_dir():
        return
    foreign = sorted(name for name in os.listdir(out) if name not in names)
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise FileExistsError(f"{out} holds files that are not a tribofmu result ({shown}); "
                              f"give an empty or new folder as --out")


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

