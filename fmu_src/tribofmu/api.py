"""The Python API: load a scenario, override parameters, simulate, get arrays back, save.

    from tribofmu.api import simulate, simulate_and_save, save
    result = simulate("fig2_dry", {"drive.omega": 80})   # a shipped scene, or a .toml path
    result.time, result.v, result.stats
    save(result, "out/omega80")                        # the folder `tribofmu simulate` writes
    simulate_and_save("fig2_dry", "out/fig2_dry")      # what `tribofmu simulate fig2_dry` does

The CLI is a thin layer over these functions: ``tribofmu simulate`` is
:func:`simulate_and_save`.
"""
from __future__ import annotations

import contextlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import result_set
from .checked import checked_simulation
from .columns import SIDECAR_NAME
from .fmu_cache import find_fmus
from .forked_runs import check_workers as count_check_workers
from .provenance import overrides_dict, record
from .result_csv import ResultCsvWriter, write_result_csv
from .api_arguments import (SCENE_MAX_WALL, arguments, check_flag, check_overrides, check_path,
                            check_run_arguments, refuse)
from .errors import ArgumentError, FMUError, FMUSetupError  # noqa: F401 (FMUSetupError re-exported)
from .coupling.algorithms import Scales, make_algorithm
from .coupling.estimate import carry_needs_verification, carry_problem
from .coupling.window_error import WindowError
from .coupling.settings import CHECK_SETTINGS, STEP_CONTROL
from .coupling.interpolation import INPUT_SIGNALS, NS, SAMPLES_PER_PERIOD, SIGNALS
from .coupling.system import CoupledSystem
from .master import FMUCallError, FMUFileError, FMUInstance, GridRecorder, RunLimits, run
from .master.energy import EnergyAudit
from .metrics import result_metrics
from .scene.checks import check_run
from .scene.library import resolve_scene
from .scene.scenario import Scenario, ScenarioError, load_scenario, scales, to_dict
from .scene.wiring import constant_inputs, fmu_parameters
from .trajectory import SampledTrajectory


# The output grid is held in memory (8 bytes a value): 1e7 samples are 0.6 GB of results.
MAX_OUTPUT_SAMPLES = 10_000_000


@dataclass
class _OfScenario:
    scenario: Scenario


@dataclass
class SimulationResult(SampledTrajectory, _OfScenario):
    """Signals on a uniform grid (every T/1000 or finer) over the whole span, SI units: the
    :class:`~tribofmu.trajectory.SampledTrajectory` of ``scenario``, with what the coupling adds.
    Fields in the order scenario, time, X, V, x, v, F, f, stuck, ok, message, ... (a dataclass
    puts the fields of its last base first: _OfScenario's, then SampledTrajectory's)."""

    stuck: np.ndarray  # 1.0 where the coupling held the blocks together, else 0.0
    ok: bool
    message: str
    stats: dict[str, Any] = field(default_factory=dict)
    points: list = field(default_factory=list, repr=False)  # every communication point (keep_points)
    inputs: dict[str, np.ndarray] = field(default_factory=dict)  # T [K], n [Pa], Q [J] on the grid, when
    # other FMUs (Thermal, Load) feed the friction

    def window_mask(self) -> np.ndarray:
        """Boolean mask of the shown window [5T, 6.5T] (or the scene's)."""
        start, end = self.scenario.window
        return (self.time >= start - 1e-12) & (self.time <= end + 1e-12)


def load(path: str | Path, overrides: dict[str, Any] | list[str] | None = None) -> Scenario:
    """Read and validate a scenario (a .toml path, or a shipped scene's name such as
    ``"fig2_dry"``); raises ScenarioError with a one-line message (ArgumentError for a path
    that is no path, or overrides that are no overrides)."""
    check_path("load", "path", path)
    check_overrides("load", overrides)
    return load_scenario(resolve_scene(path), overrides)


