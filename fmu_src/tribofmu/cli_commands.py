"""The ``tribofmu`` commands, one function each (``cmd_<command>(args) -> exit code``), called
by :func:`tribofmu.cli.main` with the parsed arguments of :func:`tribofmu.cli._parser`."""
from __future__ import annotations

import json
import logging
import math
import signal
import sys
import threading
from pathlib import Path

from .cli_checks import (PLOT_BYTES, one_line, SSP_BYTES, SWEEP_POINT_BYTES, check_algorithm_options, claim_out,
                         check_number, check_out_file, label_overrides, output_folder,
                         preflight, preflight_folder, require, resolve_fmu_dir)
from .errors import UsageError


def quiet_from_now_on() -> None:
    """After the one line of an interruption: a second Ctrl-C or SIGTERM while the process
    shuts down (Dask's cluster, atexit handlers) ends it silently, and what libraries still
    log or fail to clean up at exit (Dask: CommClosedError, 'Nanny failed to start') is not
    printed: the line said what happened."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            signal.signal(sig, signal.SIG_IGN)
        except (ValueError, OSError):  # not the main thread
            pass
    logging.disable(logging.CRITICAL)
    sys.unraisablehook = lambda unraisable: None  # "Exception ignored in atexit callback"
    sys.excepthook = lambda *exc: None  # a late exception at shutdown
    threading.excepthook = lambda args: None  # one in a thread (Dask's event loop)


EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_TOL_NOT_MET = 3  # the run completed and its result is kept, but its checked error is past --tol


def cmd_build(args) -> int:
    from .build import build_fmus
    from .fmu_cache import BUILD_BYTES, find_fmus
    from .fmu.registry import fmu_names
    if args.out is None:  # the cache: rebuilt, with the hashes it checks recorded
        folder = find_fmus(fmu_names(), None, fmi=args.fmi, build=True)
        paths = [folder / f"{name}.fmu" for name in fmu_names()]
    else:
        claim_out(Path(args.out), "build", BUILD_BYTES)
        paths = build_fmus(args.out, fmi=args.fmi)
    for path in paths:
        print(path)
    return 0


def cmd_simulate(args) -> int:
    from . import api
    from .progress import RunBar, work_done
    from .result_csv import expected_bytes
    from .scene.library import resolve_scene

    scene_file = resolve_scene(args.scenario)
    scenario = api.load(scene_file, args.overrides)
    check_algorithm_options(scenario, args.algorithm, args.step, args.tol, args.max_wall)
    out = Path(args.out) if args.out else output_folder(scenario.name, label_overrides(
        args.overrides, args.algorithm, args.step, args.tol, args.max_wall, args.fmi,
        scenario=scenario, base=api.load(scene_file) if args.overrides else scenario))
    samples = api.output_samples(scenario) + 1
    preflight(out, expected_bytes(scenario, samples) + (0 if args.no_plots else PLOT_BYTES))
    fmu_dir = resolve_fmu_dir(args.fmu_dir, scenario.fmus, args.quiet, args.fmi)
    quiet = True if args.quiet else None
    # the API's own call writes the set (swapped in whole when done; untouched on failure or
    # Ctrl-C); it enters the bar (Ctrl-C deferred to the next communication point) around the run
    bar = RunBar(scenario.name, scenario.stop_time, enabled=False if quiet else None)
    try:
        result = api.simulate_and_save(
            scene_file, out, args.overrides, algorithm=args.algorithm, step=args.step, tol=args.tol,
            fmu_dir=fmu_dir, build=False, plots=not args.no_plots, progress=bar, notice=bar.notice,
            max_wall=api.SCENE_MAX_WALL if args.max_wall is None else args.max_wall, command=["tribofmu", *sys.argv[1:]])
    finally:
        bar.close()  # also when the call failed before the run began
    work_done()  # the result set is complete (or the failure is known): what follows only says so
    estimate = result.stats["estimated_error"]["nrms_v"]
    method = result.stats["estimated_error"].get("method", "")
    checked, own = method.startswith("checked"), method.startswith("own")  # own: one run vouched for itself
    runs = len(result.stats.get("check", {}).get("runs", ())) or 1
    vouched = ("one run: its own estimate vouches" if runs == 1 else
               f"{runs} runs: the last one's own estimate vouches")
    accuracy = (f", {'checked' if checked else 'estimated'} nRMS(v) {estimate:.2g}"
                + (f" (tol {result.stats['tol']:g})" if checked else
                   f" (tol {result.stats['tol']:g}, {vouched})" if own else "")
                ) if estimate is not None else ""
    print(f"{scenario.name}: {result.message}; {result.stats['communication_steps']} steps, "
          f"{result.stats['wall_time']:.2f} s{accuracy} -> {out}/")
    if not result.stats.get("completed", result.ok):
        print(f"tribofmu: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    if not result.ok:  # completed, kept, but short of its tolerance: one line, exit 3
        print(f"tribofmu: {result.message}", file=sys.stderr)
        return EXIT_TOL_NOT_MET
    return 0


def cmd_plot(args) -> int:
    """Redraw a saved result from its result.csv and the scenario recorded in stats.json."""
    from .columns import read_result_csv
    from .errors import TriboFMUError
    from .plots import plot_signals
    from .scene.scenario import from_dict
    folder = Path(args.result_dir)
    csv, stats_file = folder / "result.csv", folder / "stats.json"
    for path in (csv, stats_file):
        if not path.is_file():
            raise UsageError(f"{folder}: no {path.name} here (a folder written by 'tribofmu simulate')")
    try:
        stats = json.loads(stats_file.read_text(encoding="utf-8"))
        data = stats["scenario"]
    except (ValueError, KeyError, TypeError):
        raise UsageError(f"{stats_file}: no scenario recorded (written by an older tribofmu: "
                         "simulate again)") from None
    except OSError as exc:
        raise UsageError(f"{stats_file}: cannot be read ({exc.strerror or exc})") from None
    if not (isinstance(data, dict) and all(isinstance(v, dict) for v in data.values())):
        raise UsageError(f"{stats_file}: its \"scenario\" is not a recorded scenario (a table of "
                         f"tables), got {json.dumps(data)[:60]}")
    try:
        scenario = from_dict(data, stats_file.name)
    except TriboFMUError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise UsageError(f"{stats_file}: its \"scenario\" cannot be read ({one_line(exc)})") from None
    try:
        signals = read_result_csv(csv)
    except ValueError as exc:
        raise UsageError(f"{csv}: not a result table ({exc})") from None
    missing = [k for k in ("time", "X", "V", "x", "v") if k not in signals]
    if missing:
        raise UsageError(f"{csv}: no column {missing[0]!r}")
    out = claim_out(Path(args.out), "plot", PLOT_BYTES, also=("simulate",)) if args.out else folder
    out.mkdir(parents=True, exist_ok=True)
    for path in plot_signals(signals, scenario, out):
        print(path)
    return 0


def cmd_scenes(args) -> int:
    from .scene.library import scene_names, scene_path, scene_summary
    names = scene_names()
    width = max(map(len, names))
    for name in names:
        print(f"{name:<{width}}  {scene_summary(scene_path(name))}")
    return 0


def cmd_export_ssp(args) -> int:
    from . import api
    from .scene.ssp import archive_step, check_replaceable_archive, export_ssp
    from .scene.wiring import instances
    scenario = api.load(args.scenario, args.overrides)  # a shipped scene's name or a path
    out = check_out_file(Path(args.out))
    try:  # never replaces a file it did not write (exit 2, before any build)
        check_replaceable_archive(out)
    except FileExistsError as exc:
        raise UsageError(f"--out {exc}") from None
    names = [inst.fmu.name for inst in instances(scenario, args.pair)]  # a scene the pair cannot take: exit 2
    preflight_folder(out.parent, SSP_BYTES)
    fmu_dir = resolve_fmu_dir(args.fmu_dir, names)
    path = export_ssp(scenario, out, fmu_dir, pair=args.pair)
    print(path)
    for line in run_lines(path, scenario.stop_time, archive_step(scenario, args.pair)):
        print(line)
    return 0


def run_lines(path: Path, stop: float, step: float) -> list[str]:
    """What to run an archive with: its stop time [s] and step [s], and the OMSimulator and
    fmpy command lines that run it to the stop time exactly. OMSimulator takes the stop time
    from --stopTime only (the step from the archive) and ends its last step on it; fmpy's
    simulate_ssp takes whole steps while time < stop_time, so it gets a step that divides
    the stop time (n steps of stop / n) and a stop_time half a step short of the end."""
    import shlex
    n = math.ceil(stop / step * (1 - 1e-12))
    h = stop / n
    name = shlex.quote(str(path))
    fmpy = (f"from fmpy.ssp.simulation import simulate_ssp; r = simulate_ssp({str(path)!r}, "
            f"stop_time={(n - 0.5) * h!r}, step_size={h!r}); print(r['time'][-1] + {h!r})")
    def quoted(code: str) -> str:  # in double quotes where the shell leaves it as it is
        return f'"{code}"' if not any(c in code for c in '"$`\\!') else shlex.quote(code)
    return [f"stop time {stop!r} s, step {step:g} s ({n} steps); to run it to the stop time:",
            f"  OMSimulator {name} --resultFile={shlex.quote(path.stem + '.csv')} --stopTime={stop!r}",
            f"  python -c {quoted(fmpy)}   # fmpy: {n} steps of stop/{n} = {h:.6g} s; rows stamped "
            "with their step's start"]


def cmd_sweep(args) -> int:
    """Exit 0 when every point is ok, 1 when some failed (see their rows), 2 on bad input."""
    from . import api
    from .progress import work_done
    from .studies.sweep import parse_grid, sweep
    require("tqdm", "tqdm", "tribofmu sweep")
    if args.workers != 0:
        require("distributed", "dask[distributed]", "tribofmu sweep on Dask (--workers 0 runs without)")
    from .scene.library import resolve_scene
    scene_file = resolve_scene(args.scenario)
    scenario = api.load(scene_file, args.overrides)
    check_algorithm_options(scenario, args.algorithm, args.step, args.tol)
    check_number("--timeout", args.timeout)
    out = Path(args.out) if args.out else output_folder(scene_file.stem, {}, "--sweep", "the scenario file's name")
    grid = parse_grid(args.grid)
    points = math.prod(len(values) for values in grid.values())
    claim_out(out, "sweep", points * SWEEP_POINT_BYTES + (0 if args.no_plots else PLOT_BYTES))
    try:
        rows = sweep(scene_file, grid, out, scheduler=args.scheduler,
                     workers=args.workers, overrides=args.overrides, algorithm=args.algorithm,
                     step=args.step, tol=args.tol, fmu_dir=args.fmu_dir,
                     retry_failed=args.retry_failed, recompute=args.recompute, timeout=args.timeout,
                     plots=not args.no_plots,
                     progress=not args.quiet and sys.stderr.isatty(),
                     log=(lambda message: None) if args.quiet else None)  # --quiet: nothing on stderr
    except KeyboardInterrupt:
        quiet_from_now_on()
        from .studies.sweep.store import STAGING_NAME
        if args.recompute and (out / STAGING_NAME).is_dir():
            print(f"tribofmu: sweep interrupted; the earlier sweep in {out}/ is as it was, the "
                  f"recompute's finished points are kept aside: rerun the same command to resume it",
                  file=sys.stderr)
        else:
            print(f"tribofmu: sweep interrupted; finished points are in {out}/sweep.csv, "
                  "rerun the same command to resume", file=sys.stderr)
        return 130
    work_done()  # sweep.csv holds every point: what follows only says so
    print(f"{len(rows)} points: {len(rows) - rows.failed} ok, {rows.failed} failed "
          f"({rows.computed} run, {rows.skipped} already done), {rows.elapsed:.1f} s -> {out}/")
    return EXIT_FAILED if rows.failed else 0


def cmd_accuracy(args) -> int:
    from . import api
    from .studies.accuracy import accuracy_study, write_study
    from .progress import check_interrupt, deferred_interrupts
    from .atomic import ACCURACY_NAMES, check_replaceable
    from .provenance import overrides_dict
    scenario = api.load(args.scenario, args.overrides)
    out = Path(args.out) if args.out else output_folder(scenario.name, overrides_dict(args.overrides),
                                                        "--accuracy")
    preflight_folder(out.absolute().parent, PLOT_BYTES)
    try:
        check_replaceable(out, ACCURACY_NAMES)
    except FileExistsError as exc:
        raise UsageError(f"--out {exc}") from None
    fmu_dir = resolve_fmu_dir(args.fmu_dir, scenario.fmus, args.quiet)
    def log(message: str) -> None:  # called between runs: where a Ctrl-C may stop the study
        if not args.quiet:
            print(message, file=sys.stderr)
        check_interrupt()
    with deferred_interrupts():  # never inside FMU code (pythonfmu would make it fmi2Fatal)
        rows, summary = accuracy_study(scenario, fmu_dir=fmu_dir, quick=args.quick, log=log,
                                       progress=lambda status: check_interrupt())
    write_study(rows, summary, scenario, out)
    print(f"{len(rows)} runs, {summary['total_wall_time_s']:.1f} s -> {out}/")
    return 0


def cmd_figures(args) -> int:
    from .figures import FIGURES, make_figures
    only = None
    if args.only:
        only = [name.strip() for name in args.only.split(",") if name.strip()]
        unknown = [name for name in only if name not in FIGURES]
        if unknown or not only:
            raise UsageError(f"--only {args.only}: unknown figure {unknown[0] if unknown else '(none)'!r} "
                             f"(known: {', '.join(FIGURES)})")
    out = claim_out(Path(args.out), "figures", 12 * PLOT_BYTES)
    if args.data:
        claim_out(Path(args.data), "figures", PLOT_BYTES, "--data")
    written: list[Path] = []  # each figure and saved run as it is complete (for a Ctrl-C's message)
    try:
        paths = make_figures(out, only=only, scenarios_dir=args.scenarios, fmu_dir=args.fmu_dir,
                             rerun=args.recompute, quiet=args.quiet, data_dir=args.data, written=written)
    except KeyboardInterrupt:
        quiet_from_now_on()
        if not written:
            raise  # nothing written: main's own line says so
        print(f"tribofmu: figures interrupted after writing {len(written)} complete file(s) "
              f"({', '.join(p.name for p in written)}); none is half written, and the same command "
              "finishes the rest (the saved runs are reused)", file=sys.stderr)
        return 130
    for path in paths:
        print(path)
    return 0


