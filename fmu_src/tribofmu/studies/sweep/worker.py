"""What runs on a worker: one grid point simulated into its metrics and phase portrait.

The FMUs reach a worker through Dask, not through a shared path: the client packs the
built FMUs' bytes (:func:`pack_fmus`), Dask moves that bundle to each worker once, and
:func:`unpack_fmus` writes it into the worker's own private folder (once per worker and bundle,
checked by its content hash). A worker therefore needs tribofmu installed, not the client's disk.
"""
from __future__ import annotations

import hashlib
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import PointTimeout, TriboFMUError  # noqa: F401 (PointTimeout re-exported)
from ...master.unzipped import forget_fmus_loaded_since
from ...scene.scenario import Scenario
from ...metrics import result_metrics

PORTRAIT_POINTS = 400
STATUS_OK, STATUS_FAILED = "ok", "failed"


def run_point(scenario: Scenario, fmu_dir: str, algorithm: str | None = None, step: float | None = None,
              tol: float | None = None, portrait_points: int = PORTRAIT_POINTS,
              timeout: float | None = None) -> dict[str, Any]:
    """Simulate one grid point; never raises: a failure is ``status = failed`` with a message.

    Returns status, message, metrics (dict), wall_time, and the window's x, v resampled at
    ``portrait_points`` uniform times (None when failed). timeout [s]: stop the run at the
    first communication point past it (the master's progress callback), a failed point.
    """
    from ... import api

    from ...progress import check_interrupt, deferred_interrupts

    start = time.perf_counter()

    def progress(status) -> None:  # between steps, outside FMU code: where a stop is safe
        check_interrupt()
        if timeout is not None and time.perf_counter() - start > timeout:
            raise PointTimeout(f"stopped after {timeout:g} s, {status.fraction:.0%} of the span done")
    out: dict[str, Any] = {"status": STATUS_FAILED, "message": "", "metrics": {}, "x": None, "v": None,
                           "pid": os.getpid()}
    path_before = list(sys.path)
    try:
        # a Ctrl-C inside FMU code would become fmi2Fatal and read as a failed point
        with deferred_interrupts():
            # one run at a time: the sweep's points already keep the cores busy
            result = api.simulate(scenario, algorithm=algorithm, step=step, tol=tol, fmu_dir=fmu_dir,
                                  build=False, progress=progress, check_workers=1)
        if not result.ok:  # failed, or completed short of its tolerance: the point is not met
            out["message"] = result.message
            if result.stats.get("completed"):  # its metrics are still worth a look
                out["metrics"] = result_metrics(result)
        else:
            out["metrics"] = result_metrics(result)
            m = result.window_mask()
            t = result.time[m]
            grid = np.linspace(t[0], t[-1], portrait_points)
            out["x"] = np.interp(grid, t, result.x[m])
            out["v"] = np.interp(grid, t, result.v[m])
            out["status"], out["message"] = STATUS_OK, result.message
    except Exception as exc:  # a point's failure is data, never the sweep's end
        out["message"] = f"{type(exc).__name__}: {exc}"
    finally:
        # An FMU whose instantiation failed is never closed: its unzipped copy and sys.path
        # entry would pile up in a long-lived worker (~2 MB and 3 entries per point).
        forget_fmus_loaded_since(path_before)
    out["message"] = " ".join(str(out["message"]).split())
    out["wall_time"] = time.perf_counter() - start
    return out


def pack_fmus(fmu_dir: Path, names) -> dict[str, bytes]:
    """The built FMUs ``<fmu_dir>/<name>.fmu`` as ``{file name: bytes}``, to send to workers."""
    return {f"{name}.fmu": (Path(fmu_dir) / f"{name}.fmu").read_bytes() for name in sorted(names)}


def unpack_fmus(fmus: dict[str, bytes]) -> str:
    """Write a bundle from :func:`pack_fmus` into this process's private folder of unzipped
    FMUs (mode 0700, removed at exit; :func:`~tribofmu.master.fmu_files.extraction_root`),
    once per bundle; returns the folder. Files already there are used only when their
    content hash is the bundle's (nothing is trusted for its name, no link followed)."""
    from ...fmu_cache import sha256_file
    from ...master.fmu_files import extraction_root
    hashes = {name: hashlib.sha256(data).hexdigest() for name, data in fmus.items()}
    digest = hashlib.sha256("".join(f"{n}\0{hashes[n]}\0" for n in sorted(hashes)).encode())
    target = extraction_root() / f"bundle-{digest.hexdigest()[:16]}"
    target.mkdir(mode=0o700, exist_ok=True)
    for name, data in fmus.items():
        path = target / name
        try:
            if sha256_file(path) == hashes[name]:
                continue
        except OSError:  # not there (or not a regular file): write it
            pass
        if path.is_symlink() or path.exists():
            path.unlink()
        partial = target / f".{name}.partial"
        partial.write_bytes(data)
        os.replace(partial, path)
    return str(target)


def run_shipped_point(scenario: Scenario, fmus: dict[str, bytes], *args, **kwargs) -> dict[str, Any]:
    """:func:`run_point` with the FMUs given as a bundle from :func:`pack_fmus` (the Dask task)."""
    return run_point(scenario, unpack_fmus(fmus), *args, **kwargs)