def simulate(scenario: Scenario | str | Path, overrides: dict[str, Any] | list[str] | None = None,
             algorithm: str | None = None, step: float | None = None, tol: float | None = None,
             fmu_dir: str | Path | None = None, build: bool | None = None,
             progress=None, keep_points: bool = False, max_wall: float | None | str = SCENE_MAX_WALL,
             notice=None, sink=None, keep_window: bool = False,
             check_workers: int | None = None) -> SimulationResult:
    """Co-simulate a scenario with the FMUs in fmu_dir.

    algorithm/step/tol default to the scenario's [simulation] table, then to the
    algorithm's own defaults; step [s] > 0, tol (the checked nRMS(v) on the window,
    relative) in (0, 1). fmu_dir defaults to the per-user cache of FMUs built from this
    source (:func:`tribofmu.build.default_fmu_dir`). build: True rebuilds the FMUs,
    None builds only missing ones, False never builds (a missing FMU is then an
    FMUFileError). keep_points: keep every communication point in ``result.points``
    (memory grows with the run); otherwise only the output grid is kept. max_wall [s]: stop
    a run whose projected wall time exceeds it (None or 0: never; at least 1 s otherwise;
    default ``"scene"``: the scene's ``simulation.max_wall``). notice(text): told once when a
    run will take long. sink(start, signals): told each stretch of output samples as it is
    done (see :class:`~tribofmu.master.run.GridRecorder`), to stream them to disk;
    keep_window: keep only the shown window in the result (with a sink, memory then does not
    grow with the run). check_workers: how many runs of the adaptive's check go at once, each
    in a forked process (None: ``TRIBOFMU_CHECK_WORKERS``, else on Linux the usable cores, at
    most 2; see :mod:`tribofmu.forked_runs`); the result is the same whatever it is.

    Every argument is checked before any FMU is found or built: a wrong type or a value out
    of range raises :class:`~tribofmu.errors.ArgumentError` (one line naming it).
    """
    check_run_arguments("simulate", scenario, overrides, fmu_dir, build, progress, notice, max_wall,
                        keep_points=keep_points, keep_window=keep_window, sink=sink)
    workers = arguments("simulate", lambda: count_check_workers(check_workers))
    scenario = _scenario(scenario, overrides)
    sim = scenario.simulation
    # step and tol in range, the algorithm known and taking them, a drive and a
    # communication step the run can resolve: refused before any work, as the CLI refuses them
    name = arguments("simulate", lambda: check_run(scenario, algorithm, step, tol))
    tol = tol if tol is not None else sim.tol
    step = step if step is not None else sim.step
    try:
        make_algorithm(name, step=step, tol=tol)
    except ValueError as exc:
        raise ScenarioError(f"{scenario.source}: {exc}") from None
    n = output_samples(scenario)  # before any FMU is found or built
    if fmu_dir is None or build is not False:  # a given folder as is: every missing FMU in one message
        fmu_dir = find_fmus(scenario.fmus, fmu_dir, build=build)
    fmu_dir = Path(fmu_dir)
    budget = (sim.max_wall if max_wall == SCENE_MAX_WALL else max_wall) or None

    global_tol = tol if tol is not None else DEFAULT_TOL

    def run_once(step_tol=None, max_wall=budget, sink=sink, progress=progress, notice=notice, aim=False):
        # aim: the run steers its per-step tolerance to meet tol on the window (coupling/lead_in.py)
        return _run_once(scenario, name, step, step_tol, fmu_dir, n, progress, keep_points, max_wall,
                         notice, sink, keep_window, global_tol if aim else None)

    def load_fmus():
        """Once, before the check's runs are forked: what a process does the first time it opens
        an FMU (unzip it, load its library, import its Python), which each forked run would
        otherwise do again."""
        for fmu, params in fmu_parameters(scenario).items():
            try:
                FMUInstance(fmu_dir / f"{fmu}.fmu", instance=fmu.lower(), parameters=params).close()
            except Exception:  # a missing or damaged FMU: the run that opens it says so, in one line
                pass

    if name != "adaptive":
        return run_once(step_tol=None)
    vouches = own_estimate_problem(scenario, inputs_vary(scenario)) is None
    verify = vouches and "Friction" in scenario.fmus and carry_needs_verification(scenario.friction.law())
    return checked_simulation(run_once, global_tol, budget, sink, workers=workers,
                              progress=progress, notice=notice, prepare=load_fmus, vouches=vouches,
                              verify=verify)


