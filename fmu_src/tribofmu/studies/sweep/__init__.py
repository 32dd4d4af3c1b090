"""Parameter sweeps on Dask: the cartesian grid of ``--set`` overrides, one simulation per point.

    from tribofmu.studies.sweep import sweep
    rows = sweep("scenarios/fig2_dry.toml", {"drive.omega": [10, 20, 30, 50, 80, 130]}, "out/fig4")

Each grid point is independent: a worker simulates it and returns its metrics
(:mod:`tribofmu.metrics`) and its phase portrait, downsampled. The modules, in the
order a sweep uses them:

- :mod:`.grid`: parse ``--grid``, expand the points, validate each before any work;
- :mod:`.store`: the output directory (lock, ``sweep.csv`` appended as points finish and
  resumed from, ``sweep.json``, the portraits);
- :mod:`.runner`: a plain loop or a Dask cluster, longest points first;
- :mod:`.worker`: one point on a worker, with the FMUs sent through Dask;
- :mod:`.plots`: ``sweep.png`` or ``map_<metric>.png``, and ``portraits.png``.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, Callable

from ...errors import SweepError
from . import grid as _grid
from .grid import parse_grid
from .plots import plot_sweep
from .runner import run_dask, run_plain
from .store import WORKER_LOG_NAME, SweepStore
from .worker import PORTRAIT_POINTS, STATUS_OK

__all__ = ["sweep", "parse_grid", "SweepRows", "SweepError"]


class SweepRows(list):
    """The sweep's rows (dicts, in grid order) with what this call did.

    Each row: the swept keys (their values), ``status``, ``message``, the metrics (float,
    NaN when not defined) and ``wall_time``, ``finished_at``. Attributes: ``keys``,
    ``computed`` (points run by this call), ``skipped`` (already in sweep.csv), ``out_dir``,
    ``elapsed`` (s, the whole call).
    """

    keys: tuple[str, ...] = ()
    computed: int = 0
    skipped: int = 0
    out_dir: Path | None = None
    elapsed: float = 0.0

    @property
    def failed(self) -> int:
        return sum(1 for r in self if r["status"] != STATUS_OK)


def sweep(scenario_path: str | Path, grid: dict[str, list], out_dir: str | Path,
          scheduler: str | None = None, workers: int | None = None,
          overrides: dict[str, Any] | list[str] | None = None, algorithm: str | None = None,
          step: float | None = None, tol: float | None = None, fmu_dir: str | Path | None = None,
          retry_failed: bool = False, recompute: bool = False, timeout: float | None = None, plots: bool = True,
          progress: bool = True, portrait_points: int = PORTRAIT_POINTS,
          log: Callable[[str], None] | None = None) -> SweepRows:
    """Run the cartesian ``grid`` of overrides of a scenario; returns the rows in grid order.

    scheduler: address of an existing Dask scheduler; workers: None = a LocalCluster with one
    process per core, N = N processes, 0 = no Dask (a plain loop in this process).
    fmu_dir: use these FMUs (they must exist); default: the per-user cache of FMUs built from
    the installed source (checked, built when missing). sweep.json records the tribofmu
    version and the FMUs' source; a sweep in out_dir computed with other FMUs is refused
    (SweepError) unless recompute (every point is then run again).
    retry_failed: also rerun the points sweep.csv has as failed. timeout [s]: a point still
    running after it is stopped (at its next communication point) and reported failed.
    Raises SweepError (a ScenarioError) on a bad grid, setting or out_dir before any
    simulation runs, and when another sweep holds out_dir.
    """
    began = time.perf_counter()
    log = log or (lambda msg: print(msg, file=sys.stderr))
    if workers is not None and (not isinstance(workers, int) or workers < 0):
        raise SweepError(f"--workers must be an integer >= 0, got {workers!r}")
    if scheduler and workers is not None:
        raise SweepError("--workers and --scheduler exclude each other (the cluster has its workers)")
    if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0):
        raise SweepError(f"--timeout must be > 0 seconds, got {timeout!r}")
    plan = _grid.plan(scenario_path, grid, overrides, algorithm, step, tol)
    out_dir = Path(out_dir)
    plan.meta.update(fmu_record(plan, fmu_dir))
    with SweepStore(out_dir, plan).locked() as store:
        todo = store.resume(retry_failed, recompute)
        fmu_dir = _fmus_on_the_client(plan, fmu_dir, bool(todo))
        store.start()
        if len(todo) < len(plan.points):
            log(f"{store.csv_path}: {len(plan.points) - len(todo)} of {len(plan.points)} points already done; "
                f"running {len(todo)}")
        if todo:
            settings = (algorithm, step, tol, portrait_points, timeout)
            with store.appending():
                if workers == 0:
                    run_plain(plan.scenarios, todo, fmu_dir, settings, store.record, progress, plan.base.name)
                else:
                    run_dask(plan.scenarios, todo, fmu_dir, settings, store.record, progress, plan.base.name,
                             scheduler, workers, log, worker_log=out_dir / WORKER_LOG_NAME)
        store.write_sorted()
        store.publish()  # a recompute replaces the earlier sweep only now, every point done
        rows = SweepRows(store.rows())
        rows.keys, rows.computed, rows.skipped, rows.out_dir = (
            tuple(plan.keys), len(todo), len(plan.points) - len(todo), out_dir)
        portraits = store.write_portraits(rows)
        if plots:
            plot_sweep(rows, plan.keys, portraits, out_dir, plan.base)
    rows.elapsed = time.perf_counter() - began
    return rows


def _needed(plan: _grid.Plan) -> list[str]:
    return sorted({name for sc in plan.scenarios for name in sc.fmus})


def fmu_record(plan: _grid.Plan, fmu_dir) -> dict:
    """What sweep.json says about the software: the tribofmu version and the source the
    FMUs were built from (the private package name inside them, which carries the version
    and the hash of the shipped sources), known before any FMU is built."""
    from ... import __version__
    from ...build import private_package_name
    from ...fmu_cache import fmu_source
    if fmu_dir is None:
        source = private_package_name(2)
    else:
        found = {fmu_source(Path(fmu_dir) / f"{name}.fmu") for name in _needed(plan)}
        source = " ".join(sorted(str(f) for f in found))
    return {"tribofmu": __version__, "fmu_source": source}


def _fmus_on_the_client(plan: _grid.Plan, fmu_dir, needed_now: bool) -> Path | None:
    """The FMUs the points need: ``fmu_dir`` (must hold them) or the checked per-user cache."""
    from ...fmu_cache import find_fmus
    if not needed_now:
        return None
    return find_fmus(_needed(plan), fmu_dir, build=None if fmu_dir is None else False).resolve()
