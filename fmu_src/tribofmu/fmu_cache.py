"""Find or build the FMUs a run needs: the one function every command and the API use.

Without a folder, the FMUs come from the per-user cache of FMUs built from the installed
source (:func:`tribofmu.build.default_fmu_dir`). Nothing there is run because of its name:

- the cache folders are the user's own and private (mode 0700), never symbolic links;
- ``manifest.json`` beside the FMUs records each file's sha256 when this code built it;
  an FMU is used only when it is a regular file (not a link) whose content has that hash.
  A missing, planted or damaged FMU is rebuilt, that one alone;
- leftovers of killed builds (``.<Name>.fmu.partial-<pid>`` in the cache, staging folders
  ``tribofmu_build_<pid>_*`` in the temp dir) are removed once their process is gone.

With a folder (``--fmu-dir``), the FMUs there are the user's choice: they must exist (and be
of the FMI version asked for); they are built there only on request (``build``).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import stat
import tempfile
import zipfile
from pathlib import Path
from typing import Callable, Iterable

from .atomic import atomic_write_bytes, json_object, left_by_gone_process, pid_alive
from .build import BUILD_PREFIX, build_fmus, cache_root, default_fmu_dir, fmu_source, private_package_name
from .errors import FMUCacheError, FMUError, FMUFileError  # noqa: F401 (FMUCacheError re-exported)

MANIFEST = "manifest.json"
LOCK = ".build.lock"
# A cold build writes six FMUs of < 1 MB each and stages them in the temp dir first.
BUILD_BYTES = 20_000_000


def sha256_file(path: Path) -> str:
    """sha256 of a regular file: checked with lstat before it is opened (a FIFO, a device or
    a folder is never opened: an open of a FIFO blocks until a writer comes), opened without
    following a symbolic link and without blocking, and checked again on the open file."""
    if not stat.S_ISREG(os.lstat(path).st_mode):
        raise OSError(f"{path} is not a regular file")
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
            raise OSError(f"{path} is not a regular file")
        digest = hashlib.sha256()
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def find_fmus(names: Iterable[str], fmu_dir: str | Path | None = None, *, fmi: int | None = None,
              build: bool | None = None, notice: Callable[[str], None] | None = None) -> Path:
    """The folder holding ``<name>.fmu`` for every name, verified or built.

    fmu_dir None: the per-user cache of FMI ``fmi`` (default 2) FMUs, each checked against
    its recorded hash; missing or mismatching ones are built (unless build is False: then
    FMUError). fmu_dir given: build True rebuilds the names there, None builds the missing
    ones, False (the default for a given folder) requires them. notice(text) is told
    before a build. Raises :class:`~tribofmu.master.instance.FMUFileError` (a
    FileNotFoundError) naming the first missing file, :class:`FMUCacheError` when the cache
    cannot be used.
    """
    names = tuple(dict.fromkeys(names))
    if fmu_dir is not None:
        return _given_folder(Path(fmu_dir), names, fmi, build, notice)
    fmi = fmi or 2
    folder = default_fmu_dir(fmi)
    _private_folder(folder)
    manifest = _read_manifest(folder)
    stale = names if build else tuple(n for n in names if not _verified(folder, n, manifest, fmi))
    if not stale:
        return folder
    if build is False:
        raise FMUFileError(f"FMU file not found or not as built: {folder / (stale[0] + '.fmu')} "
                           f"(run 'tribofmu build')")
    try:
        with _build_lock(folder):
            manifest = _read_manifest(folder)  # another process may have built them meanwhile
            stale = names if build else tuple(n for n in names if not _verified(folder, n, manifest, fmi))
            if stale:
                _build_into(folder, stale, fmi, notice, manifest)
    except FMUError:
        raise
    except OSError as exc:  # the cache removed or made unwritable while building: exit 1, not "missing input"
        raise write_error(f"cannot write the FMU cache {folder}: {exc.strerror or exc} (was it removed or "
                          f"changed while the FMUs were built? run the command again)", exc.errno) from None
    return folder


def _given_folder(path: Path, names: tuple[str, ...], fmi: int | None, build: bool | None,
                  notice) -> Path:
    missing = [n for n in names if not (path / f"{n}.fmu").is_file()]
    todo = names if build else tuple(missing) if build is None else ()
    if todo:
        _build_into(path, todo, fmi or 2, notice, None)
        missing = []
    if missing:
        option = f" --fmi {fmi}" if fmi == 3 else ""
        error = FMUFileError(f"FMU file not found: {path / (missing[0] + '.fmu')} "
                             f"(build it with 'tribofmu build --out {path}{option}', or drop --fmu-dir)")
        error.filename = str(path / (missing[0] + ".fmu"))  # as a FileNotFoundError names its file
        raise error
    if fmi is not None:
        import fmpy  # 137 ms at start-up (see master.instance): only an --fmi check reads a description here
        for name in names:
            found = fmpy.read_model_description(str(path / f"{name}.fmu"), validate=False).fmiVersion
            if not found.startswith(str(fmi)):
                raise FMUFileError(f"--fmi {fmi}: {path / (name + '.fmu')} is an FMI {found} FMU")
    return path


def _build_into(folder: Path, names: tuple[str, ...], fmi: int, notice, manifest: dict | None) -> None:
    """Build ``names`` into ``folder`` after checking it can take them; record their hashes
    in the manifest when there is one (the cache)."""
    folder.mkdir(parents=True, exist_ok=True)
    remove_build_leftovers(folder)
    check_writable(folder, BUILD_BYTES, "the FMU folder")
    check_writable(Path(tempfile.gettempdir()), BUILD_BYTES, "the temp dir (FMUs are staged there)")
    for name in names:
        path = folder / f"{name}.fmu"
        if manifest is not None:
            _clear_for_build(path)  # the cache is ours: a folder or FIFO there is damage
        elif os.path.lexists(path) and not stat.S_ISREG(os.lstat(path).st_mode):
            raise FMUFileError(f"{path} is not an FMU file (a folder, a link or a special file); "
                               f"remove it or give another folder")
    if notice is not None:
        notice(f"building the FMI {fmi}.0 FMUs {', '.join(names)} into {folder}/")
    built = build_fmus(folder, names, fmi=fmi)
    if manifest is not None:
        manifest.update({path.stem: sha256_file(path) for path in built})
        atomic_write_bytes(folder / MANIFEST, (json.dumps(manifest, indent=2, sort_keys=True) + "\n").encode())


def _verified(folder: Path, name: str, manifest: dict[str, str], fmi: int) -> bool:
    """The cached ``<name>.fmu`` is what this install built: a regular file whose sha256 is
    the one recorded when it was built and which carries this source's private package (an
    FMU of another build under a manifest rewritten to match is still not ours)."""
    path = folder / f"{name}.fmu"
    expected = manifest.get(name)
    if expected is None:
        return False
    try:
        return sha256_file(path) == expected and fmu_source(path) == private_package_name(fmi)
    except OSError:  # missing, a link, a FIFO, a folder
        return False


def _clear_for_build(path: Path) -> None:
    """Make way in the cache for a rebuilt ``path``: whatever is there and is not a regular
    file (a folder, a FIFO, a link, a socket) is removed; a regular file is replaced by the
    build's rename. Only ever called on the private cache."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISDIR(info.st_mode):
        shutil.rmtree(path)
    elif not stat.S_ISREG(info.st_mode):
        os.unlink(path)