def _scenario(scenario: Scenario | str | Path, overrides) -> Scenario:
    """The scenario to run: a :class:`Scenario` (with the overrides applied) or one loaded."""
    if not isinstance(scenario, Scenario):
        return load_scenario(resolve_scene(scenario), overrides)
    return scenario.with_overrides(overrides) if overrides else scenario


# The global tolerance of an adaptive run when neither the scene nor the caller gives one:
# nRMS(v) on the shown window, relative to its largest |v| (docs/model.md's ranges meet it).
DEFAULT_TOL = 1e-3


def one_run(scenario: Scenario, step_tol: float, fmu_dir: Path, max_wall: float | None = None,
            keep_points: bool = False, aim: float | None = None) -> SimulationResult:
    """One run of the adaptive coupling at the per-step tolerance step_tol, unchecked (a checked
    call's first run is one): for benchmarks and tests that judge a run on its own; max_wall [s]
    its budget (None: none); keep_points: the accepted points in ``result.points``; aim: the
    global tol it aims its window at, as a call's first run does (coupling/lead_in.py; None: none)."""
    return _run_once(scenario, "adaptive", None, step_tol, Path(fmu_dir), output_samples(scenario), None,
                     keep_points, max_wall, None, None, False, aim)


def _run_once(scenario: Scenario, name: str, step: float | None, step_tol: float | None, fmu_dir: Path,
              n: int, progress, keep_points: bool, max_wall: float | None, notice, sink,
              keep_window: bool, aim: float | None = None) -> SimulationResult:
    """One run of the coupling ``name`` at the per-step tolerance ``step_tol`` (adaptive); aim:
    the global tol its window is to meet, which its per-step tolerance may tighten for once
    (coupling/lead_in.py; None: the tolerance is fixed)."""
    coupling = make_algorithm(name, step=step, tol=step_tol)
    asked_tol = coupling.tol
    if aim is not None and name == "adaptive":
        coupling.aim_window(scenario.window[0], STEP_CONTROL.safety * aim / CHECK_SETTINGS.estimate_safety,
                            scenario.stop_time)
    grid = np.linspace(0.0, scenario.stop_time, n + 1)
    keep = None
    if keep_window:
        start, end = scenario.window
        keep = (int(np.searchsorted(grid, start - 1e-12)), int(np.searchsorted(grid, end + 1e-12, side="right")))
    audit = EnergyAudit(scenario)
    error_audit = WindowError(scenario.window)
    inputs = inputs_vary(scenario)
    recorder = GridRecorder(grid, [audit, error_audit], inputs=inputs, keep_points=keep_points, sink=sink,
                            keep=keep)
    limits = RunLimits(max_wall=max_wall)
    slaves: dict[str, FMUInstance] = {}
    try:
        failures = []  # every instance's failure, in one message
        for fmu, params in fmu_parameters(scenario).items():
            try:
                slaves[fmu] = FMUInstance(fmu_dir / f"{fmu}.fmu", instance=fmu.lower(), parameters=params)
            except (FMUFileError, FMUCallError) as exc:
                failures.append(str(exc))
        if failures:
            raise FMUSetupError("; ".join(failures))
        system = build_system(scenario, slaves)
        position, velocity, period = scales(scenario)
        outcome = run(system, coupling, scenario.stop_time, Scales(position, velocity, period), progress,
                      recorder=recorder, limits=limits, notice=notice)
    finally:
        for slave in slaves.values():
            slave.close()
    signals = recorder.sampled()
    reached = recorder.filled  # samples of the grid the run reached (all streamed to the sink)
    first = recorder.keep[0]
    grid = grid[first:first + len(signals["v"])]  # the kept part of the grid the run reached
    adaptive = name == "adaptive"
    stats = {"algorithm": coupling.name, "step": coupling.step_ns / NS if not adaptive else None,
             "tol": asked_tol if adaptive else None, "step_tol": asked_tol if adaptive else None,
             # (the per-step tolerance the run ended at: tighter where it aimed at its window)
             "window_step_tol": coupling.tol if adaptive else None,
             "lead_in": getattr(coupling, "lead_in_decision", None),  # (coupling/lead_in.py; None: none made)
             "ok": outcome.ok, "completed": outcome.ok, "out_of_time": outcome.out_of_time,
             "message": outcome.message,
             "wall_time": outcome.wall_time,
             "communication_steps": outcome.counters["steps"], "rejected_steps": outcome.counters["rejected"],
             "landed_events": outcome.counters.get("landed", 0),
             "coupling_iterations": outcome.counters["iterations"],
             "stick_steps": outcome.counters["stick_steps"], "forced_steps": outcome.counters["forced"],
             "fmu_calls": outcome.calls, "fmu_calls_total": sum(outcome.calls.values()),
             "fmu_calls_per_step": fmu_calls_per_step(outcome),
             "output_points": int(reached),
             "fmus": {name: {"file": str((fmu_dir / f"{name}.fmu").resolve()), "guid": getattr(slave, "guid", None)}
                      for name, slave in slaves.items()}}
    stats["estimated_error"] = estimated_error(coupling, error_audit, own_estimate_problem(scenario, inputs))
    stats["warnings"] = []
    stats["energy"] = audit.result()
    heat = audit.heat()
    if heat:
        stats["heat"] = heat
    return SimulationResult(scenario, grid, *(signals[k] for k in SIGNALS), outcome.ok, outcome.message,
                            stats, outcome.points if keep_points else [],
                            {k: signals[k] for k in INPUT_SIGNALS if k in signals})


