"""Parameter sweeps on Dask: the cartesian grid of ``--set`` overrides, one simulation per point.

    from tribofmu.studies.sweep import sweep
    rows = sweep("scenarios/fig2_dry.toml", {"drive.omega": [10, 20, 30, 50, 80, 130]}, "out/fig4")

Each grid point is independent: a worker simulates it (``api.simulate(..., build=False)`` with
the FMUs the client built into ``out_dir/fmus``) and returns its metrics
(:mod:`tribofmu.studies.metrics`) and its phase portrait, downsampled. The client appends each row
to ``out_dir/sweep.csv`` as it arrives, so an interrupted sweep resumes: running it again
skips the points already there (matched on the swept values). At the end ``sweep.csv`` is
rewritten whole, in grid order, with ``portraits.npz`` and the pictures.

Where the work runs: ``workers=None`` starts a ``distributed.LocalCluster`` with one
single-threaded worker process per core (pythonfmu FMUs hold the GIL); ``workers=N``, N of
them; ``scheduler="tcp://host:8786"`` uses an existing cluster (its workers must have
tribofmu installed and see ``out_dir/fmus`` at the same path); ``workers=0`` runs the points
one after the other in this process, without Dask.

Files in ``out_dir``:

- ``sweep.csv``: the swept keys (one column each, named as the keys), ``status`` (ok /
  failed), ``message``, the metrics (:data:`tribofmu.studies.metrics.METRICS`; empty = not defined),
  ``wall_time`` (s spent simulating the point) and ``finished_at`` (local ISO time).
- ``sweep.json``: what was swept and with which settings (a resumed sweep must match it).
- ``portraits.npz``: ``labels`` and ``x``, ``v`` (points x PORTRAIT_POINTS, NaN when failed),
  the window's phase portraits resampled uniformly in time; ``points/`` holds them per point.
- 1-D sweep: ``sweep.png`` (metrics against the swept value), ``portraits.png`` (v(x) per
  point); 2-D sweep: ``map_<metric>.png`` (one heat map per metric) and ``portraits.png``.
"""
from __future__ import annotations

import contextlib
import csv
import datetime as _dt
import hashlib
import io
import itertools
import json
import logging
import math
import os
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from ..atomic import atomic_write_bytes
from ..scene.scenario import Scenario, ScenarioError, _split_assignment, load_scenario, to_dict
from .metrics import METRICS, result_metrics

PORTRAIT_POINTS = 400
STATUS_OK, STATUS_FAILED = "ok", "failed"
EXTRA_COLUMNS = ("wall_time", "finished_at")
CSV_NAME, META_NAME, PORTRAITS_NAME, POINTS_DIR = "sweep.csv", "sweep.json", "portraits.npz", "points"
LOCK_NAME = ".sweep.lock"
MAX_PORTRAIT_PANELS = 100
WORKER_START_TIMEOUT = 120.0  # s


class SweepError(ScenarioError):
    """A bad grid, setting or output directory, found before any work: one line, exit code 2."""


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


# -- the grid ------------------------------------------------------------------------------
def parse_grid(items: Iterable[str]) -> dict[str, list]:
    """``["drive.omega=10,20", "conditions.n=-10,-20"]`` -> ``{"drive.omega": [10, 20], ...}``.

    Values are read like ``--set`` values (TOML: numbers, true/false, ``[1, 2]`` arrays,
    otherwise a bare word); commas inside brackets or quotes do not split.
    """
    grid: dict[str, list] = {}
    for item in items:
        if "=" not in item:
            raise SweepError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        key, text = (s.strip() for s in item.split("=", 1))
        if not key:
            raise SweepError(f"--grid expects KEY=V1,V2,..., got {item!r}")
        if key in grid:
            raise SweepError(f"--grid {key} is given twice")
        parts = _split_values(text)
        if not parts or any(p == "" for p in parts):
            raise SweepError(f"--grid {key}: empty value in {text!r}")
        grid[key] = [_split_assignment(f"{key}={p}", "--grid")[1] for p in parts]
    return grid


def _split_values(text: str) -> list[str]:
    parts, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    parts.append("".join(cur).strip())
    return parts


