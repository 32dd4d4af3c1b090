"""Error measures shared by every study: how far a trajectory is from a reference one.

:func:`nrms` samples at the reference's times: the number depends on which grid the
reference is given on, and the docs name it beside each table. The dense grid: the reference
solver's own output (``tribofmu accuracy``, the checked ``--tol``, docs/coupling.md) or
``tribofmu simulate``'s 1000 samples a period; a host's communication points: a third-party
master's steps, where the reference is evaluated at the host's times (docs/hosts.md). At a
host's points the samples are the step ends only, so the error between them is not seen."""
from __future__ import annotations

import numpy as np

__all__ = ["nrms"]


def nrms(t: np.ndarray, v: np.ndarray, t_ref: np.ndarray, v_ref: np.ndarray,
         window: tuple[float, float]) -> float:
    """Normalised RMS distance of ``v(t)`` from ``v_ref(t_ref)`` on ``window`` = (t0, t1) [s].

    ``v`` is interpolated linearly onto the reference times inside the window; the RMS of
    the difference is divided by ``max |v_ref|`` there. Dimensionless. Raises ValueError
    when ``t`` does not cover the window, the window holds no reference point, or the
    reference is identically zero on it (nRMS undefined).
    """
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    t_ref, v_ref = np.asarray(t_ref, dtype=float), np.asarray(v_ref, dtype=float)
    if t.ndim != 1 or t.shape != v.shape or t_ref.ndim != 1 or t_ref.shape != v_ref.shape:
        raise ValueError("t, v and t_ref, v_ref must be 1-D arrays of equal length pairwise")
    t0, t1 = window
    if not t0 < t1:
        raise ValueError(f"window must be (start, end) with start < end, got {window}")
    if np.any(np.diff(t) < 0) or np.any(np.diff(t_ref) < 0):
        raise ValueError("t and t_ref must be non-decreasing")
    span = max(abs(t0), abs(t1), t1 - t0)
    slack = 1e-9 * span  # grids that end a rounding error short of the window still cover it
    if t.size == 0 or t[0] > t0 + slack or t[-1] < t1 - slack:
        raise ValueError(f"t spans [{t[0] if t.size else 'nan'}, {t[-1] if t.size else 'nan'}] s, "
                         f"which does not cover the window [{t0}, {t1}] s")
    inside = (t_ref >= t0 - slack) & (t_ref <= t1 + slack)
    if not np.any(inside):
        raise ValueError(f"no reference time lies in the window [{t0}, {t1}] s")
    scale = float(np.max(np.abs(v_ref[inside])))
    if scale == 0.0:
        raise ValueError("the reference is zero on the window: nRMS is undefined")
    diff = np.interp(t_ref[inside], t, v) - v_ref[inside]
    return float(np.sqrt(np.mean(diff * diff)) / scale)