def simulate_and_save(scenario: Scenario | str | Path, out: str | Path,
                      overrides: dict[str, Any] | list[str] | None = None, *,
                      algorithm: str | None = None, step: float | None = None, tol: float | None = None,
                      fmu_dir: str | Path | None = None, build: bool | None = None, plots: bool = True,
                      max_wall: float | None | str = SCENE_MAX_WALL, progress=None, notice=None,
                      command: list[str] | None = None) -> SimulationResult:
    """Simulate and write the result set ``tribofmu simulate`` writes, into the folder ``out``:
    ``result.csv`` (streamed to disk as the run goes: memory does not grow with the run),
    ``columns.json``, ``stats.json`` (the run's stats, the scene's metrics, the scenario and
    the provenance) and, with ``plots``, ``time.png`` and ``phase.png``.

    The set is written in a folder beside ``out`` and swapped in whole
    (:func:`tribofmu.atomic.result_set`): on an error or Ctrl-C ``out`` is as it was. ``out``
    must be new, empty or an earlier result set (a folder holding other files raises
    :class:`FileExistsError`). A run that did not complete (``stats["completed"]``, where
    the run reports it, else ``result.ok``, False) leaves ``stats.json`` alone, with its
    message. The arguments are :func:`simulate`'s; scenario is
    a shipped scene's name, a .toml path (recorded in the provenance with its sha256) or a
    :class:`Scenario`. progress: as :func:`simulate`'s; one that is a context manager (the
    CLI's :class:`tribofmu.progress.RunBar`) is entered around the run alone, not the
    writing. command: the command line recorded in the provenance (the CLI's; None from
    Python). Returns the result, holding the shown window only (the rest is in
    ``result.csv``)."""

    check_run_arguments("simulate_and_save", scenario, overrides, fmu_dir, build, progress, notice, max_wall,
                        plots=plots)
    check_path("simulate_and_save", "out", out)
    if command is not None and not (isinstance(command, (list, tuple)) and all(isinstance(w, str) for w in command)):
        refuse("simulate_and_save", "command", "a list of strings or None", command)
    scene_file = None if isinstance(scenario, Scenario) else resolve_scene(scenario)
    scenario = _scenario(scenario if scene_file is None else scene_file, overrides)
    arguments("simulate_and_save", lambda: check_run(scenario, algorithm, step, tol))
    requested = {"algorithm": algorithm, "step": step, "tol": tol}
    with result_set(Path(out)) as tmp:  # swapped in whole when done; untouched on failure or Ctrl-C
        # rows go to disk as they come; only the shown window is kept (metrics, plots)
        around_run = progress if hasattr(progress, "__enter__") else contextlib.nullcontext()
        with ResultCsvWriter(tmp / "result.csv", scenario) as rows, around_run:
            result = simulate(scenario, algorithm=algorithm, step=step, tol=tol, fmu_dir=fmu_dir, build=build,
                              progress=progress, notice=notice, max_wall=max_wall, sink=rows, keep_window=True)
        _write_result_set(tmp, result, scene_file, overrides_dict(overrides), requested, plots, command)
    return result