def grid_points(grid: dict[str, list]) -> list[dict[str, Any]]:
    """The cartesian product in grid order: the first key varies slowest."""
    keys = list(grid)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]


def format_value(value: Any) -> str:
    """A swept value as written in sweep.csv; read back by :func:`parse_value`."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return str(value)


def parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _norm(value: Any) -> Any:
    """Values that are the same setting compare equal: 10 == 10.0, [1, 2] == [1.0, 2.0]."""
    if isinstance(value, bool):
        return ("b", value)
    if isinstance(value, (int, float)):
        return ("n", float(value))
    if isinstance(value, (list, tuple)):
        return ("l", tuple(_norm(v) for v in value))
    return ("s", str(value))


def point_key(point: dict[str, Any], keys: Iterable[str]) -> tuple:
    return tuple(_norm(point[k]) for k in keys)


def point_label(point: dict[str, Any]) -> str:
    return ", ".join(f"{k}={format_value(v)}" for k, v in point.items())


def point_id(point: dict[str, Any]) -> str:
    text = json.dumps([[k, repr(_norm(v))] for k, v in point.items()])
    return hashlib.sha1(text.encode()).hexdigest()[:16]


# -- one point (runs on a worker) ---------------------------------------------------------
class PointTimeout(Exception):
    """A point ran longer than the sweep's per-point time limit."""


def run_point(scenario: Scenario, fmu_dir: str, algorithm: str | None = None, step: float | None = None,
              tol: float | None = None, portrait_points: int = PORTRAIT_POINTS,
              timeout: float | None = None) -> dict[str, Any]:
    """Simulate one grid point; never raises: a failure is ``status = failed`` with a message.

    Returns status, message, metrics (dict), wall_time, and the window's x, v resampled at
    ``portrait_points`` uniform times (None when failed). timeout [s]: stop the run at the
    first communication point past it (the master's progress callback), a failed point.
    """
    from .. import api

    start = time.perf_counter()
    progress = None
    if timeout is not None:
        def progress(status) -> None:
            if time.perf_counter() - start > timeout:
                raise PointTimeout(f"stopped after {timeout:g} s, {status.fraction:.0%} of the span done")
    out: dict[str, Any] = {"status": STATUS_FAILED, "message": "", "metrics": {}, "x": None, "v": None,
                           "pid": os.getpid()}
    path_before = list(sys.path)
    try:
        result = api.simulate(scenario, algorithm=algorithm, step=step, tol=tol, fmu_dir=fmu_dir,
                              build=False, progress=progress)
        if not result.ok:
            out["message"] = result.message
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
        _drop_extracted_fmus(path_before)
    out["message"] = " ".join(str(out["message"]).split())
    out["wall_time"] = time.perf_counter() - start
    return out


def _extracted_fmu(entry: str) -> Path | None:
    """The unzipped FMU whose ``resources`` folder this sys.path entry is, if it is one."""
    path = Path(entry)
    if path.name == "resources" and (path.parent / "modelDescription.xml").is_file():
        return path.parent
    return None


def _drop_extracted_fmus(path_before: list[str]) -> None:
    """Undo what loading the FMUs leaves behind in this process, once they are freed.

    pythonfmu puts each instance's ``<unzipped FMU>/resources`` on sys.path and nothing
    removes it, nor the unzipped FMU (~0.7 MB) in the temp dir: 3 entries and ~2 MB per
    point, which a long-lived worker would pile up (and a process spawned from it would
    import the FMU's stripped copy of tribofmu first). Only entries added during this
    point's simulation, inside the temp dir, are touched.
    """
    import shutil
    import tempfile

    before = set(path_before)
    tmp = Path(tempfile.gettempdir()).resolve()
    for entry in [e for e in sys.path if e not in before]:
        unzipped = _extracted_fmu(entry)
        if unzipped is None:
            continue
        while entry in sys.path:
            sys.path.remove(entry)
        if tmp in unzipped.resolve().parents:
            shutil.rmtree(unzipped, ignore_errors=True)


