"""Scalar metrics of one simulation on its shown window: pure numpy functions of the arrays.

Every function takes the window's samples (``t`` increasing, SI units) and returns a float.
:func:`compute_metrics` returns all of them as a dict, in :data:`METRICS` order. Definitions:

``stick_fraction``
    Share of window time during which the blocks are stuck together. From a simulation
    (:func:`result_metrics`) this is the coupling's own state (``SimulationResult.stuck``:
    1 where the master held the lower block on the drive because the friction needed to do
    so was within the static bound), exact, no threshold. Time-weighted with the trapezoid
    weights of the samples, so it does not depend on the sampling being uniform. For
    signals without that state (the reference solution, another master's output) the
    estimate ``|V - v| <= rel_tol * max|V|`` is available (``rel_tol`` = 1e-3 by default);
    it counts slow creeping slip as stick (at w = 130 rad/s on Fig. 2's parameters: 0.958
    by the threshold where the blocks are stuck 0.91 of the time).
    Only dry friction sticks: fluid and boundary friction have no static force, the
    lubricant always creeps (the solid boundary lubricant at ~1 % of max|V|), so both stick
    measures are exactly 0 for them (and for a scene without friction), whatever the
    coupling's stuck mask says (the master may hold dv = 0 over a step where dv crosses
    zero; that is a step of the numerics, not stick). ``creep_fraction`` and
    ``melt_fraction`` are their regime measures.

``stick_episodes_per_period``
    Number of stick episodes (maximal runs of stuck samples, as above) per drive period,
    counted on the window's whole periods ``[t0, t0 + k T)`` (``k`` = the number of whole
    periods in the window, its length counted to one sample spacing past its last sample)
    taken as periodic (a run crossing the end continues at the start, so a periodic signal
    gives exactly its number of episodes per period, whatever its phase at ``t0``). Runs
    shorter than ``min_stick * T`` (default 0.005 T) are not episodes, and slip gaps
    shorter than that do not split an episode. A window stuck (or slipping) throughout has
    0 episodes: there is no stick-slip; ``stick_fraction`` (1 or 0) tells which. With less
    than one whole period in the window, the runs in the whole window are counted and
    divided by its length in periods.

``creep_fraction``
    Fluid and boundary friction only (NaN for dry friction, which sticks, and without
    friction): share of window time (time-weighted) with the blocks creeping together,
    ``|V - v| < CREEP_REL * A w`` (``CREEP_REL`` = 0.05: 5 % of the drive's velocity
    amplitude). The paper's "stick-slip" of a pseudoplastic fluid or a solid boundary
    lubricant is this creep: the block follows the drive slowly slipping, never stuck. A
    relative velocity crossing zero creeps briefly too: a sinusoidal ``V - v`` of amplitude
    ``D > CREEP_REL * A w`` gives a share ``(2/pi) asin(CREEP_REL * A w / D)`` in two
    episodes per period (a Newtonian fluid's small share; compare the shares).

``creep_episodes_per_period``
    Fluid and boundary friction only: episodes of creep (as above) per drive period,
    counted like ``stick_episodes_per_period`` (whole periods taken as periodic, runs and
    gaps shorter than 0.005 T ignored; 0 when creeping always or never).

``harmonics``
    Number of significant harmonics of ``x(t)``: the Fourier amplitudes
    ``a_h = |2 / (k T) integral (x - mean x) exp(-i h w t) dt|`` over the window's ``k`` whole
    periods ``[t0, t0 + k T)`` (left rectangle rule: the DFT bin ``h k`` on a uniform grid),
    for ``h = 1 .. H`` (``H = min(50, samples per period / 2 - 1)``); the count of ``h`` with
    ``a_h > rel * max_h a_h`` (``rel`` = 0.01). The mean (h = 0) is not a harmonic; a pure
    sinusoid at the drive frequency, with any phase and offset, has 1; a constant (or ``x``
    varying by less than 1e-9 of ``max|x|``), 0. Frequencies that are not multiples of ``w``
    (subharmonics, transients) are not counted. NaN when the window holds less than one
    whole period.

``amplitude_ratio``
    ``max|x| / A`` over the window (the block's amplitude relative to the drive's; an offset
    of the block counts).

``dissipated_per_cycle``
    Energy dissipated by friction per drive period [J]: ``integral F (V - v) dt`` over the
    window (trapezoid rule) divided by the window's length in periods. ``F (V - v) >= 0`` for
    every friction law here, so this is >= 0 up to numerical error.

``melt_fraction``
    Boundary friction only: share of window time (time-weighted as above) with the
    lubricant's excess volume ``f`` above the melting point ``mu_shear / mu_shear_bar``, where
    the effective shear modulus vanishes. NaN for the other regimes (no threshold given).
"""
from __future__ import annotations

