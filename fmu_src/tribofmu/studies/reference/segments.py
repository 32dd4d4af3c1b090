"""What the regime solvers return: the motion as a list of typed segments (each knows its
own closed form or dense solution), sampled onto the output grid by one function.

A segment covers [t_start, t_end] [s]; a time on a boundary between two segments belongs to
the later one (the states are continuous there, the force may jump).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, Sequence

import numpy as np

__all__ = ["Segment", "Samples", "Trajectory", "sample_segments", "SIGNALS"]

SIGNALS = ("x", "v", "F", "f", "T")  # m, m/s, N, 1, K

Samples = dict[str, np.ndarray]  # signal name (one of SIGNALS) -> values [SI] at the times asked for


class Segment(Protocol):
    """One piece of the motion between two events."""

    kind: str  # "stick", "slip", "smooth", "free"
    t_start: float  # s
    t_end: float  # s

    def sample(self, t: np.ndarray) -> Samples:
        """x, v, F, f, T at times t [s] inside [t_start, t_end]."""


@dataclass(frozen=True)
class Trajectory:
    """A regime solver's answer on the output grid: x [m], v [m/s], F [N], f [1] (NaN where the
    solver did not reach), T [K] (None when the film temperature is not a state), whether it
    reached the end (ok, else message says why) and its stats (solver, counts, event_times as
    (t [s], kind), ...; the keys :class:`~tribofmu.studies.reference.ReferenceResult` documents).
    """

    x: np.ndarray
    v: np.ndarray
    F: np.ndarray
    f: np.ndarray
    ok: bool
    message: str
    stats: dict = field(default_factory=dict)
    T: np.ndarray | None = None

    @classmethod
    def from_segments(cls, segments: Sequence[Segment], t_eval: np.ndarray, until: float, ok: bool,
                      message: str, stats: dict, heated: bool) -> "Trajectory":
        s = sample_segments(segments, t_eval, until)
        return cls(s["x"], s["v"], s["F"], s["f"], ok, message, stats, s["T"] if heated else None)


def sample_segments(segments: Sequence[Segment], t_eval: np.ndarray, until: float) -> Samples:
    """Every signal of SIGNALS on ``t_eval`` (non-decreasing [s]) from the segment each time
    falls in; NaN before the first segment and after ``until`` [s] (where a failed solve stopped)."""
    t_eval = np.asarray(t_eval, dtype=float)
    out = {name: np.full_like(t_eval, np.nan) for name in SIGNALS}
    if not segments:
        return out
    starts = np.array([seg.t_start for seg in segments])
    index = np.searchsorted(starts, t_eval, side="right") - 1
    last = int(np.searchsorted(t_eval, until, side="right"))  # t_eval[:last] <= until
    bounds = np.searchsorted(index[:last], np.arange(len(segments) + 1), side="left")
    for seg, lo, hi in zip(segments, bounds[:-1], bounds[1:]):
        if hi > lo:
            for name, values in seg.sample(t_eval[lo:hi]).items():
                out[name][lo:hi] = values
    return out
