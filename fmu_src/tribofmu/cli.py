"""The ``tribofmu`` command: a thin layer over :mod:`tribofmu.api`.

The commands themselves are in :mod:`tribofmu.cli_commands`. The synopsis of every command
is its ``--help`` (the "Synopsis" of docs/cli.md is checked
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
import sys

from . import __version__
from .cli_checks import label_overrides, one_line  # noqa: F401 (label_overrides: cli.label_overrides, as before)
from .cli_commands import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_TOL_NOT_MET, quiet_from_now_on  # noqa: F401 (the exit codes)


def main(argv: list[str] | None = None) -> int:
    # first of all (before the parser and the imports of the first half second): Ctrl-C and
    # SIGTERM stop between steps, write nothing half, and say so in one line
    from .progress import install_signal_handlers, work_done
    install_signal_handlers()
    from .atomic import forget_published
    forget_published()  # what this command writes, for the Ctrl-C message
    try:
        parser = _parser()
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # said with the command's own usage line, not the top level's (exit 2)
            _subparsers(parser)[args.command].error(f"unrecognized arguments: {' '.join(unknown)}")
        from .forked_runs import check_workers
        check_workers()  # TRIBOFMU_CHECK_WORKERS, read by any run: wrong, it is said before any work
        from .master.fmu_files import remove_orphan_extractions
        atexit.register(remove_orphan_extractions)  # unzipped FMUs of finished (Dask) workers
        status = args.run(args)
        work_done()
        return status
    except BaseException as exc:
        if not _interrupted(exc):
            return _failure(exc)
        quiet_from_now_on()
        from .atomic import published
        done = published()
        if done:
            print(f"tribofmu: interrupted after writing {done[-1]}/ (complete); nothing else was written",
                  file=sys.stderr)
        else:
            print("tribofmu: interrupted; no result was written (earlier results are as they were)",
                  file=sys.stderr)
        return 130
    finally:
        from .cli_checks import release_out_locks
        release_out_locks()


def _interrupted(exc: BaseException) -> bool:
    """A Ctrl-C or SIGTERM: a KeyboardInterrupt, or an error it caused (one arriving while a
    class is made during an import comes back as RuntimeError "Error calling __set_name__")."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _failure(exc: BaseException) -> int:
    """Every expected failure as one line and its exit code, never a traceback; the rest raised."""
    from .errors import NumericalError, TriboFMUError
    if isinstance(exc, (TriboFMUError, FileNotFoundError, FileExistsError)):
        print(f"tribofmu: {one_line(exc)}", file=sys.stderr)
        return EXIT_FAILED if isinstance(exc, NumericalError) else EXIT_BAD_INPUT
    if isinstance(exc, OSError):  # a write that failed after the preflight: disk full, gone, ...
        print(f"tribofmu: {one_line(exc)}; earlier results are as they were", file=sys.stderr)
        return EXIT_FAILED
    raise exc


DESCRIPTION = """tribofmu: dry, fluid and boundary friction as FMI co-simulation FMUs.

SCENARIO is a shipped scene's name (list them with 'tribofmu scenes') or the path of a
.toml scene file. Bad input is one line on stderr and exit code 2, checked before
anything runs; a failed run exits 1; a run that completed but whose checked error is past
its --tol exits 3 (its result is kept and says so)."""

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
    from .cli_commands import (cmd_accuracy, cmd_build, cmd_export_ssp, cmd_figures, cmd_plot, cmd_scenes,
                               cmd_simulate, cmd_sweep)
    plain = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(prog="tribofmu", description=DESCRIPTION, epilog=_examples(None),
                                     formatter_class=plain)
    parser.add_argument("--version", action="version", version=f"tribofmu {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    fmu_help = "use the .fmu files in DIR (default: built from this source, in a per-user cache)"

    def command(name: str, summary: str, description: str | None = None):
        return sub.add_parser(name, help=summary, description=description or summary[0].upper() + summary[1:] + ".",
                              epilog=_examples(name), formatter_class=plain)

    from .fmu.registry import fmu_names
    p = command("build", f"build the FMUs ({', '.join(fmu_names())})")
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: the per-user FMU cache)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version of the co-simulation FMUs (default 2; 3 goes to its own cache folder)")
    p.set_defaults(run=cmd_build)

    p = command("simulate", "co-simulate a scene; result.csv, columns.json, stats.json, time.png, phase.png, friction.png")
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

    p = command("plot", "redraw time.png, phase.png and friction.png of a saved simulate result")
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
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: out/<scene name>--sweep)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="address of an existing Dask scheduler")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes (default: one per core; 0: no Dask, a plain loop)")
    _add_set(p)
    _add_algorithm(p)
    p.add_argument("--fmu-dir", default=None, metavar="DIR",
                   help="use these FMUs (default: the per-user cache, built from this source)")
    p.add_argument("--retry-failed", action="store_true", help="rerun the points sweep.csv has as failed")
    p.add_argument("--recompute", action="store_true",
                   help="rerun every point, whatever OUT holds (needed when OUT's sweep was computed with other FMUs)")
    p.add_argument("--timeout", type=float, default=None, metavar="S", help="per-point time limit [s]: then failed")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_sweep)

    p = command("accuracy", "error vs cost of every algorithm against the reference solution")
    p.add_argument("scenario", metavar="SCENARIO", help=SCENARIO_HELP)
    p.add_argument("--out", default=None, metavar="DIR", help="output directory (default: out/<scene name>[--<overrides>]--accuracy)")
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
    p.add_argument("--recompute", "--rerun", dest="recompute", action="store_true",
                   help="simulate every run again, whatever --data holds (--rerun: the same, its old name)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_figures)
    return parser


def _subparsers(parser) -> dict[str, argparse.ArgumentParser]:
    """Each command's own parser, by name."""
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def synopsis() -> list[str]:
    """One line per command, every option it takes: docs/cli.md's "Synopsis" block is this."""
    import argparse as ap
    lines = []
    for name, p in _subparsers(_parser()).items():
        words = [f"tribofmu {name}"]
        for action in p._actions:
            if isinstance(action, ap._HelpAction):
                continue
            if not action.option_strings:
                words.append(action.metavar or action.dest.upper())
                continue
            flag = max(action.option_strings, key=len)  # --quiet, not -q: the name says what it does
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


def _default_tol() -> float:
    from .api import DEFAULT_TOL
    return DEFAULT_TOL


def _figure_names() -> list[str]:
    from .figures import FIGURES
    return list(FIGURES)


def _add_set(p) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. drive.omega=80 (repeatable); a key the scene "
                        "does not use is an error")


def _add_algorithm(p) -> None:
    from .coupling.algorithms import ALGORITHMS
    names = list(ALGORITHMS)
    p.add_argument("--algorithm", default=None, metavar="NAME",
                   help=f"{', '.join(names[:-1])} or {names[-1]} (default: the scene's simulation.algorithm)")
    p.add_argument("--step", type=float, default=None, metavar="S",
                   help="communication step [s] (fixed-step algorithms; adaptive: the first step)")
    p.add_argument("--tol", type=float, default=None, metavar="TOL",
                   help="adaptive: the error the run must meet, the nRMS of v on the shown window relative "
                        "to its largest |v|, checked by runs at tighter per-step tolerances (default: the "
                        f"scene's simulation.tol, else {_default_tol():g}); past it the result is kept, exit 3")


if __name__ == "__main__":
    sys.exit(main())
