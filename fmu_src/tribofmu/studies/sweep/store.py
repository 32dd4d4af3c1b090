"""The sweep's files in its output directory, as one small store object (:class:`SweepStore`).

- ``sweep.csv``: the swept keys (one column each, named as the keys), ``status`` (ok /
  failed), ``message``, the metrics (:data:`tribofmu.metrics.METRICS`; empty = not
  defined), ``wall_time`` (s spent simulating the point) and ``finished_at`` (ISO time in UTC,
  with its zone, as stats.json's).
- ``columns.json``: each column of sweep.csv with its unit and meaning (as ``simulate``'s
  columns.json beside result.csv).
  A row is appended (and fsynced) as each point finishes, so an interrupted sweep resumes:
  the rows already there are skipped. At the start and the end the file is rewritten whole,
  in grid order.
- ``sweep.json``: what was swept and with which settings, the tribofmu version and the
  source the FMUs were built from (a resumed sweep must match it all).
- ``points/<id>.npz`` and ``portraits.npz``: the window's phase portraits, per point and all
  together (``labels``, ``status``, ``x``, ``v``: points x portrait points, NaN when failed;
  ``grid:<key>``: the swept values).
- ``.sweep.lock``: held while a sweep runs, so two sweeps never share a directory.
- ``.dask.log``: on a local Dask cluster, what its workers and Dask itself printed (kept
  only when not empty; the terminal shows tribofmu's own lines).
- ``.recompute/``: a ``--recompute`` of a directory holding a sweep is built here (its own
  sweep.csv, sweep.json and points/) and replaces the earlier sweep only when every point is
  done, so an interrupted recompute leaves the earlier sweep whole; rerunning the same
  command resumes it (its rows were computed with the same FMUs).
"""
from __future__ import annotations

import contextlib
import csv
import datetime as _dt
import io
import json
import math
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ...atomic import atomic_write_bytes
from ...errors import SweepError
from ...metrics import METRICS
from .grid import Plan, format_value, is_numeric, parse_value, point_id, point_key, point_label
from .worker import PORTRAIT_POINTS, STATUS_FAILED, STATUS_OK

EXTRA_COLUMNS = ("wall_time", "finished_at")
CSV_NAME, META_NAME, PORTRAITS_NAME, POINTS_DIR = "sweep.csv", "sweep.json", "portraits.npz", "points"
SIDECAR_NAME = "columns.json"
# sweep.csv's columns after the swept keys: (unit, meaning); the metrics' definitions are
# tribofmu.metrics' (docs/studies.md, Metrics)
COLUMN_MEANINGS = {
    "status": ("", "ok, or failed (its message says why)"),
    "message": ("", "the run's message"),
    "stick_fraction": ("1", "share of the window's time the blocks are stuck together"),
    "stick_episodes_per_period": ("1/period", "stuck runs per drive period"),
    "creep_fraction": ("1", "share of the window's time with |V - v| < 0.05 A w (fluid, boundary)"),
    "creep_episodes_per_period": ("1/period", "creeping runs per drive period (fluid, boundary)"),
    "harmonics": ("1", "harmonics of x above 1 % of the largest"),
    "amplitude_ratio": ("1", "max|x| / A"),
    "dissipated_per_cycle": ("J", "friction work over the window per drive period"),
    "melt_fraction": ("1", "share of the window's time the lubricant is molten (boundary)"),
    "wall_time": ("s", "wall time spent simulating the point"),
    "finished_at": ("", "when the point finished: ISO 8601 time in UTC, with its zone"),
}
LOCK_NAME = ".sweep.lock"
STAGING_NAME = ".recompute"
WORKER_LOG_NAME = ".dask.log"  # a local cluster's workers' and Dask's messages, if any