class _CleanSysPath:
    """While a LocalCluster runs: no unzipped FMU's ``resources`` on sys.path.

    Worker processes are spawned with the parent's sys.path; an FMU loaded earlier in this
    process (``api.simulate``) leaves its resources folder there, whose ``tribofmu`` (the
    FMU's copy, without ``api``) would shadow the installed package in the workers.
    """

    def __enter__(self):
        self.saved = list(sys.path)
        sys.path[:] = [e for e in sys.path if _extracted_fmu(e) is None]
        return self

    def __exit__(self, *exc):
        added = [e for e in sys.path if e not in self.saved]
        sys.path[:] = self.saved + added


# -- sweep.csv ---------------------------------------------------------------------------
def _columns(keys: Iterable[str]) -> list[str]:
    return [*keys, "status", "message", *METRICS, *EXTRA_COLUMNS]


def _fmt_float(x: Any) -> str:
    if x is None:
        return ""
    x = float(x)
    return "" if math.isnan(x) else format(x, ".10g")


def _csv_line(row: dict[str, Any], keys: Iterable[str]) -> str:
    cells = [format_value(row[k]) for k in keys] + [row["status"], row["message"]]
    cells += [_fmt_float(row.get(m)) for m in METRICS]
    cells += [_fmt_float(row.get("wall_time")), row.get("finished_at", "")]
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(cells)
    return buf.getvalue()


def _csv_text(rows: Iterable[dict[str, Any]], keys: Iterable[str]) -> str:
    keys = list(keys)
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(_columns(keys))
    return buf.getvalue() + "".join(_csv_line(r, keys) for r in rows)


def read_sweep_csv(path: Path, keys: list[str]) -> list[dict[str, Any]]:
    """The complete rows of an existing sweep.csv (a torn last line is dropped).

    Raises SweepError when its columns are not this sweep's.
    """
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            return []
        expected = _columns(keys)
        if header != expected:
            raise SweepError(f"{path} holds another sweep (columns {','.join(header[:len(keys) + 2])}...,"
                             f" this one needs {','.join(expected[:len(keys) + 2])}...); "
                             f"use another --out or remove it")
        rows = []
        for cells in reader:
            if len(cells) != len(expected) or cells[len(keys)] not in (STATUS_OK, STATUS_FAILED):
                continue
            row: dict[str, Any] = {k: parse_value(c) for k, c in zip(keys, cells)}
            row["status"], row["message"] = cells[len(keys)], cells[len(keys) + 1]
            try:
                for name, cell in zip((*METRICS, "wall_time"), cells[len(keys) + 2:]):
                    row[name] = float(cell) if cell else math.nan
            except ValueError:
                continue
            row["finished_at"] = cells[-1]
            rows.append(row)
    return rows


# -- the sweep ---------------------------------------------------------------------------
@dataclass
class _Plan:
    keys: list[str]
    points: list[dict[str, Any]]
    scenarios: list[Scenario]
    base: Scenario
    meta: dict[str, Any]


def _plan(scenario_path, grid: dict[str, list], overrides, algorithm, step, tol) -> _Plan:
    """Validate everything on the client: every grid point's scenario, the coupling settings."""
    if not grid:
        raise SweepError("nothing to sweep: give at least one --grid KEY=V1,V2,...")
    keys = list(grid)
    for key, values in grid.items():
        if not isinstance(values, (list, tuple)) or not values:
            raise SweepError(f"--grid {key} needs at least one value, got {values!r}")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(_split_assignment(item, "--set") for item in overrides)
    overrides = dict(overrides or {})
    both = [k for k in keys if k in overrides]
    if both:
        raise SweepError(f"{both[0]} is both swept (--grid) and set (--set)")
    base = load_scenario(scenario_path, overrides)
    for key, values in grid.items():  # each value alone first: the message names it
        for value in values:
            try:
                base.with_overrides({key: value})
            except ScenarioError as exc:
                raise SweepError(f"--grid {key}={format_value(value)}: {exc}") from None
        if len({_norm(v) for v in values}) != len(values):
            raise SweepError(f"--grid {key} repeats a value: {', '.join(map(format_value, values))}")
    points = grid_points(grid)
    scenarios = []
    for point in points:
        try:
            scenarios.append(base.with_overrides(point))
        except ScenarioError as exc:
            raise SweepError(f"--grid point {point_label(point)}: {exc}") from None
    from ..master import make_algorithm
    for value, name in ((step, "step"), (tol, "tol")):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise SweepError(f"--{name} must be > 0, got {value}")
    for sc in {(s.simulation.algorithm, s.simulation.step, s.simulation.tol) for s in scenarios}:
        name = algorithm or sc[0]
        try:
            make_algorithm(name, step=step if step is not None else sc[1], tol=tol if tol is not None else sc[2])
        except ValueError as exc:
            raise SweepError(f"--algorithm: {exc}") from None
    meta = {"scenario": str(scenario_path), "base": _fingerprint(base, keys), "overrides":
            {k: format_value(v) for k, v in overrides.items()}, "algorithm": algorithm, "step": step,
            "tol": tol, "keys": keys, "grid": {k: [format_value(v) for v in vs] for k, vs in grid.items()}}
    return _Plan(keys, points, scenarios, base, meta)


