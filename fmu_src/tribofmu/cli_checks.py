"""What the ``tribofmu`` command checks before anything runs, and where its results go.

Output folders (``out/<scene>[--<overrides>]``, one canonical name per run), the preflight of
a folder (writable, free space, holds nothing but results), the numbers and options that
must make sense, the FMUs found or built. Every failure is a :class:`UsageError` (one line,
exit 2) or an OSError (one line, exit 1), raised before the run.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import math
import os
import re
import sys
import tempfile
from pathlib import Path

from .atomic import MARKER, check_output_folder, check_replaceable, mark
from .fmu_cache import check_writable, find_fmus, write_error
from .provenance import overrides_dict, run_label
from .errors import MAX_MESSAGE, UsageError, readable  # noqa: F401 (UsageError re-exported: bad input, exit code 2)
from .scene.checks import (MIN_MAX_WALL, check_max_wall, check_resolution,  # noqa: F401 (re-exported)
                           check_run)

OUTPUT_ROOT = Path("out")  # default output folders: OUTPUT_ROOT/<scene name>[--<overrides>]
# A scene name that may name a folder: printable, no separators, no "..", not too long.
FOLDER_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+=,-]{0,99}$")
PLOT_BYTES = 1_000_000  # the PNGs of a run, generously
SSP_BYTES = 10_000_000  # an .ssp archive holds up to six FMUs of < 1 MB
SWEEP_POINT_BYTES = 20_000  # a sweep point: its row, its portrait (.npz)


# -- checks made before anything runs ----------------------------------------------------------
def check_out_dir(path: Path, option: str = "--out") -> Path:
    """A folder to write into: it and its parents must not be files."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            if not candidate.is_dir():
                raise UsageError(f"{option} {path}: {candidate} is a file, not a folder")
            break
    return path


def check_out_file(path: Path, option: str = "--out") -> Path:
    """A file to write: not a folder, and its parents not files."""
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a folder, not a file")
    check_out_dir(path.parent, option)
    return path


def output_folder(name: str, overrides: dict[str, str], suffix: str = "", what: str = "scenario.name") -> Path:
    """``out/<name>[--<overrides>][<suffix>]`` for a scene name that can name a folder (a
    name from a scenario file must not choose where files go: no separators, no "..", no
    absolute path, printable, at most 100 characters)."""
    if not FOLDER_NAME.match(name) or ".." in name:
        shown = name.encode("unicode_escape").decode("ascii")
        shown = shown if len(shown) <= 60 else f"{shown[:60]}... ({len(name)} characters)"
        raise UsageError(f"{what} {shown!r} cannot name an output folder (letters, digits and "
                         f"._+=,- only, at most 100 characters); rename it or give --out")
    return OUTPUT_ROOT / f"{run_label(name, overrides)}{suffix}"


def preflight(out: Path, needed_bytes: int, option: str = "--out") -> None:
    """Before any work: ``out``'s parent can take a new folder and has the space the results
    need (OSError, one line, exit 1, otherwise); ``out`` holds nothing but results (exit 2)."""
    check_out_dir(out, option)
    check_swappable(out, option)
    try:
        check_replaceable(out)
    except FileExistsError as exc:
        raise UsageError(f"{option} {exc}") from None
    _writable_folder(out.absolute().parent, needed_bytes, f"{option}'s parent")
    lock_out(out, option)


def check_swappable(out: Path, option: str = "--out") -> None:
    """A result set replaces ``out`` as a whole (a sibling folder renamed in its place): the
    current folder, one of its parents or a mount point cannot be, so they are refused
    before the run rather than at its end (``--out .``: "Device or resource busy")."""
    absolute = Path(os.path.abspath(out))
    if out.name in ("", ".", "..") or absolute == Path(absolute.anchor):
        raise UsageError(f"{option} {out}: a result set replaces its folder as a whole, and "
                         f"{out} cannot be replaced; give a folder inside it, e.g. {option} {out / 'run'}")
    if out.is_symlink() or not out.is_dir():
        return  # check_replaceable refuses links and files; a new folder can always be swapped
    resolved, cwd = out.resolve(), Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise UsageError(f"{option} {out} is the current folder or holds it: a result set replaces "
                         f"its folder as a whole, which cannot be done to the folder a process runs "
                         f"in; give another folder")
    if os.path.ismount(resolved):
        raise UsageError(f"{option} {out} is a mount point: a result set replaces its folder as a "
                         f"whole, which cannot be done to a mount point; give a folder inside it")


