"""``result.csv``: the output grid's rows, streamed to disk as the run produces them.

The columns come from one table, :data:`COLUMNS` (name, unit, how to compute it from the
sampled signals, and which scenes have it): a new column is one entry there, and the
writer, the header and the free-space estimate follow.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Column:
    name: str
    unit: str
    value: Callable[[dict[str, np.ndarray]], np.ndarray]  # the sampled signals (and "time" [s]) -> values
    applies: Callable[[object], bool] = lambda scenario: True  # does the scene have this column?


def _signal(name: str) -> Callable[[dict[str, np.ndarray]], np.ndarray]:
    return lambda signals: signals[name]


COLUMNS: tuple[Column, ...] = (
    Column("time", "s", _signal("time")),
    Column("X", "m", _signal("X")),
    Column("V", "m/s", _signal("V")),
    Column("x", "m", _signal("x")),
    Column("v", "m/s", _signal("v")),
    Column("F", "N", _signal("F")),
    Column("f", "1", _signal("f")),
)
BYTES_PER_VALUE = 25  # "%.17g" and a comma: the free-space estimate


def columns_for(scenario) -> tuple[Column, ...]:
    return tuple(c for c in COLUMNS if c.applies(scenario))


def expected_bytes(scenario, samples: int) -> int:
    """About how large result.csv will be for ``samples`` rows."""
    return samples * len(columns_for(scenario)) * BYTES_PER_VALUE


class ResultCsvWriter:
    """Writes result.csv as :class:`~tribofmu.master.run.GridRecorder` hands over its samples:
    pass it as ``sink`` (``writer(start, signals)``, signals with "time" [s])."""

    def __init__(self, path: Path, scenario):
        self.columns = columns_for(scenario)
        self.rows = 0
        self._fh = open(path, "w", encoding="ascii", newline="\n")
        self._fh.write(",".join(c.name for c in self.columns) + "\n")

    def __call__(self, start: int, signals: dict[str, np.ndarray]) -> None:
        table = np.column_stack([c.value(signals) for c in self.columns])
        np.savetxt(self._fh, table, delimiter=",", fmt="%.17g")
        self.rows += len(table)

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.flush()
            self._fh.close()

    def __enter__(self) -> "ResultCsvWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