def _fingerprint(base: Scenario, keys: list[str]) -> str:
    data = to_dict(base)
    for key in keys:  # the swept values are per point, not part of the base
        table, _, name = key.partition(".")
        data.get(table, {}).pop(name, None)
    data.get("scenario", {}).pop("title", None)
    return hashlib.sha1(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()[:16]


def _check_meta(path: Path, meta: dict[str, Any]) -> None:
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    for field, what in (("keys", "swept keys"), ("base", "scenario (file and --set values)"),
                        ("algorithm", "--algorithm"), ("step", "--step"), ("tol", "--tol")):
        if old.get(field) != meta.get(field):
            raise SweepError(f"{path.parent}/ holds a sweep with other {what} ({old.get(field)!r}, now "
                             f"{meta.get(field)!r}); use another --out or remove it")


def sweep(scenario_path: str | Path, grid: dict[str, list], out_dir: str | Path,
          scheduler: str | None = None, workers: int | None = None,
          overrides: dict[str, Any] | list[str] | None = None, algorithm: str | None = None,
          step: float | None = None, tol: float | None = None, fmu_dir: str | Path | None = None,
          retry_failed: bool = False, timeout: float | None = None, plots: bool = True,
          progress: bool = True, portrait_points: int = PORTRAIT_POINTS,
          log: Callable[[str], None] | None = None) -> SweepRows:
    """Run the cartesian ``grid`` of overrides of a scenario; returns the rows in grid order.

    scheduler: address of an existing Dask scheduler; workers: None = a LocalCluster with one
    process per core, N = N processes, 0 = no Dask (a plain loop in this process).
    fmu_dir: use these FMUs (they must exist); default ``out_dir/fmus``, built when missing.
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
    plan = _plan(scenario_path, grid, overrides, algorithm, step, tol)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with _locked(out_dir):
        rows = _sweep_locked(plan, out_dir, scheduler, workers, algorithm, step, tol, fmu_dir, retry_failed,
                             timeout, plots, progress, portrait_points, log)
    rows.elapsed = time.perf_counter() - began
    return rows


@contextlib.contextmanager
def _locked(out_dir: Path):
    """One sweep at a time in a directory (two would run the same points and interleave rows)."""
    import fcntl
    with open(out_dir / LOCK_NAME, "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SweepError(f"another sweep is running in {out_dir}/ (it holds {LOCK_NAME})") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _sweep_locked(plan, out_dir, scheduler, workers, algorithm, step, tol, fmu_dir, retry_failed, timeout,
                  plots, progress, portrait_points, log) -> SweepRows:
    keys = plan.keys
    csv_path, meta_path = out_dir / CSV_NAME, out_dir / META_NAME

    # resume: what is done already
    previous = read_sweep_csv(csv_path, keys) if csv_path.is_file() else []
    if previous and meta_path.is_file():
        _check_meta(meta_path, plan.meta)
    done: dict[tuple, dict[str, Any]] = {}
    for row in previous:
        if retry_failed and row["status"] != STATUS_OK:
            continue
        done[point_key(row, keys)] = row
    todo = [i for i, p in enumerate(plan.points) if point_key(p, keys) not in done]

    # the FMUs, on the client, before any work
    from .. import api
    needed = sorted({name for sc in plan.scenarios for name in sc.fmus})
    if fmu_dir is None:
        fmu_dir = out_dir / "fmus"
        if todo:
            api.ensure_fmus(fmu_dir, needed, build=None)
    elif todo:
        api.ensure_fmus(Path(fmu_dir), needed, build=False)
    fmu_dir = str(Path(fmu_dir).resolve())

    atomic_write_bytes(meta_path, (json.dumps(plan.meta, indent=2) + "\n").encode())
    grid_keys = {point_key(p, keys) for p in plan.points}
    _write_sorted(csv_path, plan, done, keys, grid_keys)  # also drops a torn last line
    (out_dir / POINTS_DIR).mkdir(exist_ok=True)
    if len(todo) < len(plan.points):
        log(f"{csv_path}: {len(plan.points) - len(todo)} of {len(plan.points)} points already done; "
            f"running {len(todo)}")

    def record(i: int, out: dict[str, Any], fh) -> None:
        point = plan.points[i]
        row = {**point, "status": out["status"], "message": out["message"],
               **{m: out["metrics"].get(m, math.nan) for m in METRICS},
               "wall_time": out.get("wall_time", math.nan),
               "finished_at": _dt.datetime.now().isoformat(timespec="microseconds")}
        if out.get("x") is not None:
            buf = io.BytesIO()
            np.savez(buf, x=out["x"], v=out["v"])
            atomic_write_bytes(out_dir / POINTS_DIR / f"{point_id(point)}.npz", buf.getvalue())
        fh.write(_csv_line(row, keys))
        fh.flush()
        os.fsync(fh.fileno())
        done[point_key(point, keys)] = row

    if todo:
        args = (fmu_dir, algorithm, step, tol, portrait_points, timeout)
        with open(csv_path, "a", encoding="utf-8", newline="") as fh:
            if workers == 0:
                _run_plain(plan, todo, args, lambda i, out: record(i, out, fh), progress)
            else:
                _run_dask(plan, todo, args, lambda i, out: record(i, out, fh), progress, scheduler,
                          workers, log)

    _write_sorted(csv_path, plan, done, keys, grid_keys)
    rows = SweepRows(done[point_key(p, keys)] for p in plan.points)
    rows.keys, rows.computed, rows.skipped, rows.out_dir = tuple(keys), len(todo), len(plan.points) - len(todo), out_dir
    portraits = _write_portraits(out_dir, plan, rows)
    if plots:
        plot_sweep(rows, keys, portraits, out_dir, plan.base)
    return rows


def _write_sorted(csv_path: Path, plan: _Plan, done: dict, keys: list[str], grid_keys: set) -> None:
    """sweep.csv whole, atomically: the grid's rows in grid order, then rows of other grids."""
    ordered = [done[k] for k in (point_key(p, keys) for p in plan.points) if k in done]
    ordered += [r for k, r in done.items() if k not in grid_keys]
    atomic_write_bytes(csv_path, _csv_text(ordered, keys).encode("utf-8"))


def _progress_bar(total: int, enabled: bool, desc: str):
    from tqdm import tqdm
    return tqdm(total=total, unit="point", desc=desc, disable=not enabled, file=sys.stderr,
                dynamic_ncols=True)


def _run_plain(plan: _Plan, todo: list[int], args: tuple, record, progress: bool) -> None:
    with _progress_bar(len(todo), progress, plan.base.name) as bar:
        failed = 0
        for i in todo:
            out = run_point(plan.scenarios[i], *args)
            record(i, out)
            failed += out["status"] != STATUS_OK
            bar.set_postfix(failed=failed, refresh=False)
            bar.update()


def _run_dask(plan: _Plan, todo: list[int], args: tuple, record, progress: bool,
              scheduler: str | None, workers: int | None, log) -> None:
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    clean = _CleanSysPath().__enter__()
    try:
        if scheduler:
            client = Client(scheduler)
        else:
            n = workers or _cores()
            n = max(1, min(n, len(todo)))
            log(f"starting a local Dask cluster: {n} worker process{'es' if n > 1 else ''}, 1 thread each")
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   scheduler_kwargs={"dashboard_address": ":0"},  # no clash on :8787
                                   silence_logs=logging.ERROR)
            client = Client(cluster)
            try:  # a worker that cannot start (import error) would otherwise leave us waiting forever
                client.wait_for_workers(n, timeout=WORKER_START_TIMEOUT)
            except TimeoutError:
                client.close()
                cluster.close()
                raise SweepError(f"the local Dask cluster's {n} workers did not start within "
                                 f"{WORKER_START_TIMEOUT:g} s") from None
    except BaseException:
        clean.__exit__(None, None, None)
        raise
    futures = {}
    try:
        token = hashlib.sha1(f"{time.time()}{os.getpid()}".encode()).hexdigest()[:8]
        for i in todo:
            fut = client.submit(run_point, plan.scenarios[i], *args, key=f"tribofmu-point-{i}-{token}",
                                pure=False, retries=0)
            futures[fut] = i
        with _progress_bar(len(todo), progress, plan.base.name) as bar:
            failed = 0
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    out = fut.result()
                except Exception as exc:  # the worker died, the task could not be run
                    out = {"status": STATUS_FAILED, "message": " ".join(f"{type(exc).__name__}: {exc}".split()),
                           "metrics": {}, "wall_time": math.nan}
                record(i, out)
                failed += out["status"] != STATUS_OK
                bar.set_postfix(failed=failed, refresh=False)
                bar.update()
                fut.release()
    finally:
        for fut in futures:
            if not fut.done():
                fut.cancel()
        client.close()
        if cluster is not None:
            cluster.close()
        clean.__exit__(None, None, None)


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