# -- one run per output folder -------------------------------------------------------------------
_held: list[tuple[Path, int]] = []  # (lock file, fd) this process holds


def lock_path(out: Path) -> Path:
    """The lock of the folder ``out`` names: a file in this user's private lock folder in the
    temp dir, named by a hash of the folder's real path (not beside it: the preflight makes no
    folder, and the folder itself is swapped out by the run)."""
    real = os.path.realpath(out)
    uid = os.getuid() if hasattr(os, "getuid") else 0
    name = hashlib.sha256(os.fsencode(real)).hexdigest()[:24]
    return Path(tempfile.gettempdir()) / f"tribofmu-{uid}-locks" / f"{name}.lock"


def lock_out(out: Path, option: str = "--out") -> None:
    """Hold ``out``'s lock until :func:`release_out_locks` (the end of the command) or the
    process's end: a second run writing into the same folder meanwhile is refused with one
    line (UsageError) before it simulates, instead of silently replacing the other's set."""
    import fcntl  # POSIX only: the rest of the command runs where it is missing
    path = lock_path(out)
    if any(held == path for held, _ in _held):
        return
    try:
        path.parent.mkdir(mode=0o700, exist_ok=True)
        if path.parent.is_symlink() or path.parent.stat().st_uid != os.getuid():
            return  # not this user's: no lock rather than one someone else controls
    except OSError:
        return  # no temp dir to lock in: the run goes on unlocked, as before
    for _ in range(10):
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
        except FileNotFoundError:  # another run removed the (empty) lock folder just now
            with contextlib.suppress(OSError):
                path.parent.mkdir(mode=0o700, exist_ok=True)
            continue
        except OSError:
            return  # no lock to be had here: the run goes on unlocked, as before
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            holder = _lock_holder(path)
            raise UsageError(f"{option} {out}: another tribofmu run{holder} is writing into this "
                             f"folder; wait for it to end or give another {option}") from None
        except OSError:  # a file system without locks: nothing to hold
            os.close(fd)
            return
        # the holder before us may have removed the file after we opened it: lock the file
        # that is there now, or we and a third run would each hold a lock of our own
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except OSError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            _held.append((path, fd))
            return
        os.close(fd)


def _lock_holder(path: Path) -> str:
    try:
        pid = path.read_text().strip()
    except OSError:
        return ""
    return f" (process {pid})" if pid.isdigit() else ""


def release_out_locks() -> None:
    """Give up the locks :func:`lock_out` took (the lock file removed, then unlocked), and
    remove the folders :func:`claim_out` made that hold nothing but their marker (a command
    refused or failed before it wrote anything leaves no folder behind)."""
    while _claimed:
        folder = _claimed.pop()
        with contextlib.suppress(OSError):
            if os.listdir(folder) in ([MARKER], []):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(folder / MARKER)
                os.rmdir(folder)
    while _held:
        path, fd = _held.pop()
        try:
            if os.stat(path).st_ino == os.fstat(fd).st_ino:
                os.unlink(path)
        except OSError:
            pass
        os.close(fd)
        with contextlib.suppress(OSError):
            path.parent.rmdir()  # when no other run holds a lock: the temp dir as it was


_claimed: list[Path] = []  # folders claim_out made in this process
UNMARKED = ("build",)  # a folder of FMUs is known by its FMUs (tribofmu.atomic.RECORDS)


def claim_out(out: Path, command: str, needed_bytes: int, option: str = "--out",
              also: tuple[str, ...] = ()) -> Path:
    """The output rule for a folder a command writes into and keeps (build, plot, sweep,
    figures): ``out`` must be new, empty, or a folder ``command`` (or one of ``also``) made,
    never a symbolic link (UsageError, one line, before any work); then it is made, with
    ``command``'s marker (:func:`tribofmu.atomic.mark`; build's FMUs are their own proof),
    so the next run knows it as its own."""
    try:
        check_output_folder(out, (command, *also))
    except FileExistsError as exc:
        raise UsageError(f"{option} {exc}") from None
    preflight_folder(out, needed_bytes, option)
    try:
        if not out.exists():
            _claimed.append(out)  # removed again at the end if the command wrote nothing into it
        out.mkdir(parents=True, exist_ok=True)
        if command not in UNMARKED and not (out / MARKER).exists():
            mark(out, command)
    except OSError as exc:
        raise write_error(f"cannot write into {option} {out}: {exc.strerror or exc}", exc.errno) from None
    return out