import math

import numpy as np

METRICS = ("stick_fraction", "stick_episodes_per_period", "creep_fraction", "creep_episodes_per_period",
           "harmonics", "amplitude_ratio", "dissipated_per_cycle", "melt_fraction")
CREEP_REL = 0.05  # |V - v| < CREEP_REL * A w counts as creeping together

STICK_REL_TOL = 1e-3  # |V - v| <= STICK_REL_TOL * max|V| counts as stuck
MIN_STICK = 0.005  # shortest stick episode (and slip gap) counted, in drive periods
HARMONIC_REL = 0.01  # significant harmonic: amplitude > HARMONIC_REL * the largest
MAX_HARMONIC = 50
FLAT = 1e-9  # x varying less than this fraction of max|x| has no harmonics

_TINY = 1e-9  # relative slack when comparing times to whole periods


def _arrays(*arrays):
    out = [np.asarray(a, dtype=float) for a in arrays]
    n = len(out[0])
    if any(len(a) != n for a in out):
        raise ValueError(f"arrays of different lengths: {[len(a) for a in out]}")
    return out


def time_weights(t) -> np.ndarray:
    """Trapezoid weights of the samples: ``sum(w * y)`` is the trapezoid integral of ``y``."""
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        return np.ones(len(t))
    dt = np.diff(t)
    w = np.zeros(len(t))
    w[:-1] += dt / 2
    w[1:] += dt / 2
    return w


def time_fraction(t, mask) -> float:
    """Share of the time span ``[t[0], t[-1]]`` where mask is true (trapezoid weights)."""
    mask = np.asarray(mask, dtype=bool)
    if len(mask) == 0:
        return math.nan
    w = time_weights(t)
    total = w.sum()
    return float(mask.mean()) if total <= 0 else float(w[mask].sum() / total)


def stuck(V, v, rel_tol: float = STICK_REL_TOL) -> np.ndarray:
    """Boolean mask of the samples where the blocks move together: ``|V - v| <= rel_tol max|V|``."""
    V, v = _arrays(V, v)
    scale = float(np.max(np.abs(V))) if len(V) else 0.0
    return np.abs(V - v) <= rel_tol * scale


