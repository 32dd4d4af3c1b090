"""What a run of a scene must satisfy before it starts, for the API and the CLI alike: run
settings (step, tol, max_wall) of the right type and range, an algorithm that takes them, a
drive and a communication step the coupling can resolve on its time grid.

Every refusal is one :class:`~tribofmu.errors.UsageError` line naming the setting as the
caller knows it (``tol`` from Python, ``--tol`` from the command line, ``simulation.tol``
from the scene) and its value, cut to a readable length.
"""
from __future__ import annotations

import math
from numbers import Real

from ..coupling.interpolation import NS
from ..errors import UsageError
from .scenario_file import NUMBER_RANGE, _short

# -- a run that can resolve its drive ------------------------------------------------------------
# The coupling's time grid counts integer nanoseconds (coupling.interpolation.NS) in int64, with
# steps of at least 2 ns; the adaptive algorithm's steps are bounded by the drive's own
# interpolation (its cubic within tol: about an eighth of the period at tol 1e-3), and it is let
# through for drives the grid gives 20 points a period. A fixed-step run needs a handful of
# communication points per drive period: with
# fewer, the drive's motion is sampled below its Nyquist rate and the result is garbage (the
# jacobi run at --step 0.2 on Fig. 2: one step, V ten times A*omega, x = v = 0).
MIN_POINTS_PER_PERIOD = 10  # fixed-step algorithms: communication points per drive period
ADAPTIVE_POINTS_PER_PERIOD = 20  # grid points a period the adaptive algorithm is given at least
GRID_NS = 2  # the smallest step of the integer-nanosecond time grid
LONGEST_RUN = 2.0 ** 62 / NS  # s (~146 years): the time grid is int64 nanoseconds
# The smallest --max-wall but 0 (no limit) [s]. The limit is on a run's projected wall time,
# which the master judges once the run has gone for a few seconds (3 s): a smaller positive
# limit (1e-100) could only ever mean "stop at the first judgement", and reads like a promise
# the run cannot keep, so it is refused rather than accepted and ignored.
MIN_MAX_WALL = 1.0  # s
# tol is the checked nRMS(v) on the window relative to its largest |v|: 1 (100 %) or more
# accepts any answer, so a run "meeting" it would be a silent wrong answer (--tol 1e300 was
# reported ok with a true error of 4.6 %).
TOL_MAX = 1.0


def shown(value) -> str:
    """A value as a one-line message quotes it: its repr, cut to a readable length."""
    return _short(repr(value))


def is_number(value) -> bool:
    """A real number that is not a bool (True is no tolerance)."""
    return isinstance(value, Real) and not isinstance(value, bool)


def _magnitude_ok(value: float) -> bool:
    low, high = NUMBER_RANGE
    return math.isfinite(value) and low <= abs(value) <= high


def check_step(value, name: str = "step") -> float | None:
    """A communication step [s]: None, or a finite number > 0 (of a scene number's magnitude)."""
    if value is None:
        return None
    if not (is_number(value) and value > 0 and _magnitude_ok(float(value))):
        raise UsageError(f"{name} must be > 0 and finite, a number of seconds of magnitude "
                         f"{NUMBER_RANGE[0]:g}..{NUMBER_RANGE[1]:g}, got {shown(value)}")
    return float(value)


def check_tol(value, name: str = "tol") -> float | None:
    """The global tolerance (checked nRMS(v), relative): None, or a number in (0, TOL_MAX)."""
    if value is None:
        return None
    if not (is_number(value) and 0 < value < TOL_MAX and _magnitude_ok(float(value))):
        raise UsageError(f"{name} must be > 0 and < {TOL_MAX:g}, a number (the checked nRMS(v), relative) "
                         f"of at least {NUMBER_RANGE[0]:g}, got {shown(value)}")
    return float(value)


def check_max_wall(value, name: str = "max_wall") -> float | None:
    """A wall-time limit [s]: None, 0 (no limit) or a finite number >= MIN_MAX_WALL."""
    if value is None:
        return None
    if not (is_number(value) and math.isfinite(value) and value >= 0 and value <= NUMBER_RANGE[1]):
        raise UsageError(f"{name} must be >= 0 s and finite (0: no limit), got {shown(value)}")
    if 0 < value < MIN_MAX_WALL:
        raise UsageError(f"{name} must be 0 (no limit) or at least {MIN_MAX_WALL:g} s (a run's projected "
                         f"wall time is judged after its first seconds), got {value:g}")
    return float(value)


