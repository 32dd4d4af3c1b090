"""The ``tribofmu`` command: a thin layer over :mod:`tribofmu.api`.

The synopsis of every command is its ``--help`` (the "Synopsis" of docs/cli.md is checked
against this parser by tests/integration/test_user_sees.py).

FMUs: ``--fmu-dir DIR`` uses the FMUs in DIR (they must exist); without it the FMUs built
from the installed source are found in (or built once into) a per-user cache, whatever
the working directory. Bad input (a scenario key, a value, an option that does not apply,
a missing FMU, an output path that is a file) is one line on stderr and exit code 2,
checked before anything runs; results are written whole or not at all.
"""
from __future__ import annotations

import argparse
import atexit
import json
import math
import sys
from pathlib import Path

from . import __version__
from .cli_checks import (PLOT_BYTES, one_line, SSP_BYTES, SWEEP_POINT_BYTES, check_algorithm_options,
                         check_number, check_out_dir, check_out_file, label_overrides, output_folder,
                         preflight, preflight_folder, require, resolve_fmu_dir)
from .errors import UsageError

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_TOL_NOT_MET = 3  # the run completed and its result is kept, but its checked error is past --tol


def main(argv: list[str] | None = None) -> int:
    # first of all (before the parser and the imports of the first half second): Ctrl-C and
    # SIGTERM stop between steps, write nothing half, and say so in one line
    from .progress import install_signal_handlers, work_done
    install_signal_handlers()
    from .atomic import forget_published
    forget_published()  # what this command writes, for the Ctrl-C message
    try:
        parser = _parser()
        args = parser.parse_args(argv)
        from .master.instance import remove_orphan_extractions
        atexit.register(remove_orphan_extractions)  # unzipped FMUs of finished (Dask) workers
        status = args.run(args)
        work_done()
        return status
    except KeyboardInterrupt:
        _quiet_from_now_on()
        from .atomic import published
        done = published()
        if done:
            print(f"tribofmu: interrupted after writing {done[-1]}/ (complete); nothing else was written",
                  file=sys.stderr)
        else:
            print("tribofmu: interrupted; no result was written (earlier results are as they were)",
                  file=sys.stderr)
        return 130
    except Exception as exc:  # every expected failure becomes one line, never a traceback
        from .errors import NumericalError, TriboFMUError
        if isinstance(exc, (TriboFMUError, FileNotFoundError, FileExistsError)):
            print(f"tribofmu: {one_line(exc)}", file=sys.stderr)
            return EXIT_FAILED if isinstance(exc, NumericalError) else EXIT_BAD_INPUT
        if isinstance(exc, OSError):  # a write that failed after the preflight: disk full, gone, ...
            print(f"tribofmu: {one_line(exc)}; earlier results are as they were", file=sys.stderr)
            return EXIT_FAILED
        raise
    finally:
        from .cli_checks import release_out_locks
        release_out_locks()


def _quiet_from_now_on() -> None:
    """After the one line of an interruption: a second Ctrl-C or SIGTERM while the process
    shuts down (Dask's cluster, atexit handlers) ends it silently, and what libraries still
    log or fail to clean up at exit (Dask: CommClosedError, 'Nanny failed to start') is not
    printed: the line said what happened."""
    import logging
    import signal
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            signal.signal(sig, signal.SIG_IGN)
        except (ValueError, OSError):  # not the main thread
            pass
    logging.disable(logging.CRITICAL)
    sys.unraisablehook = lambda unraisable: None  # "Exception ignored in atexit callback"
    sys.excepthook = lambda *exc: None  # a late exception at shutdown
    import threading
    threading.excepthook = lambda args: None  # one in a thread (Dask's event loop)


DESCRIPTION = """tribofmu: dry, fluid and boundary friction as FMI co-simulation FMUs.

SCENARIO is a shipped scene's name (list them with 'tribofmu scenes') or the path of a
.toml scene file. Bad input is one line on stderr and exit code 2, checked before
anything runs; a failed run exits 1."""

EXAMPLES = {
    None: ["tribofmu scenes", "tribofmu simulate fig2_dry", "tribofmu figures",
           "tribofmu <command> --help"],
    "build": ["tribofmu build", "tribofmu build --out fmus --fmi 3"],
    "simulate": ["tribofmu simulate fig2_dry",
                 "tribofmu simulate fig2_dry --set drive.omega=80 --no-plots",
                 "tribofmu simulate my_scene.toml --algorithm jacobi --step 1e-4 --out out/mine"],
    "plot": ["tribofmu plot out/fig2_dry"],
    "scenes": ["tribofmu scenes"],
    "export-ssp": ["tribofmu export-ssp fig2_dry --out fig2.ssp",
                   "tribofmu export-ssp fig2_dry --out fig2_pair.ssp --pair"],
    "sweep": ["tribofmu sweep fig2_dry --grid drive.omega=10,20,30,50,80,130 --workers 0",
              "tribofmu sweep fig2_dry --grid drive.omega=30,80 --grid conditions.n=-10,-20"],
    "accuracy": ["tribofmu accuracy fig2_dry --quick"],
    "figures": ["tribofmu figures", "tribofmu figures --only fig2,fig4 --out out/figs"],
}
SCENARIO_HELP = ("a shipped scene's name (see 'tribofmu scenes', e.g. fig2_dry) "
                 "or the path of a .toml scene file")