def whole_periods(t, period: float) -> tuple[int, int]:
    """``(k, m)``: the window holds ``k`` whole periods, ``t[:m]`` are the samples in ``[t0, t0 + k T)``.

    The window's length counts one sample spacing past its last sample (the samples of
    ``[t0, t0 + k T)`` are all a periodic analysis needs), so a window that lost its end
    sample to rounding still holds its whole periods.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2 or not period > 0:
        return 0, len(t)
    dt = float(np.median(np.diff(t)))
    k = int(math.floor((t[-1] - t[0] + dt) / period * (1 + _TINY) + _TINY))
    if k < 1:
        return 0, len(t)
    end = t[0] + k * period
    m = int(np.searchsorted(t, end - min(dt / 2, _TINY * period), side="left"))
    return k, m


def stuck_fraction(t, stuck_mask) -> float:
    """Share of window time where ``stuck_mask`` (the coupling's stuck state) is true."""
    return time_fraction(t, np.asarray(stuck_mask) > 0.5)


def stick_fraction(t, V, v, rel_tol: float = STICK_REL_TOL) -> float:
    """Estimate from velocities: share of window time with ``|V - v| <= rel_tol * max|V|``."""
    return time_fraction(t, stuck(V, v, rel_tol))


def _runs(mask: np.ndarray, circular: bool) -> list[tuple[int, int]]:
    """Maximal runs of True as ``(start, length)``; with circular, a run may wrap around."""
    n = len(mask)
    if n == 0 or not mask.any():
        return []
    if mask.all():
        return [(0, n)]
    shift = 0
    if circular:  # start at a False sample so no run wraps
        shift = int(np.argmin(mask))
        mask = np.roll(mask, -shift)
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [((s + shift) % n, e - s) for s, e in zip(edges[::2], edges[1::2])]


def _debounce(mask: np.ndarray, min_len: int, circular: bool) -> np.ndarray:
    """Fill False gaps shorter than min_len between True runs, then drop short True runs."""
    mask = mask.copy()
    n = len(mask)
    if min_len <= 1 or n == 0:
        return mask
    for start, length in _runs(~mask, circular):
        inside = circular or (start > 0 and start + length < n)  # a gap between two stuck runs
        if length < min_len and inside and mask.any():
            mask[np.arange(start, start + length) % n] = True
    for start, length in _runs(mask, circular):
        if length < min_len:
            mask[np.arange(start, start + length) % n] = False
    return mask


def stuck_episodes_per_period(t, stuck_mask, period: float, min_stick: float = MIN_STICK) -> float:
    """Stick episodes per drive period of a stuck mask (see the module docstring)."""
    t = np.asarray(t, dtype=float)
    mask = np.asarray(stuck_mask) > 0.5
    if len(t) != len(mask):
        raise ValueError(f"arrays of different lengths: {[len(t), len(mask)]}")
    if len(t) < 2:
        return math.nan
    k, m = whole_periods(t, period)
    circular = k >= 1
    mask = mask[:m]
    dt = float(np.median(np.diff(t)))
    min_len = max(1, int(math.ceil(min_stick * period / dt - _TINY)))
    mask = _debounce(mask, min_len, circular)
    if mask.all() or not mask.any():
        return 0.0
    episodes = len(_runs(mask, circular))
    span = k if circular else (t[-1] - t[0]) / period
    return float(episodes / span)


def stick_episodes_per_period(t, V, v, period: float, rel_tol: float = STICK_REL_TOL,
                              min_stick: float = MIN_STICK) -> float:
    """Estimate from velocities: episodes of ``|V - v| <= rel_tol * max|V|`` per period."""
    t, V, v = _arrays(t, V, v)
    return stuck_episodes_per_period(t, stuck(V, v, rel_tol), period, min_stick)


def harmonic_amplitudes(t, x, period: float, max_harmonic: int = MAX_HARMONIC) -> np.ndarray:
    """``a_h`` for ``h = 1 .. H`` over the window's whole periods (see :func:`harmonics`)."""
    t, x = _arrays(t, x)
    k, m = whole_periods(t, period)
    if k < 1:
        return np.array([])
    t0, end = t[0], t[0] + k * period
    tt, xx = t[:m], x[:m]
    top = int(min(max_harmonic, math.floor(m / k / 2) - 1))
    if top < 1:
        return np.array([])
    w = np.diff(np.append(tt, end))  # left rectangles over [t0, t0 + k T): the DFT when uniform
    xx = xx - np.sum(w * xx) / np.sum(w)
    h = np.arange(1, top + 1)
    omega = 2 * math.pi / period
    phases = np.exp(-1j * omega * np.outer(h, tt - t0))
    return np.abs(2.0 / (k * period) * (phases @ (w * xx)))


def harmonics(t, x, period: float, rel: float = HARMONIC_REL, max_harmonic: int = MAX_HARMONIC) -> float:
    """Number of harmonics ``h w`` of x(t) with amplitude > rel * the largest one (NaN under one period)."""
    a = harmonic_amplitudes(t, x, period, max_harmonic)
    if len(a) == 0:
        return math.nan
    top = float(a.max())
    if not top > FLAT * float(np.max(np.abs(x))):  # a constant: rounding noise is not a harmonic
        return 0.0
    return float(np.count_nonzero(a > rel * top))


def amplitude_ratio(x, A: float) -> float:
    """``max|x| / A``."""
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x)) / A) if len(x) and A else math.nan


