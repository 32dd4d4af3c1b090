"""The columns of ``result.csv``: one table (name, unit, meaning, which scenes have it, how it
is computed from the sampled signals), used by every writer and reader of results.

Every scene has ``time, X, V, x, v, F, f, stuck, dv, a``; a scene with a Thermal FMU adds
``T`` and ``Q``, one with a Load FMU adds ``n``. The units go into a sidecar
``columns.json`` beside the CSV (the CSV keeps a single header line, so numpy, pandas and
spreadsheets read it as plain numbers).

A writer that streams rows takes :func:`columns_for` once, then calls :func:`rows` on each
chunk of sampled signals (a mapping of name to array, as the recorder and
:class:`tribofmu.api.SimulationResult` give them).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

CSV_NAME = "result.csv"
SIDECAR_NAME = "columns.json"


@dataclass(frozen=True)
class Column:
    name: str
    unit: str
    meaning: str
    needs: str | None = None  # the FMU a scene must list for this column (None: every scene)
    derive: Callable | None = None  # (signals, scenario) -> array, when not a sampled signal

    def applies(self, scenario) -> bool:
        return self.needs is None or self.needs in scenario.fmus

    def values(self, signals: Mapping, scenario):
        return self.derive(signals, scenario) if self.derive else signals[self.name]


def _dv(s, sc):
    return s["V"] - s["v"]


def _a(s, sc):
    # slipping: the block's equation of motion, M a = F - 2 K x (what BlockSpring integrates);
    # stuck to the drive: the drive's acceleration, -w^2 X (X = A cos wt)
    free = (s["F"] - 2.0 * sc.block.K * s["x"]) / sc.block.M
    if "Drive" not in sc.fmus:
        return free
    return np.where(np.asarray(s["stuck"]) > 0.5, -sc.drive.omega ** 2 * np.asarray(s["X"]), free)


RESULT_CSV_COLUMNS: tuple[Column, ...] = (
    Column("time", "s", "simulated time"),
    Column("X", "m", "drive (upper block) position, A cos(wt)"),
    Column("V", "m/s", "drive velocity"),
    Column("x", "m", "block position"),
    Column("v", "m/s", "block velocity"),
    Column("F", "N", "friction force on the block"),
    Column("f", "1", "lubricant excess volume (boundary friction; 0 otherwise)"),
    Column("stuck", "1", "1 where the coupling held the blocks together over the step, else 0"),
    Column("dv", "m/s", "relative velocity V - v (the friction's input)", derive=_dv),
    Column("a", "m/s^2", "block acceleration: M a = F - 2 K x slipping, the drive's -w^2 X stuck", derive=_a),
    Column("T", "K", "film temperature (Thermal FMU output, the friction's input)", needs="Thermal"),
    Column("Q", "J", "heat the Thermal FMU received since t = 0", needs="Thermal"),
    Column("n", "Pa", "normal stress (Load FMU output, the friction's input; L = -n S)", needs="Load"),
)
BY_NAME = {c.name: c for c in RESULT_CSV_COLUMNS}


def columns_for(scenario) -> list[Column]:
    """The columns a run of this scene writes, in CSV order."""
    return [c for c in RESULT_CSV_COLUMNS if c.applies(scenario)]


def header(columns) -> str:
    return ",".join(c.name for c in columns)


def rows(signals: Mapping, scenario, columns=None):
    """A 2-D array (samples x columns) of a chunk of signals (``time`` included)."""
    columns = columns or columns_for(scenario)
    return np.column_stack([np.asarray(c.values(signals, scenario), dtype=float) for c in columns])


def sidecar(columns) -> dict:
    """The content of columns.json."""
    return {"file": CSV_NAME, "columns": [{"name": c.name, "unit": c.unit, "meaning": c.meaning}
                                          for c in columns]}


def result_signals(result) -> dict:
    """A :class:`tribofmu.api.SimulationResult`'s sampled signals by name."""
    out = {"time": result.time}
    for name in ("X", "V", "x", "v", "F", "f", "stuck"):
        out[name] = getattr(result, name)
    out.update({k: v for k, v in result.inputs.items() if k in BY_NAME and BY_NAME[k].applies(result.scenario)})
    return out


def read_result_csv(path: Path) -> dict:
    """``result.csv`` back as ``{column name: array}``."""
    path = Path(path)
    with path.open(encoding="utf-8") as fh:
        names = fh.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {data.shape[1]} values per row for {len(names)} header names")
    return {name: data[:, i] for i, name in enumerate(names)}