def _examples(command: str | None) -> str:
    return "example" + ("s" if len(EXAMPLES[command]) > 1 else "") + ":\n" + "\n".join(
        f"  {line}" for line in EXAMPLES[command])


def _parser() -> argparse.ArgumentParser:
    plain = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(prog="tribofmu", description=DESCRIPTION, epilog=_examples(None),
                                     formatter_class=plain)
    parser.add_argument("--version", action="version", version=f"tribofmu {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    fmu_help = "use the .fmu files in DIR (default: built from this source, in a per-user cache)"

    def command(name: str, summary: str, description: str | None = None):
        return sub.add_parser(name, help=summary, description=description or summary[0].upper() + summary[1:] + ".",
                              epilog=_examples(name), formatter_class=plain)

    from .scene.wiring import fmu_names
    p = command("build", f"build the FMUs ({', '.join(fmu_names())})")
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: the per-user FMU cache)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version of the co-simulation FMUs (default 2; 3 goes to its own cache folder)")
    p.set_defaults(run=cmd_build)

    p = command("simulate", "co-simulate a scene; result.csv, columns.json, stats.json, time.png, phase.png")
    p.add_argument("scenario", metavar="SCENARIO", help=SCENARIO_HELP)
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output directory (default: out/<scene name>[--<overrides>])")
    _add_set(p)
    _add_algorithm(p)
    p.add_argument("--max-wall", type=float, default=None, metavar="S",
                   help="stop a run whose projected wall time exceeds S seconds (0: no limit; "
                        "default: the scene's simulation.max_wall, 1800)")
    p.add_argument("--fmu-dir", default=None, metavar="DIR", help=fmu_help)
    p.add_argument("--fmi", type=int, choices=(2, 3), default=None,
                   help="run FMI 2.0 (default) or FMI 3.0 FMUs; with --fmu-dir, the FMUs there must be of it")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures (draw them later with 'tribofmu plot DIR')")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_simulate)

    p = command("plot", "redraw time.png and phase.png of a saved simulate result")
    p.add_argument("result_dir", metavar="DIR", help="a folder written by 'tribofmu simulate' (result.csv, stats.json)")
    p.add_argument("--out", default=None, metavar="DIR", help="where to write the PNGs (default: DIR)")
    p.set_defaults(run=cmd_plot)

    p = command("scenes", "list the shipped scenes, one line each")
    p.set_defaults(run=cmd_scenes)

    p = command("export-ssp", "write a scene's coupled system as an SSP 1.0 archive")
    p.add_argument("scenario", metavar="SCENARIO", help=SCENARIO_HELP)
    p.add_argument("--out", required=True, metavar="FILE.ssp", help="the .ssp file to write")
    _add_set(p)
    p.add_argument("--pair", action="store_true",
                   help="replace BlockSpring and Friction by TriboPair.fmu, which couples them implicitly "
                        "inside itself (stick right in masters that exchange values once per step)")
    p.add_argument("--fmu-dir", default=None, metavar="DIR", help=fmu_help)
    p.set_defaults(run=cmd_export_ssp)

    p = command("sweep", "run a grid of overrides on Dask; sweep.csv, regime maps")
    p.add_argument("scenario", metavar="SCENARIO", help=SCENARIO_HELP)
    p.add_argument("--grid", action="append", default=[], required=True, metavar="KEY=V1,V2,...",
                   help="swept values of a scenario key (repeatable: the cartesian product)")
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: out/<scene name>-sweep)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="address of an existing Dask scheduler")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: one per core; 0: no Dask, a plain loop)")
    _add_set(p)
    _add_algorithm(p)
    p.add_argument("--fmu-dir", default=None, metavar="DIR",
                   help="use these FMUs (default: the per-user cache, built from this source)")
    p.add_argument("--retry-failed", action="store_true", help="rerun the points sweep.csv has as failed")
    p.add_argument("--recompute", action="store_true",
                   help="rerun every point (needed when OUT's sweep was computed with other FMUs)")
    p.add_argument("--timeout", type=float, default=None, metavar="S", help="per-point time limit [s]: then failed")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_sweep)

    p = command("accuracy", "error vs cost of every algorithm against the reference solution")
    p.add_argument("scenario", metavar="SCENARIO", help=SCENARIO_HELP)
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: out/<scene name>-accuracy)")
    _add_set(p)
    p.add_argument("--quick", action="store_true", help="a shorter ladder of steps and tolerances")
    p.add_argument("--fmu-dir", default=None, metavar="DIR", help=fmu_help)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(run=cmd_accuracy)

    p = command("figures", "the paper's Figs. 2-6 from the shipped scenes, one PNG per figure")
    p.add_argument("--out", default="out/figures", metavar="DIR", help="output directory (default: out/figures)")
    p.add_argument("--only", default=None, metavar="FIG,...",
                   help="a comma-separated subset of " + ",".join(_figure_names()) +
                        " (default: the paper's fig2-fig6 and friction, the friction force and loops of their scenes; tn_map, the boundary film's T x n map, only when named)")
    p.add_argument("--scenarios", default=None, metavar="DIR",
                   help="a folder of scene files to use instead of the shipped ones")
    p.add_argument("--fmu-dir", default=None, metavar="DIR", help=fmu_help)
    p.add_argument("--data", default=None, metavar="DIR",
                   help="where the runs' results are kept for reuse (default: OUT/data)")
    p.add_argument("--rerun", action="store_true", help="simulate again even where saved results match")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_figures)
    return parser


