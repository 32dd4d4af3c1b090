"""``result.csv``: the output grid's rows, streamed to disk as the run produces them.

The columns come from the one table of :mod:`tribofmu.columns` (name, unit, meaning, which
scenes have it, how it is computed from the sampled signals): the writer, the header, the
``columns.json`` sidecar and the free-space estimate follow it.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .columns import SIDECAR_NAME, Column, columns_for, header, result_signals, rows, sidecar

BYTES_PER_VALUE = 25  # "%.17g" and a comma: the free-space estimate


def expected_bytes(scenario, samples: int) -> int:
    """About how large result.csv will be for ``samples`` rows."""
    return samples * len(columns_for(scenario)) * BYTES_PER_VALUE


class ResultCsvWriter:
    """Writes result.csv (and columns.json beside it) as
    :class:`~tribofmu.master.run.GridRecorder` hands over its samples: pass it as ``sink``
    (``writer(start, signals)``, signals with "time" [s])."""

    def __init__(self, path: Path, scenario):
        path = Path(path)
        self.scenario, self.columns = scenario, columns_for(scenario)
        self.rows = 0
        (path.parent / SIDECAR_NAME).write_text(json.dumps(sidecar(self.columns), indent=2) + "\n")
        self._fh = open(path, "w", encoding="ascii", newline="\n")
        self._fh.write(header(self.columns) + "\n")

    def __call__(self, start: int, signals: dict[str, np.ndarray]) -> None:
        table = rows(signals, self.scenario, self.columns)
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


def write_result_csv(result, path: Path) -> list[Column]:
    """A whole :class:`tribofmu.api.SimulationResult` as ``result.csv`` with ``columns.json``
    beside it, through the same writer as a streamed run; returns the columns written."""
    with ResultCsvWriter(path, result.scenario) as writer:
        writer(0, result_signals(result))
    return writer.columns