# -- portraits and pictures ------------------------------------------------------------
def _write_portraits(out_dir: Path, plan: _Plan, rows: SweepRows) -> dict[str, np.ndarray]:
    n = None
    xs, vs = [], []
    for point, row in zip(plan.points, rows):
        data = None
        path = out_dir / POINTS_DIR / f"{point_id(point)}.npz"
        if row["status"] == STATUS_OK and path.is_file():
            with np.load(path) as z:
                data = (z["x"], z["v"])
            n = n or len(data[0])
        xs.append(data[0] if data else None)
        vs.append(data[1] if data else None)
    n = n or PORTRAIT_POINTS
    nan = np.full(n, np.nan)
    portraits = {"labels": np.array([point_label(p) for p in plan.points]),
                 "status": np.array([r["status"] for r in rows]),
                 "x": np.array([x if x is not None and len(x) == n else nan for x in xs]),
                 "v": np.array([v if v is not None and len(v) == n else nan for v in vs])}
    for key in plan.keys:
        values = [p[key] for p in plan.points]
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        portraits[f"grid:{key}"] = np.array(values, dtype=float) if numeric else np.array(
            [format_value(v) for v in values])
    buf = io.BytesIO()
    np.savez(buf, **portraits)
    atomic_write_bytes(out_dir / PORTRAITS_NAME, buf.getvalue())
    return portraits