def save(result: SimulationResult, out: str | Path, plots: bool = True,
         scene_file: str | Path | None = None, overrides: dict[str, Any] | list[str] | None = None) -> Path:
    """Write a :func:`simulate` result as the result set ``tribofmu simulate`` writes (see
    :func:`simulate_and_save`), atomically, into the folder ``out``; returns ``out``.

    The result must hold the whole run (a :func:`simulate` result without ``keep_window``);
    a window-only result raises ValueError. scene_file, overrides: recorded in the
    provenance (the scene's file and its sha256; default: none, a scene from Python)."""

    if not isinstance(result, SimulationResult):
        refuse("save", "result", "a SimulationResult (what api.simulate returns)", result)
    check_path("save", "out", out)
    check_flag("save", "plots", plots)
    check_path("save", "scene_file", scene_file, optional=True)
    check_overrides("save", overrides)
    completed = result.stats.get("completed", result.ok)
    if completed and (len(result.time) == 0 or result.time[0] != 0.0):
        raise ArgumentError("api.save: the result holds the shown window only (keep_window=True): save needs the whole "
                         "run; use simulate_and_save, which streams result.csv as the run goes")
    stats = result.stats
    requested = {"algorithm": stats.get("algorithm"), "step": stats.get("step"), "tol": stats.get("tol")}
    out = Path(out)
    with result_set(out) as tmp:
        if completed:
            write_result_csv(result, tmp / "result.csv")
        _write_result_set(tmp, result, None if scene_file is None else Path(scene_file),
                          overrides_dict(overrides), requested, plots, None)
    return out


def _write_result_set(folder: Path, result: SimulationResult, scene_file: Path | None, overrides: dict[str, str],
                      requested: dict[str, Any], plots: bool, command: list[str] | None) -> None:
    """stats.json (and the plots) of a result set whose result.csv and columns.json are in
    ``folder``; a failed run's set is its stats.json alone."""

    stats = dict(result.stats)
    completed = stats.get("completed", result.ok)  # ran to the end (a run may complete short of a target)
    if completed:
        # the scene's metrics on its shown window; null where one does not apply (NaN)
        stats["metrics"] = {k: (v if v == v else None) for k, v in result_metrics(result).items()}
    settings = {"algorithm": stats.get("algorithm"), "step": stats.get("step"), "tol": stats.get("tol"),
                "requested": requested}
    stats["provenance"] = record(scene_file, overrides, settings, stats.get("fmus"), command=command)
    stats["scenario"] = to_dict(result.scenario)  # what was simulated, for 'tribofmu plot'
    (folder / "stats.json").write_text(json.dumps(stats, indent=2) + "\n")
    if not completed:  # a failed run leaves its stats (with the message), never a partial result
        (folder / "result.csv").unlink(missing_ok=True)
        (folder / SIDECAR_NAME).unlink(missing_ok=True)
    elif plots:  # drawn once the rows and stats are on disk, swapped in with them
        from .plots import plot_result  # matplotlib.pyplot: 538 ms at start-up (-X importtime, min of 5,
        # 2026-11-26 23:59 UTC, load 5.5) that a run without plots (every API call, the sweep's workers) skips
        plot_result(result, folder)


def fmu_calls_per_step(outcome) -> dict[str, Any] | None:
    """The stepping calls into the FMUs per accepted communication step of this run, in all
    (``total``) and by kind (get, set, doStep, save, restore, free); set-up calls (instantiate,
    parameters, initialization) are not counted. The runs of a check count apart
    (``stats["check"]["runs"]``)."""
    steps = outcome.counters["steps"]
    if not steps or not outcome.calls_by_kind:
        return None
    kinds = {kind: count / steps for kind, count in outcome.calls_by_kind.items()}
    return {"total": sum(kinds.values()), "by_kind": kinds}