MANIFEST_BYTES = 100_000  # six hashes take 500 bytes


def _read_manifest(folder: Path) -> dict[str, str]:
    """The recorded hashes (empty when the manifest is missing, not a small regular file, or
    not a JSON object: the FMUs are then rebuilt)."""
    data = json_object(folder / MANIFEST, MANIFEST_BYTES)
    return {str(k): str(v) for k, v in data.items()} if data else {}


def _private_folder(folder: Path) -> None:
    """Make the cache folder and its parents; from the cache root down each must be a real
    folder of this user, and the root private (0700).

    The root's own missing parents (``~/.cache`` on a new account, a ``TRIBOFMU_CACHE`` under
    a folder not made yet) are made too, private as the XDG base-directory spec asks of
    ``~/.cache``; the ones that exist are not checked: they are the user's."""
    root = cache_root()
    missing_above = [p for p in root.parents if not p.exists()][::-1]
    ours = [p for p in (folder, *folder.parents) if p == root or root in p.parents][::-1]
    for path in (*missing_above, *ours):
        try:
            path.mkdir(mode=0o700, exist_ok=True)
            info = os.lstat(path)
        except OSError as exc:  # a failed write: one line, exit 1 in the CLI
            raise write_error(f"cannot write the FMU cache {path}: {exc.strerror or exc}", exc.errno) from None
        if path in missing_above:
            continue
        if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
            raise FMUCacheError(f"FMU cache {path} is not a folder (a link or a file); remove it or "
                                f"set TRIBOFMU_CACHE")
        if hasattr(os, "getuid") and info.st_uid != os.getuid():
            raise FMUCacheError(f"FMU cache {path} belongs to another user; set TRIBOFMU_CACHE")
        if path == root and stat.S_IMODE(info.st_mode) & 0o077:
            os.chmod(path, 0o700)


@contextlib.contextmanager
def _build_lock(folder: Path):
    import fcntl  # POSIX only
    _clear_for_build(folder / LOCK)  # a FIFO there would block the open
    fd = os.open(folder / LOCK, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0),
                 0o600)
    with os.fdopen(fd, "r+b") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def write_error(message: str, errno_: int | None) -> OSError:
    """A folder that cannot be written, as a plain OSError (exit 1 in the CLI): not the
    subclass its errno would pick, since a FileNotFoundError reads as a missing input (exit 2)."""
    error = OSError(message)
    error.errno = errno_
    return error


def check_writable(folder: Path, needed_bytes: int, what: str) -> None:
    """Raise OSError (one line) unless a file can be created in ``folder`` and the disk has
    ``needed_bytes`` free."""
    probe = None
    try:
        fd, probe = tempfile.mkstemp(prefix=".tribofmu-probe-", dir=folder)
        os.close(fd)
    except OSError as exc:
        raise write_error(f"cannot write into {what} {folder}: {exc.strerror or exc}", exc.errno) from None
    finally:
        if probe:
            with contextlib.suppress(OSError):
                os.unlink(probe)
    free = shutil.disk_usage(folder).free
    if free < needed_bytes:
        raise write_error(f"{what} {folder} has {free / 1e6:.1f} MB free, {needed_bytes / 1e6:.1f} MB needed", 28)


def remove_build_leftovers(folder: Path | None = None) -> None:
    """Remove what killed builds left: ``.<Name>.fmu.partial-<pid>`` in ``folder`` and this
    user's ``tribofmu_build_<pid>_*`` staging folders in the temp dir, of processes that are gone."""
    if folder is not None and folder.is_dir():
        for path in folder.glob(".*.fmu.partial-*"):
            pid = path.name.rsplit("-", 1)[-1]
            if pid.isdigit() and len(pid) <= 9 and not pid_alive(int(pid)):
                with contextlib.suppress(OSError):
                    path.unlink()
    tmp = Path(tempfile.gettempdir())
    for path in tmp.glob(BUILD_PREFIX + "*"):
        if left_by_gone_process(path, BUILD_PREFIX, "_") and path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