def check_run(scenario, algorithm: str | None, step, tol, names: dict[str, str] | None = None) -> str:
    """The algorithm that will run ``scenario`` with these settings (None: the scene's); the
    step and tol given or, when None, the scene's, each in range; a tol for an algorithm
    that has none, or a drive the run cannot resolve, refused. ``names``: how the caller
    calls ``algorithm``, ``step`` and ``tol`` (default: as here)."""
    from ..coupling.algorithms import ALGORITHMS  # the coupling and the physics: 49 ms at start-up
    # (-X importtime, min of 5, 2026-11-26 23:59 UTC, load 5.5) that --help skips
    names = {"algorithm": "algorithm", "step": "step", "tol": "tol", **(names or {})}
    if algorithm is not None and not isinstance(algorithm, str):
        raise UsageError(f"{names['algorithm']} must be an algorithm's name (a string), got {shown(algorithm)}")
    check_step(step, names["step"])
    check_tol(tol, names["tol"])
    sim = scenario.simulation
    name = algorithm or sim.algorithm
    if name not in ALGORITHMS:
        raise UsageError(f"unknown algorithm {_short(name)!r} (known: {', '.join(ALGORITHMS)})")
    if tol is not None and name != "adaptive":
        raise UsageError(f"{names['tol']} applies to the adaptive algorithm only, not {name} "
                         f"(use {names['step']})")
    if tol is None and name == "adaptive":
        check_tol(sim.tol, "simulation.tol")
    check_resolution(scenario, name, step, names["step"])
    return name


def check_resolution(scenario, algorithm: str, step: float | None, step_name: str = "--step") -> None:
    """Refuse, before the run, a drive or a communication step the run cannot resolve: one
    line naming the limit (UsageError, exit 2)."""
    from ..coupling.algorithms import ALGORITHMS  # (see check_run)
    omega, period = scenario.drive.omega, scenario.drive.period
    stop = scenario.stop_time
    if not (math.isfinite(stop) and stop <= LONGEST_RUN):
        raise UsageError(f"drive.omega = {omega:g} rad/s and time.periods = {scenario.time.periods:g} "
                         f"make a run of {stop:.3g} s, longer than the time grid holds "
                         f"({LONGEST_RUN:.3g} s in integer nanoseconds): raise drive.omega or lower "
                         f"time.periods")
    points = ADAPTIVE_POINTS_PER_PERIOD if algorithm == "adaptive" else MIN_POINTS_PER_PERIOD
    fastest = 2 * math.pi / (points * GRID_NS / NS)
    if omega > fastest:
        raise UsageError(f"drive.omega = {omega:g} rad/s: its period {period:.3g} s is shorter than "
                         f"the {algorithm} coupling can resolve ({points} steps per period of at "
                         f"least {GRID_NS} ns); drive.omega must be <= {fastest:.3g} rad/s")
    if algorithm == "adaptive":
        return  # its steps are bounded by the drive's interpolation, whatever the first try
    if step is not None:
        source, h = step_name, step
    elif scenario.simulation.step is not None:
        source, h = "simulation.step", scenario.simulation.step
    else:
        try:
            default = float(ALGORITHMS[algorithm]().default_step)
        except Exception:  # the coupling's own default; 1e-4 s when it cannot be read
            default = 1e-4
        source, h = f"the {algorithm} default step", default
    h = max(GRID_NS, round(h * NS)) / NS  # the step the run takes, on the grid
    if period / h < MIN_POINTS_PER_PERIOD:
        raise UsageError(f"{source} {h:g} s gives {period / h:.3g} communication points per drive "
                         f"period ({period:.3g} s at drive.omega = {omega:g} rad/s); the {algorithm} "
                         f"coupling needs at least {MIN_POINTS_PER_PERIOD}: use a step <= "
                         f"{period / MIN_POINTS_PER_PERIOD:.3g} s")