def dissipated_per_cycle(t, F, V, v, period: float) -> float:
    """``integral F (V - v) dt`` over the window / (window length / T)  [J per period]."""
    t, F, V, v = _arrays(t, F, V, v)
    if len(t) < 2:
        return math.nan
    energy = float(np.sum(time_weights(t) * F * (V - v)))
    return energy / ((t[-1] - t[0]) / period)


def melt_fraction(t, f, threshold: float | None) -> float:
    """Share of window time with ``f > threshold`` (``mu_shear / mu_shear_bar``); NaN without one."""
    if threshold is None:
        return math.nan
    t, f = _arrays(t, f)
    return time_fraction(t, f > threshold)


def creeping(V, v, A: float, omega: float, rel: float = CREEP_REL) -> np.ndarray:
    """Boolean mask of creep: ``|V - v| < rel * A w`` (A [m], w [rad/s])."""
    V, v = _arrays(V, v)
    return np.abs(V - v) < rel * abs(A * omega)


def creep_fraction(t, V, v, A: float, omega: float, rel: float = CREEP_REL) -> float:
    """Share of window time with ``|V - v| < rel * A w``."""
    return time_fraction(t, creeping(V, v, A, omega, rel))


def creep_episodes_per_period(t, V, v, A: float, omega: float, period: float, rel: float = CREEP_REL,
                              min_stick: float = MIN_STICK) -> float:
    """Episodes of ``|V - v| < rel * A w`` per drive period (counted as stick episodes are)."""
    return stuck_episodes_per_period(t, creeping(V, v, A, omega, rel), period, min_stick)


def compute_metrics(t, V, x, v, F, f, period: float, amplitude: float,
                    melt_threshold: float | None = None, rel_tol: float = STICK_REL_TOL,
                    stuck_mask=None, sticks: bool | None = None, creeps: bool = False,
                    omega: float | None = None) -> dict[str, float]:
    """All of :data:`METRICS` for one window's arrays; the stick measures from ``stuck_mask``
    (the coupling's state) when given, else estimated from ``|V - v|``.

    sticks: whether the friction law can stick (its ``sticks``; False without friction): a
    law that cannot has stick measures 0; None: not known (stick measured as given).
    creeps: whether to measure creep (a law that cannot stick but follows the drive closely:
    fluid, boundary); NaN otherwise. omega [rad/s]: the drive's (default 2 pi / period)."""
    omega = 2 * math.pi / period if omega is None else omega
    if sticks is False:
        stick = episodes = 0.0
    elif stuck_mask is not None:
        stick = stuck_fraction(t, stuck_mask)
        episodes = stuck_episodes_per_period(t, stuck_mask, period)
    else:
        stick = stick_fraction(t, V, v, rel_tol)
        episodes = stick_episodes_per_period(t, V, v, period, rel_tol)
    return {
        "stick_fraction": stick,
        "stick_episodes_per_period": episodes,
        "creep_fraction": creep_fraction(t, V, v, amplitude, omega) if creeps else math.nan,
        "creep_episodes_per_period": (creep_episodes_per_period(t, V, v, amplitude, omega, period)
                                      if creeps else math.nan),
        "harmonics": harmonics(t, x, period),
        "amplitude_ratio": amplitude_ratio(x, amplitude),
        "dissipated_per_cycle": dissipated_per_cycle(t, F, V, v, period),
        "melt_fraction": melt_fraction(t, f, melt_threshold),
    }


def result_metrics(result) -> dict[str, float]:
    """:func:`compute_metrics` on a :class:`tribofmu.api.SimulationResult`'s shown window,
    the stick measures from the coupling's own stuck state (laws that stick; 0 for the others)."""
    sc = result.scenario
    m = result.window_mask()
    law = sc.friction.law() if "Friction" in sc.fmus else None
    threshold = law.melt_threshold() if law is not None else None
    return compute_metrics(result.time[m], result.V[m], result.x[m], result.v[m], result.F[m],
                           result.f[m], sc.drive.period, sc.drive.A, threshold,
                           stuck_mask=np.asarray(result.stuck)[m],
                           sticks=law is not None and law.sticks, creeps=law is not None and not law.sticks,
                           omega=sc.drive.omega)