class SweepStore:
    """The files of one sweep in ``out_dir``: what is done, recording points, the portraits.

    ``done`` maps :func:`~.grid.point_key` to the row of every point finished (here or in an
    earlier run of the same sweep)."""

    def __init__(self, out_dir: Path, plan: Plan):
        self.out_dir, self.plan, self.keys = Path(out_dir), plan, plan.keys
        self.work_dir = self.out_dir  # where this run writes: out_dir, or the recompute's staging
        self.csv_path, self.meta_path = self.out_dir / CSV_NAME, self.out_dir / META_NAME
        self.staged = False
        self.done: dict[tuple, dict[str, Any]] = {}
        self._grid_keys = {point_key(p, self.keys) for p in plan.points}
        self._fh = None

    @contextlib.contextmanager
    def locked(self):
        """One sweep at a time in a directory (two would run the same points and interleave rows)."""
        import fcntl
        self.out_dir.mkdir(parents=True, exist_ok=True)
        with open(self.out_dir / LOCK_NAME, "w") as fh:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise SweepError(f"another sweep is running in {self.out_dir}/ (it holds {LOCK_NAME})") from None
            try:
                yield self
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    def resume(self, retry_failed: bool, recompute: bool = False) -> list[int]:
        """Read what earlier runs finished; returns the indices of the points still to run.

        Raises SweepError when the directory holds another sweep, or one computed with other
        FMUs (unless recompute: then every point runs again and the old rows are dropped)."""
        previous = read_sweep_csv(self.csv_path, self.keys) if self.csv_path.is_file() else []
        staging = self.out_dir / STAGING_NAME
        if previous:
            _check_meta(self.meta_path, self.plan.meta)
            if not recompute:
                _check_fmus(self.meta_path, self.plan.meta)
            else:  # built beside the earlier sweep, which stays whole until this one is
                previous = self._stage(staging)
        elif staging.exists():  # a recompute's leftovers, with no earlier sweep to keep
            _remove_tree(staging)
        for row in previous:
            if retry_failed and row["status"] != STATUS_OK:
                continue
            self.done[point_key(row, self.keys)] = row
        return [i for i, p in enumerate(self.plan.points) if point_key(p, self.keys) not in self.done]

    def _stage(self, staging: Path) -> list[dict[str, Any]]:
        """Work in ``staging`` from now on; returns the rows an interrupted recompute of this
        same sweep, with these FMUs, left there (none when it is another's: it is dropped)."""
        rows = []
        csv_path, meta_path = staging / CSV_NAME, staging / META_NAME
        if csv_path.is_file():
            try:
                _check_meta(meta_path, self.plan.meta)
                _check_fmus(meta_path, self.plan.meta)
                if not _read_meta(meta_path):
                    raise SweepError("no sweep.json")
                rows = read_sweep_csv(csv_path, self.keys)
            except SweepError:
                rows = []
        if not rows and staging.exists():
            _remove_tree(staging)
        staging.mkdir(exist_ok=True)
        self.work_dir, self.csv_path, self.meta_path, self.staged = staging, csv_path, meta_path, True
        return rows

    def start(self) -> None:
        """Write sweep.json and sweep.csv whole (dropping a torn last line); ready to record."""
        atomic_write_bytes(self.meta_path, (json.dumps(self.plan.meta, indent=2) + "\n").encode())
        atomic_write_bytes(self.work_dir / SIDECAR_NAME, (json.dumps(sidecar(self.keys), indent=2) + "\n").encode())
        self.write_sorted()
        (self.work_dir / POINTS_DIR).mkdir(exist_ok=True)

    def publish(self) -> None:
        """A recompute, every point done: its files replace the earlier sweep's. points/ first
        (the old one set aside, then removed), sweep.json, and sweep.csv last (one rename), so
        a reader of sweep.csv sees the earlier table or the new one, whole."""
        if not self.staged:
            return
        staging, final_points = self.work_dir, self.out_dir / POINTS_DIR
        old_points = self.out_dir / f".{POINTS_DIR}.old"
        if old_points.exists():
            _remove_tree(old_points)
        if final_points.exists():
            os.replace(final_points, old_points)
        os.replace(staging / POINTS_DIR, final_points)
        os.replace(staging / META_NAME, self.out_dir / META_NAME)
        os.replace(staging / SIDECAR_NAME, self.out_dir / SIDECAR_NAME)
        os.replace(staging / CSV_NAME, self.out_dir / CSV_NAME)
        _fsync_dir(self.out_dir)
        _remove_tree(old_points)
        _remove_tree(staging)
        self.work_dir, self.staged = self.out_dir, False
        self.csv_path, self.meta_path = self.out_dir / CSV_NAME, self.out_dir / META_NAME

    @contextlib.contextmanager
    def appending(self):
        """While inside, :meth:`record` appends rows to sweep.csv."""
        with open(self.csv_path, "a", encoding="utf-8", newline="") as fh:
            self._fh = fh
            try:
                yield self
            finally:
                self._fh = None

    def record(self, i: int, out: dict[str, Any]) -> None:
        """Point ``i``'s outcome (from :func:`~.worker.run_point`) as a row, on disk at once."""
        point = self.plan.points[i]
        row = {**point, "status": out["status"], "message": out["message"],
               **{m: out["metrics"].get(m, math.nan) for m in METRICS},
               "wall_time": out.get("wall_time", math.nan),
               "finished_at": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="microseconds")}
        if out.get("x") is not None:
            buf = io.BytesIO()
            np.savez(buf, x=out["x"], v=out["v"])
            atomic_write_bytes(self.work_dir / POINTS_DIR / f"{point_id(point)}.npz", buf.getvalue())
        self._fh.write(_csv_line(row, self.keys))
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.done[point_key(point, self.keys)] = row

    def write_sorted(self) -> None:
        """sweep.csv whole, atomically: the grid's rows in grid order, then rows of other grids."""
        ordered = [self.done[k] for k in (point_key(p, self.keys) for p in self.plan.points) if k in self.done]
        ordered += [r for k, r in self.done.items() if k not in self._grid_keys]
        atomic_write_bytes(self.csv_path, _csv_text(ordered, self.keys).encode("utf-8"))

    def rows(self) -> list[dict[str, Any]]:
        """Every grid point's row, in grid order (all must be done)."""
        return [self.done[point_key(p, self.keys)] for p in self.plan.points]

    def write_portraits(self, rows: list[dict[str, Any]]) -> dict[str, np.ndarray]:
        """portraits.npz from the points' files; returns its arrays."""
        n = None
        xs, vs = [], []
        for point, row in zip(self.plan.points, rows):
            data = None
            path = self.work_dir / POINTS_DIR / f"{point_id(point)}.npz"
            if row["status"] == STATUS_OK and path.is_file():
                with np.load(path) as z:
                    data = (z["x"], z["v"])
                n = n or len(data[0])
            xs.append(data[0] if data else None)
            vs.append(data[1] if data else None)
        n = n or PORTRAIT_POINTS
        nan = np.full(n, np.nan)
        portraits = {"labels": np.array([point_label(p) for p in self.plan.points]),
                     "status": np.array([r["status"] for r in rows]),
                     "x": np.array([x if x is not None and len(x) == n else nan for x in xs]),
                     "v": np.array([v if v is not None and len(v) == n else nan for v in vs])}
        for key in self.keys:
            values = [p[key] for p in self.plan.points]
            portraits[f"grid:{key}"] = np.array(values, dtype=float) if is_numeric(values) else np.array(
                [format_value(v) for v in values])
        buf = io.BytesIO()
        np.savez(buf, **portraits)
        atomic_write_bytes(self.out_dir / PORTRAITS_NAME, buf.getvalue())
        return portraits