def preflight_folder(out: Path, needed_bytes: int, option: str = "--out") -> None:
    """For outputs kept across runs (a sweep's folder, an .ssp file's folder): ``out`` can be
    written and has the space (OSError, exit 1, otherwise)."""
    check_out_dir(out, option)
    _writable_folder(out.absolute(), needed_bytes, option)


def _writable_folder(folder: Path, needed_bytes: int, what: str) -> None:
    """The absolute ``folder`` takes files and has ``needed_bytes`` free; for a missing one its
    nearest existing ancestor is checked instead, and nothing is made (whatever fails later,
    before the results are written, leaves no empty folder behind)."""
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    check_writable(existing, needed_bytes, what)


def check_number(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise UsageError(f"{name} must be > 0 and finite, got {value}")


def check_algorithm_options(scenario, algorithm: str | None, step: float | None, tol: float | None,
                            max_wall: float | None = None) -> str:
    """The algorithm that will run; a --step/--tol it does not use, or out of range, is an
    error (the scene's own checks, :func:`tribofmu.scene.checks.check_run`, under the
    options' names)."""
    check_max_wall(max_wall, "--max-wall")
    return check_run(scenario, algorithm, step, tol, OPTION_NAMES)


OPTION_NAMES = {"algorithm": "--algorithm", "step": "--step", "tol": "--tol"}


def require(module: str, install: str, purpose: str) -> None:
    """A missing optional piece is one line naming what to install."""
    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a broken install counts as missing
        found = False
    if not found:
        raise UsageError(f"{purpose} needs the package {install!r}: python -m pip install '{install}'")


def resolve_fmu_dir(fmu_dir: str | None, names, quiet: bool = False, fmi: int | None = None) -> Path:
    """The FMUs a command uses (:func:`tribofmu.fmu_cache.find_fmus`): an explicit folder
    must hold them; the per-user cache is checked and filled when needed."""
    notice = None if quiet else (lambda text: print(f"tribofmu: {text} (once per installed version)",
                                                    file=sys.stderr))
    return find_fmus(names, fmu_dir, fmi=fmi, build=None if fmu_dir is None else False, notice=notice)


def label_overrides(overrides, algorithm=None, step=None, tol=None, max_wall=None, fmi=None,
                    scenario=None, base=None) -> dict[str, str]:
    """What makes a run differ from the scene, canonical: the --set values and the options
    --algorithm, --step, --tol, --max-wall (as their simulation.* keys; an option wins over a
    --set of the same key, as in the run) and --fmi 3, sorted by key. Given the overridden
    ``scenario``, each --set value is written as the scenario holds it (``--step 1e-3`` and
    ``--set simulation.step=0.001`` give the same label); given the ``base`` scene too, a
    value equal to the scene's own is dropped (the same run, the same folder)."""
    from .scene.scenario import to_dict  # the scene parser (with the coupling and the physics): 84 ms
    # at start-up (-X importtime, min of 5, 2026-11-26 23:59 UTC, load 5.5) that --help and 'scenes' skip
    data = to_dict(scenario) if scenario is not None else {}
    old = to_dict(base) if base is not None else {}
    label = {}
    for key, text in overrides_dict(overrides).items():
        table, _, name = key.partition(".")
        label[key] = data.get(table, {}).get(name, text)
    for key, value in (("simulation.algorithm", algorithm), ("simulation.step", step),
                       ("simulation.tol", tol), ("simulation.max_wall", max_wall)):
        if value is not None:
            label[key] = value
    out = {}
    for key in sorted(label):
        table, _, name = key.partition(".")
        if base is not None and name in old.get(table, {}) and _canonical(old[table][name]) == _canonical(label[key]):
            continue
        out[key] = _canonical(label[key])
    if fmi == 3:
        out["fmi"] = "3"
    return out


def _canonical(value) -> str:
    """One spelling per value: 0.001 for 1e-3, 80 for 80.0, true/false, 5,6.5 for [5, 6.5]."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        text = repr(float(value))
        return text[:-2] if text.endswith(".0") else text
    if isinstance(value, (list, tuple)):
        return ",".join(_canonical(v) for v in value)
    return str(value)


def one_line(exc: BaseException) -> str:
    """An exception as one line (an OSError from the system with its file name)."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    else:
        text = str(exc)
    return readable(" ".join(text.split()), MAX_MESSAGE - 50)  # room for "tribofmu: " and a suffix
