"""What produced a result: the scene file and its hash, the overrides, the algorithm settings,
the versions of the software and the GUIDs of the FMUs; and the default output folder,
distinct per scene and overrides so that two runs never share one silently.
"""
from __future__ import annotations

import hashlib
import platform
import re
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from . import __version__

# A folder name made of the overrides themselves while short and plain; else a hash of them.
_PLAIN = re.compile(r"^[A-Za-z0-9._=,+-]+$")
_MAX_NAME = 60


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def versions() -> dict[str, str]:
    """Versions of tribofmu, fmpy, pythonfmu, numpy, scipy and Python."""
    # importlib.metadata (with email, csv): 13 ms at start-up (-X importtime, 2026-11-27 00:03 UTC,
    # load 4.5) that every command would pay, --help and 'scenes' too; only a run's record asks
    from importlib.metadata import PackageNotFoundError, version

    found = {"tribofmu": __version__}
    for package in ("fmpy", "pythonfmu", "numpy", "scipy"):
        try:
            found[package] = version(package)
        except PackageNotFoundError:
            found[package] = "not installed"
    found["python"] = platform.python_version()
    return found


def overrides_dict(overrides: dict[str, Any] | list[str] | tuple | None) -> dict[str, str]:
    """``["drive.omega=80"]`` or ``{"drive.omega": 80}`` as ``{"drive.omega": "80"}`` (in the given order)."""
    if not overrides:
        return {}
    if isinstance(overrides, dict):
        return {str(k): str(v) for k, v in overrides.items()}
    out = {}
    for item in overrides:
        key, _, value = str(item).partition("=")
        out[key.strip()] = value.strip()
    return out


def run_label(name: str, overrides: dict[str, str]) -> str:
    """``fig2_dry`` without overrides; ``fig2_dry--drive.omega=80`` with (or ``fig2_dry--<hash>``
    when the overrides do not make a short, plain folder name)."""
    if not overrides:
        return name
    readable = "--".join(f"{k}={v}" for k, v in overrides.items())
    if len(readable) <= _MAX_NAME and _PLAIN.match(readable):
        return f"{name}--{readable}"
    digest = hashlib.sha256(repr(sorted(overrides.items())).encode()).hexdigest()[:10]
    return f"{name}--{digest}"


def default_out_dir(name: str, overrides: dict[str, str], suffix: str = "", root: str | Path = "out") -> Path:
    """``out/<scene>[--<overrides>][<suffix>]`` (relative to the working directory)."""
    return Path(root) / f"{run_label(name, overrides)}{suffix}"


_FROM_ARGV = object()


def record(scene_file: str | Path | None, overrides: dict[str, str], settings: dict[str, Any],
           fmus: dict[str, Any] | None = None, command: list[str] | None = _FROM_ARGV) -> dict[str, Any]:
    """The provenance block written into stats.json. scene_file None: a scenario built in
    Python, from no file. command: the command line that asked for the run (default: this
    process's, as ``tribofmu ...``; None for a call from Python)."""
    if command is _FROM_ARGV:
        command = ["tribofmu", *sys.argv[1:]] if sys.argv and sys.argv[0] else []
    scene = {"file": None, "sha256": None}
    if scene_file is not None:
        scene_file = Path(scene_file)
        scene = {"file": str(scene_file.resolve()), "sha256": file_sha256(scene_file)}
    return {
        "scene": scene,
        "overrides": overrides,
        "settings": settings,
        "versions": versions(),
        "fmus": fmus or {},
        "command": command,
        "finished_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