def estimated_error(coupling, audit: WindowError, problem: str | None = None) -> dict[str, Any]:
    """The run's own propagated estimate of its nRMS(v) on the shown window, how it was made,
    and whether it can vouch for the run (``vouches``; ``problem``: why not, from
    :func:`own_estimate_problem`). An adaptive call reports it only where it vouches and meets
    tol with a margin; else the checked error (:mod:`tribofmu.checked`)."""
    if not hasattr(coupling, "estimate"):
        return {"nrms_v": None, "vouches": False,
                "method": "none: a fixed-step coupling estimates no error; use --algorithm adaptive, "
                          "or tribofmu accuracy"}
    value = audit.nrms()
    if problem is None and coupling.estimate.saturated:
        problem = "its carried error reached the motion's own size (past its linearisation)"
    if problem is None and getattr(coupling.estimate, "passed_event", False):
        problem = "a step at the shortest length passed over the lubricant's re-solidifying (an event)"
    near = getattr(coupling.estimate, "near_runaways", None)
    if problem is None and near is not None and near.undecided:
        problem = (f"it passed near a melt it did not take, by less than its own error in f (that "
                   f"error, with the estimate's margin, {near.ratio:.3g}x f's rise there): which way that "
                   "passage goes is past its linearisation (coupling/passages.py)")
    motion = ("the block's and the lubricant's linearised motion (the law's own slopes)"
              if getattr(coupling.estimate, "law", None) is not None else "the block's linearised motion")
    order = coupling.convergence_order() if hasattr(coupling, "convergence_order") else None
    return {"nrms_v": value if math.isfinite(value) else None, "vouches": problem is None, "order": order,
            "near_melt": near.ratio if near is not None else None,
            "method": f"propagated: the {coupling.name} coupling's local error estimates (and the "
                      f"friction's impulse misses) carried through {motion} to the "
                      "window, with the tenth of each that its step-size rule leaves unknown carried "
                      "beside them (coupling/estimate.py); "
                      + ("it vouches for the run (its derivation holds here)" if problem is None
                         else f"it cannot vouch for the run: {problem}")}


def inputs_vary(scenario: Scenario) -> bool:
    """Whether other FMUs (Thermal, Load) feed the friction's inputs T, n over the run."""
    return bool({"Thermal", "Load"} & set(scenario.fmus))


def own_estimate_problem(scenario: Scenario, varying: bool) -> str | None:
    """Why a run's carried estimate cannot vouch for a run of scenario (None: it can); see
    :func:`tribofmu.coupling.estimate.carry_problem`. varying: a Load or Thermal FMU feeds
    the friction (:func:`inputs_vary`)."""
    if "Friction" not in scenario.fmus:
        return None  # no friction: the block's own linear motion, which the carry follows exactly
    return carry_problem(scenario.friction.law(), varying)


def build_system(scenario: Scenario, slaves: dict) -> CoupledSystem:
    """The scene's :class:`~tribofmu.coupling.system.CoupledSystem` from its instances by FMU
    name (made with :func:`~tribofmu.scene.wiring.fmu_parameters`)."""
    friction = slaves.get("Friction")
    return CoupledSystem(block=slaves["BlockSpring"], drive=slaves.get("Drive"), friction=friction,
                         conditions=constant_inputs(scenario) if friction is not None else None,
                         load=slaves.get("Load"), thermal=slaves.get("Thermal"),
                         law=scenario.friction.law() if friction is not None else None)


def output_samples(scenario: Scenario) -> int:
    """The number of output intervals of the run; ScenarioError when past MAX_OUTPUT_SAMPLES."""
    n = max(1, math.ceil(round(scenario.time.periods * SAMPLES_PER_PERIOD, 6)))
    if n > MAX_OUTPUT_SAMPLES:
        raise ScenarioError(
            f"{scenario.source}: time.periods = {scenario.time.periods:g} asks for {n:.3g} output samples "
            f"({n * 8 * (len(SIGNALS) + 1) / 1e9:.3g} GB of results); at most {MAX_OUTPUT_SAMPLES:.0e} "
            f"({MAX_OUTPUT_SAMPLES // SAMPLES_PER_PERIOD} periods): simulate fewer periods")
    return n
