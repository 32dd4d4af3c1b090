"""What the ``tribofmu`` command checks before anything runs, and where its results go.

Output folders (``out/<scene>[--<overrides>]``, one canonical name per run), the preflight of
a folder (writable, free space, holds nothing but results), the numbers and options that
must make sense, the FMUs found or built. Every failure is a :class:`UsageError` (one line,
exit 2) or an OSError (one line, exit 1), raised before the run.
"""
from __future__ import annotations

import importlib.util
import math
import re
import sys
from pathlib import Path

OUTPUT_ROOT = Path("out")  # default output folders: OUTPUT_ROOT/<scene name>[--<overrides>]
# A scene name that may name a folder: printable, no separators, no "..", not too long.
FOLDER_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+=,-]{0,99}$")
PLOT_BYTES = 1_000_000  # the PNGs of a run, generously
SSP_BYTES = 10_000_000  # an .ssp archive holds up to six FMUs of < 1 MB
SWEEP_POINT_BYTES = 20_000  # a sweep point: its row, its portrait (.npz)



class UsageError(Exception):
    """Bad input from the command line: reported as one line, exit code 2."""


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
    from .provenance import run_label
    if not FOLDER_NAME.match(name) or ".." in name:
        shown = name.encode("unicode_escape").decode("ascii")
        shown = shown if len(shown) <= 60 else f"{shown[:60]}... ({len(name)} characters)"
        raise UsageError(f"{what} {shown!r} cannot name an output folder (letters, digits and "
                         f"._+=,- only, at most 100 characters); rename it or give --out")
    return OUTPUT_ROOT / f"{run_label(name, overrides)}{suffix}"


def preflight(out: Path, needed_bytes: int, option: str = "--out") -> None:
    """Before any work: ``out``'s parent can take a new folder and has the space the results
    need (OSError, one line, exit 1, otherwise); ``out`` holds nothing but results (exit 2)."""
    from .atomic import check_replaceable
    check_out_dir(out, option)
    try:
        check_replaceable(out)
    except FileExistsError as exc:
        raise UsageError(f"{option} {exc}") from None
    _writable_folder(out.absolute().parent, needed_bytes, f"{option}'s parent")


def preflight_folder(out: Path, needed_bytes: int, option: str = "--out") -> None:
    """For outputs kept across runs (a sweep's folder, an .ssp file's folder): ``out`` can be
    written and has the space (OSError, exit 1, otherwise)."""
    check_out_dir(out, option)
    _writable_folder(out.absolute(), needed_bytes, option)


def _writable_folder(folder: Path, needed_bytes: int, what: str) -> None:
    """The absolute ``folder`` takes files and has ``needed_bytes`` free; for a missing one its
    nearest existing ancestor is checked instead, and nothing is made (whatever fails later,
    before the results are written, leaves no empty folder behind)."""
    from .fmu_cache import check_writable
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    check_writable(existing, needed_bytes, what)


def check_number(name: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise UsageError(f"{name} must be > 0 and finite, got {value}")


def check_algorithm_options(scenario, algorithm: str | None, step: float | None, tol: float | None,
                            max_wall: float | None = None) -> str:
    """The algorithm that will run; a --step/--tol it does not use is an error."""
    from .coupling.algorithms import ALGORITHMS
    for name, value in (("--step", step), ("--tol", tol)):
        check_number(name, value)
    if max_wall is not None and not (math.isfinite(max_wall) and max_wall >= 0):
        raise UsageError(f"--max-wall must be >= 0 s (0: no limit), got {max_wall}")
    name = algorithm or scenario.simulation.algorithm
    if name not in ALGORITHMS:
        raise UsageError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})")
    if tol is not None and name != "adaptive":
        raise UsageError(f"--tol applies to the adaptive algorithm only, not {name} (use --step)")
    return name


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
    from .fmu_cache import find_fmus
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
    from .provenance import overrides_dict
    from .scene.scenario import to_dict
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
    return " ".join(text.split())