METRIC_LABELS = {"stick_fraction": "stick fraction", "stick_episodes_per_period": "stick episodes / period",
                 "harmonics": "harmonics of x", "amplitude_ratio": "max|x| / A",
                 "dissipated_per_cycle": "dissipated per cycle [J]", "melt_fraction": "melt fraction"}


def _numeric(values: list) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def plot_sweep(rows: SweepRows, keys: list[str], portraits: dict[str, np.ndarray], out_dir: Path,
               base: Scenario | None = None) -> list[Path]:
    """sweep.png + portraits.png (1-D) or map_<metric>.png + portraits.png (2-D); returns paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    paths: list[Path] = []
    title = base.name if base is not None else ""  # its title names the values being swept
    metrics = [m for m in METRICS if any(np.isfinite(r[m]) for r in rows)]
    if len(keys) == 1:
        key = keys[0]
        values = [r[key] for r in rows]
        numeric = _numeric(values)
        pos = np.array(values, dtype=float) if numeric else np.arange(len(values), dtype=float)
        ncols = 3
        nrows = max(1, math.ceil(len(metrics) / ncols))
        fig, axes = plt.subplots(nrows, ncols, figsize=(4 * ncols, 2.8 * nrows), squeeze=False)
        failed = np.array([r["status"] != STATUS_OK for r in rows])
        for ax, m in zip(axes.flat, metrics):
            y = np.array([r[m] for r in rows], dtype=float)
            ax.plot(pos, y, "o-", color="C0")
            for p in pos[failed]:
                ax.axvline(p, color="C3", ls=":", lw=1)
            ax.set_ylabel(METRIC_LABELS.get(m, m))
            ax.set_xlabel(key)
            if numeric and len(pos) > 2 and pos.min() > 0 and pos.max() / pos.min() >= 20:
                ax.set_xscale("log")
            if not numeric:
                ax.set_xticks(pos, [format_value(v) for v in values], rotation=30)
            ax.grid(alpha=0.3)
        for ax in list(axes.flat)[len(metrics):]:
            ax.axis("off")
        fig.suptitle(f"{title}: sweep over {key}" + (" (dotted: failed)" if failed.any() else ""), fontsize=10)
        fig.tight_layout()
        paths.append(out_dir / "sweep.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
        shape = (1, len(rows))
    elif len(keys) == 2:
        n0, n1 = len({_norm(r[keys[0]]) for r in rows}), len({_norm(r[keys[1]]) for r in rows})
        shape = (n0, n1)
        v0 = [rows[i * n1][keys[0]] for i in range(n0)]
        v1 = [rows[j][keys[1]] for j in range(n1)]
        for m in metrics:
            z = np.array([r[m] for r in rows], dtype=float).reshape(n0, n1).T  # y: key 1, x: key 0
            fig, ax = plt.subplots(figsize=(1.0 + 0.75 * max(n0, 4), 1.0 + 0.6 * max(n1, 4)))
            cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")
            im = ax.imshow(np.ma.masked_invalid(z), origin="lower", aspect="auto", cmap=cmap)
            ax.set_xticks(range(n0), [format_value(v) for v in v0], rotation=30)
            ax.set_yticks(range(n1), [format_value(v) for v in v1])
            ax.set_xlabel(keys[0])
            ax.set_ylabel(keys[1])
            if n0 * n1 <= 225:
                finite = z[np.isfinite(z)]
                mid = (finite.min() + finite.max()) / 2 if finite.size else 0
                for j in range(n1):
                    for i in range(n0):
                        text = "failed" if not np.isfinite(z[j, i]) else format(z[j, i], ".3g")
                        ax.text(i, j, text, ha="center", va="center", fontsize=7,
                                color="black" if not np.isfinite(z[j, i]) or z[j, i] > mid else "white")
            fig.colorbar(im, ax=ax, label=METRIC_LABELS.get(m, m))
            ax.set_title(f"{title}\n{METRIC_LABELS.get(m, m)}", fontsize=9)
            fig.tight_layout()
            paths.append(out_dir / f"map_{m}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
    else:
        return paths
    if len(rows) <= MAX_PORTRAIT_PANELS:
        paths.append(_plot_portraits(rows, keys, portraits, shape, out_dir / "portraits.png", title, plt))
    return paths


def _plot_portraits(rows, keys, portraits, shape, path: Path, title: str, plt) -> Path:
    n0, n1 = shape
    if len(keys) == 1:  # one row of panels, wrapped at 6
        ncols = min(6, len(rows))
        nrows = math.ceil(len(rows) / ncols)
        cells = [(i // ncols, i % ncols) for i in range(len(rows))]
    else:  # a grid: columns key 0, rows key 1 (top row: its largest value)
        ncols, nrows = n0, n1
        cells = [(n1 - 1 - (k % n1), k // n1) for k in range(len(rows))]
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.5 * ncols, 2.4 * nrows + 0.6), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    short = {k: k.split(".")[-1] for k in keys}
    for k, (row, (r, c)) in enumerate(zip(rows, cells)):
        ax = axes[r, c]
        ax.axis("on")
        label = ", ".join(f"{short[key]}={format_value(row[key])}" for key in keys)
        x, v = portraits["x"][k], portraits["v"][k]
        if row["status"] == STATUS_OK and np.isfinite(x).all():
            ax.plot(x * 1e3, v, lw=0.9, color="C0")
        else:
            ax.text(0.5, 0.5, "failed", ha="center", va="center", color="C3", transform=ax.transAxes)
        ax.set_title(label, fontsize=8)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
    fig.supxlabel("x [mm]", fontsize=8)
    fig.supylabel("v [m/s]", fontsize=8)
    fig.suptitle(f"{title}: phase portraits v(x) on the window", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