def synopsis() -> list[str]:
    """One line per command, every option it takes: docs/cli.md's "Synopsis" block is this."""
    import argparse as ap
    parser = _parser()
    sub = next(a for a in parser._actions if isinstance(a, ap._SubParsersAction))
    lines = []
    for name, p in sub.choices.items():
        words = [f"tribofmu {name}"]
        for action in p._actions:
            if isinstance(action, ap._HelpAction):
                continue
            if not action.option_strings:
                words.append(action.metavar or action.dest.upper())
                continue
            flag = max(action.option_strings, key=len) if action.option_strings[0].startswith("--") \
                else action.option_strings[0]
            if action.nargs == 0:
                text = flag
            else:
                value = action.metavar or "{" + ",".join(map(str, action.choices)) + "}" \
                    if action.metavar or action.choices else action.dest.upper()
                text = f"{flag} {value}"
            repeat = isinstance(action, ap._AppendAction)
            if action.required:
                words.append(text + (f" [{flag} ...]" if repeat else ""))
            else:
                words.append(f"[{text}{' ...' if repeat else ''}]")
        lines.append(" ".join(words))
    return lines


def _figure_names() -> list[str]:
    from .figures import FIGURES
    return list(FIGURES)


def _add_set(p) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. drive.omega=80 (repeatable); a key the scene "
                        "does not use is an error")


def _add_algorithm(p) -> None:
    p.add_argument("--algorithm", default=None, metavar="NAME",
                   help="jacobi, gauss-seidel, implicit or adaptive (default: the scene's)")
    p.add_argument("--step", type=float, default=None, metavar="S",
                   help="communication step [s] (fixed-step algorithms; adaptive: the first step)")
    p.add_argument("--tol", type=float, default=None, metavar="TOL", help="tolerance of the adaptive algorithm")


# -- commands -------------------------------------------------------------------------------
def cmd_build(args) -> int:
    from .build import build_fmus
    from .fmu_cache import BUILD_BYTES, find_fmus
    from .scene.wiring import fmu_names
    if args.out is None:  # the cache: rebuilt, with the hashes it checks recorded
        folder = find_fmus(fmu_names(), None, fmi=args.fmi, build=True)
        paths = [folder / f"{name}.fmu" for name in fmu_names()]
    else:
        preflight_folder(Path(args.out), BUILD_BYTES)
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
            max_wall=-1.0 if args.max_wall is None else args.max_wall, command=["tribofmu", *sys.argv[1:]])
    finally:
        bar.close()  # also when the call failed before the run began
    work_done()  # the result set is complete (or the failure is known): what follows only says so
    estimate = result.stats["estimated_error"]["nrms_v"]
    checked = result.stats["estimated_error"].get("method", "").startswith("checked")
    accuracy = (f", {'checked' if checked else 'estimated'} nRMS(v) {estimate:.2g}"
                + (f" (tol {result.stats['tol']:g})" if checked else "")) if estimate is not None else ""
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
    out = check_out_dir(Path(args.out)) if args.out else folder
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
    out = Path(args.out) if args.out else output_folder(scene_file.stem, {}, "-sweep", "the scenario file's name")
    grid = parse_grid(args.grid)
    points = math.prod(len(values) for values in grid.values())
    preflight_folder(out, points * SWEEP_POINT_BYTES + (0 if args.no_plots else PLOT_BYTES))
    try:
        rows = sweep(scene_file, grid, out, scheduler=args.scheduler,
                     workers=args.workers, overrides=args.overrides, algorithm=args.algorithm,
                     step=args.step, tol=args.tol, fmu_dir=args.fmu_dir,
                     retry_failed=args.retry_failed, recompute=args.recompute, timeout=args.timeout,
                     plots=not args.no_plots,
                     progress=not args.quiet and sys.stderr.isatty())
    except KeyboardInterrupt:
        _quiet_from_now_on()
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
                                                        "-accuracy")
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
    out = check_out_dir(Path(args.out))
    preflight_folder(out, 12 * PLOT_BYTES)
    if args.data:
        check_out_dir(Path(args.data), "--data")
    paths = make_figures(out, only=only, scenarios_dir=args.scenarios, fmu_dir=args.fmu_dir,
                         rerun=args.rerun, quiet=args.quiet, data_dir=args.data)
    for path in paths:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