def _remove_tree(path: Path) -> None:
    import shutil
    shutil.rmtree(path, ignore_errors=True)


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# -- sweep.csv ---------------------------------------------------------------------------
def _columns(keys: Iterable[str]) -> list[str]:
    return [*keys, "status", "message", *METRICS, *EXTRA_COLUMNS]


def sidecar(keys: Iterable[str]) -> dict:
    """The content of columns.json: sweep.csv's columns, each with its unit and meaning."""
    from ...scene.scenario import UNITS
    swept = [{"name": k, "unit": UNITS.get(k, ""), "meaning": f"swept value of the scenario key {k}"} for k in keys]
    return {"file": CSV_NAME, "columns": swept + [
        {"name": name, "unit": COLUMN_MEANINGS[name][0], "meaning": COLUMN_MEANINGS[name][1]}
        for name in ("status", "message", *METRICS, *EXTRA_COLUMNS)]}


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


def _read_meta(path: Path) -> dict[str, Any]:
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return old if isinstance(old, dict) else {}


def _check_fmus(path: Path, meta: dict[str, Any]) -> None:
    """Results of two physics are never merged: the finished rows must come from FMUs of the
    same source as the points still to run."""
    old = _read_meta(path)
    if old.get("fmu_source") != meta.get("fmu_source"):
        was = (f"tribofmu {old.get('tribofmu')}, FMUs {old.get('fmu_source')}" if old.get("fmu_source")
               else "FMUs not recorded (an earlier tribofmu)")
        raise SweepError(f"{path.parent}/ holds a sweep computed with other FMUs ({was}; now tribofmu "
                         f"{meta.get('tribofmu')}, FMUs {meta.get('fmu_source')}); rerun every point "
                         f"with --recompute, or use another --out")


def _check_meta(path: Path, meta: dict[str, Any]) -> None:
    old = _read_meta(path)
    if not old:
        return
    for field, what in (("keys", "swept keys"), ("base", "scenario (file and --set values)"),
                        ("algorithm", "--algorithm"), ("step", "--step"), ("tol", "--tol")):
        if old.get(field) != meta.get(field):
            raise SweepError(f"{path.parent}/ holds a sweep with other {what} ({old.get(field)!r}, now "
                             f"{meta.get(field)!r}); use another --out or remove it")
