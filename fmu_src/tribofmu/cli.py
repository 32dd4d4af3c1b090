"""The ``tribofmu`` command: a thin layer over :mod:`tribofmu.api`.

    tribofmu build [--out DIR] [--fmi {2,3}]
    tribofmu simulate SCENARIO [--out DIR] [--set KEY=VALUE ...] [--algorithm NAME] [--step S] [--tol TOL] [--max-wall S] [--fmi {2,3}]
    tribofmu export-ssp SCENARIO --out FILE.ssp [--set KEY=VALUE ...] [--pair] [--fmu-dir DIR]
    tribofmu accuracy SCENARIO [--out DIR] [--set KEY=VALUE ...] [--quick]
    tribofmu sweep SCENARIO --grid KEY=V1,V2,... [--grid ...] [--out DIR] [--scheduler ADDR] [--workers N]
    tribofmu figures [--out DIR] [--only fig2,fig4,...]

FMUs: ``--fmu-dir DIR`` uses the FMUs in DIR (they must exist); without it the FMUs built
from the installed source are found in (or built once into) a per-user cache, whatever
the working directory. Bad input (a scenario key, a value, an option that does not apply,
a missing FMU, an output path that is a file) is one line on stderr and exit code 2,
checked before anything runs; results are written whole or not at all.
"""
from __future__ import annotations

import argparse
import atexit
import importlib.util
import json
import sys
from pathlib import Path

from . import __version__

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
CSV_COLUMNS = ("X", "V", "x", "v", "F", "f")
# Files a simulate run writes; a new run removes the ones it does not write (a failed run
# writes only stats.json), so an older run's results never sit beside a newer stats.json.
RUN_OUTPUTS = ("stats.json", "result.csv", "time.png", "phase.png", "kinetics.png")


class UsageError(Exception):
    """Bad input from the command line: reported as one line, exit code 2."""


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    from .master.instance import remove_orphan_extractions
    from .progress import install_signal_handlers
    install_signal_handlers()  # Ctrl-C and SIGTERM: stop between steps, write nothing half
    atexit.register(remove_orphan_extractions)  # unzipped FMUs of finished (Dask) workers
    try:
        return args.run(args)
    except KeyboardInterrupt:
        print("tribofmu: interrupted; nothing was written", file=sys.stderr)
        return 130
    except Exception as exc:  # every expected failure becomes one line, never a traceback
        from .errors import NumericalError, TriboFMUError
        if isinstance(exc, (UsageError, TriboFMUError, FileNotFoundError)):
            print(f"tribofmu: {exc}", file=sys.stderr)
            return EXIT_FAILED if isinstance(exc, NumericalError) else EXIT_BAD_INPUT
        raise


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tribofmu", description=__doc__.split("\n")[0])
    parser.add_argument("--version", action="version", version=f"tribofmu {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    fmu_help = "use the .fmu files in DIR (default: built from this source, in a per-user cache)"

    p = sub.add_parser("build", help="build the FMUs (Friction, Drive, BlockSpring, Thermal, Load, TriboPair)")
    p.add_argument("--out", default=None, help="output directory (default: the per-user FMU cache)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                   help="FMI version of the co-simulation FMUs (default 2; 3 goes to its own cache folder)")
    p.set_defaults(run=cmd_build)

    p = sub.add_parser("simulate", help="co-simulate a scenario")
    p.add_argument("scenario")
    p.add_argument("--out", default=None,
                   help="output directory (default: out/<scenario name>[--<overrides>])")
    _add_set(p)
    _add_algorithm(p)
    p.add_argument("--max-wall", type=float, default=None, metavar="S",
                   help="stop a run whose projected wall time exceeds S seconds (0: no limit; "
                        "default: the scene's simulation.max_wall, 1800)")
    p.add_argument("--fmu-dir", default=None, help=fmu_help)
    p.add_argument("--fmi", type=int, choices=(2, 3), default=None,
                   help="run FMI 2.0 (default) or FMI 3.0 FMUs; with --fmu-dir, the FMUs there must be of it")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_simulate)

    p = sub.add_parser("export-ssp", help="write the scenario's coupled system as an SSP 1.0 archive")
    p.add_argument("scenario")
    p.add_argument("--out", required=True, help="the .ssp file to write")
    _add_set(p)
    p.add_argument("--pair", action="store_true",
                   help="replace BlockSpring and Friction by TriboPair.fmu, which couples them implicitly "
                        "inside itself (stick right in masters that exchange values once per step)")
    p.add_argument("--fmu-dir", default=None, help=fmu_help)
    p.set_defaults(run=cmd_export_ssp)

    p = sub.add_parser("sweep", help="run a grid of overrides on Dask; sweep.csv, regime maps")
    p.add_argument("scenario")
    p.add_argument("--grid", action="append", default=[], required=True, metavar="KEY=V1,V2,...",
                   help="swept values of a scenario key (repeatable: the cartesian product)")
    p.add_argument("--out", default=None, help="output directory (default: out/<scenario name>-sweep)")
    p.add_argument("--scheduler", default=None, help="address of an existing Dask scheduler")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: one per core; 0: no Dask, a plain loop)")
    _add_set(p)
    _add_algorithm(p)
    p.add_argument("--fmu-dir", default=None, help="use these FMUs (default: build into OUT/fmus)")
    p.add_argument("--retry-failed", action="store_true", help="rerun the points sweep.csv has as failed")
    p.add_argument("--timeout", type=float, default=None, help="per-point time limit [s]: then failed")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_sweep)

    p = sub.add_parser("accuracy", help="error vs cost of every algorithm against the reference solution")
    p.add_argument("scenario")
    p.add_argument("--out", default=None, help="output directory (default: out/<scenario name>-accuracy)")
    _add_set(p)
    p.add_argument("--quick", action="store_true", help="a shorter ladder of steps and tolerances")
    p.add_argument("--fmu-dir", default=None, help=fmu_help)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(run=cmd_accuracy)

    p = sub.add_parser("figures", help="the paper's Figs. 2-6 from the scenes, one PNG per figure")
    p.add_argument("--out", default="out/figures", help="output directory (default: out/figures)")
    p.add_argument("--only", default=None, metavar="FIG,...",
                   help="a comma-separated subset of fig2,fig3,fig4,fig5,fig6")
    p.add_argument("--scenarios", default=None, help="the scenes' folder (default: the repository's)")
    p.add_argument("--fmu-dir", default=None, help=fmu_help)
    p.add_argument("--data", default=None, help="where the runs' results are kept for reuse (default: OUT/data)")
    p.add_argument("--rerun", action="store_true", help="simulate again even where saved results match")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=cmd_figures)
    return parser


def _add_set(p) -> None:
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. drive.omega=80 (repeatable)")


def _add_algorithm(p) -> None:
    p.add_argument("--algorithm", default=None, help="jacobi, gauss-seidel, implicit, adaptive")
    p.add_argument("--step", type=float, default=None,
                   help="communication step [s] (fixed-step algorithms; adaptive: the first step)")
    p.add_argument("--tol", type=float, default=None, help="tolerance of the adaptive algorithm")


# -- checks made before anything runs ----------------------------------------------------------
def check_out_dir(path: Path, option: str = "--out") -> Path:
    """A folder to write into: it and its parents must not be files."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            if not candidate.is_dir():
                raise UsageError(f"{option} {path}: {candidate} is a file, not a folder")
            break
    return path


def check_out_file(path: Path, option: str = "--out") -> Path:
    """A file to write: not a folder, and its parents not files."""
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a folder, not a file")
    check_out_dir(path.parent, option)
    return path


def check_algorithm_options(scenario, algorithm: str | None, step: float | None, tol: float | None,
                            max_wall: float | None = None) -> str:
    """The algorithm that will run; a --step/--tol it does not use is an error."""
    from .coupling.algorithms import ALGORITHMS
    for name, value in (("--step", step), ("--tol", tol)):
        if value is not None and not value > 0:
            raise UsageError(f"{name} must be > 0, got {value}")
    if max_wall is not None and not max_wall >= 0:
        raise UsageError(f"--max-wall must be >= 0 s (0: no limit), got {max_wall}")
    name = algorithm or scenario.simulation.algorithm
    if name not in ALGORITHMS:
        raise UsageError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})")
    if tol is not None and name != "adaptive":
        raise UsageError(f"--tol applies to the adaptive algorithm only, not {name} (use --step)")
    return name


def require(module: str, install: str, purpose: str) -> None:
    """A missing optional piece is one line naming what to install."""
    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a broken install counts as missing
        found = False
    if not found:
        raise UsageError(f"{purpose} needs the package {install!r}: python -m pip install '{install}'")


def resolve_fmu_dir(fmu_dir: str | None, names, quiet: bool = False, fmi: int | None = None) -> Path:
    """An explicit folder must hold the FMUs (of FMI version fmi, if given); the default
    cache of that version (default 2) is filled when needed."""
    from . import api
    from .build import build_fmus, default_fmu_dir
    if fmu_dir is not None:
        path = Path(fmu_dir)
        missing = [n for n in names if not (path / f"{n}.fmu").is_file()]
        if missing:
            option = f" --fmi {fmi}" if fmi == 3 else ""
            raise UsageError(f"FMU file not found: {path / (missing[0] + '.fmu')} "
                             f"(build it with 'tribofmu build --out {path}{option}', or drop --fmu-dir)")
        if fmi is not None:
            import fmpy
            for name in names:
                found = fmpy.read_model_description(str(path / f"{name}.fmu"), validate=False).fmiVersion
                if not found.startswith(str(fmi)):
                    raise UsageError(f"--fmi {fmi}: {path / (name + '.fmu')} is an FMI {found} FMU")
        return path
    fmi = fmi or 2
    path = default_fmu_dir(fmi)
    if any(not (path / f"{n}.fmu").is_file() for n in names):
        if not quiet:
            print(f"tribofmu: building the FMI {fmi}.0 FMUs into {path}/ (once per installed version)",
                  file=sys.stderr)
        if fmi == 3:
            build_fmus(path, tuple(names), fmi=3)
        else:
            api.ensure_fmus(path, names, build=None)
    return path


def label_overrides(overrides, algorithm, step, tol) -> dict[str, str]:
    """The --set values and the algorithm options: what makes a run differ from the scene."""
    from .provenance import overrides_dict
    label = overrides_dict(overrides)
    for key, value in (("simulation.algorithm", algorithm), ("simulation.step", step), ("simulation.tol", tol)):
        if value is not None:
            label[key] = f"{value:g}" if isinstance(value, float) else str(value)
    return label


# -- commands -------------------------------------------------------------------------------
def cmd_build(args) -> int:
    from .build import build_fmus
    if args.out is not None:
        check_out_dir(Path(args.out))
    for path in build_fmus(args.out, fmi=args.fmi):
        print(path)
    return 0


def cmd_simulate(args) -> int:
    from . import api
    from .atomic import atomic_directory
    from .progress import RunBar
    from .provenance import default_out_dir, overrides_dict, record

    scenario = api.load(args.scenario, args.overrides)
    algorithm = check_algorithm_options(scenario, args.algorithm, args.step, args.tol, args.max_wall)
    out = Path(args.out) if args.out else default_out_dir(
        scenario.name, label_overrides(args.overrides, args.algorithm, args.step, args.tol))
    check_out_dir(out)
    fmu_dir = resolve_fmu_dir(args.fmu_dir, scenario.fmus, args.quiet, args.fmi)
    quiet = True if args.quiet else None
    with RunBar(scenario.name, scenario.stop_time, enabled=False if quiet else None) as bar:
        result = api.simulate(scenario, algorithm=args.algorithm, step=args.step, tol=args.tol,
                              fmu_dir=fmu_dir, build=False, progress=bar, notice=bar.notice,
                              max_wall=-1.0 if args.max_wall is None else args.max_wall)
    stats = dict(result.stats)
    settings = {"algorithm": algorithm, "step": stats.get("step"), "tol": stats.get("tol"),
                "requested": {"algorithm": args.algorithm, "step": args.step, "tol": args.tol}}
    stats["provenance"] = record(args.scenario, overrides_dict(args.overrides), settings, stats.get("fmus"))
    with atomic_directory(out) as tmp:
        (tmp / "stats.json").write_text(json.dumps(stats, indent=2) + "\n")
        if result.ok:  # a failed run leaves its stats (with the message), never a partial result
            write_result_csv(result, tmp / "result.csv")
            if not args.no_plots:
                from .plots import plot_result
                plot_result(result, tmp)
        for name in RUN_OUTPUTS:  # an older run's results must not look like this run's
            if not (tmp / name).exists() and (out / name).is_file():
                (out / name).unlink()
    estimate = result.stats["estimated_error"]["nrms_v"]
    accuracy = f", estimated nRMS(v) {estimate:.2g}" if estimate is not None else ""
    print(f"{scenario.name}: {result.message}; {result.stats['communication_steps']} steps, "
          f"{result.stats['wall_time']:.2f} s{accuracy} -> {out}/")
    for warning in result.stats["warnings"]:
        print(f"tribofmu: warning: {warning}", file=sys.stderr)
    if not result.ok:
        print(f"tribofmu: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return 0


def cmd_export_ssp(args) -> int:
    from . import api
    from .scene.ssp import export_ssp
    from .scene.wiring import instances
    scenario = api.load(args.scenario, args.overrides)
    out = check_out_file(Path(args.out))
    names = [inst.fmu.name for inst in instances(scenario, args.pair)]  # a scene the pair cannot take: exit 2
    fmu_dir = resolve_fmu_dir(args.fmu_dir, names)
    path = export_ssp(scenario, out, fmu_dir, pair=args.pair)
    print(path)
    return 0


def cmd_sweep(args) -> int:
    """Exit 0 when every point is ok, 1 when some failed (see their rows), 2 on bad input."""
    from . import api
    from .studies.sweep import parse_grid, sweep
    require("tqdm", "tqdm", "tribofmu sweep")
    if args.workers != 0:
        require("distributed", "dask[distributed]", "tribofmu sweep on Dask (--workers 0 runs without)")
    scenario = api.load(args.scenario, args.overrides)
    check_algorithm_options(scenario, args.algorithm, args.step, args.tol)
    out = Path(args.out) if args.out else Path("out") / f"{Path(args.scenario).stem}-sweep"
    check_out_dir(out)
    try:
        rows = sweep(args.scenario, parse_grid(args.grid), out, scheduler=args.scheduler,
                     workers=args.workers, overrides=args.overrides, algorithm=args.algorithm,
                     step=args.step, tol=args.tol, fmu_dir=args.fmu_dir,
                     retry_failed=args.retry_failed, timeout=args.timeout, plots=not args.no_plots,
                     progress=not args.quiet and sys.stderr.isatty())
    except KeyboardInterrupt:
        print(f"tribofmu: sweep interrupted; finished points are in {out}/sweep.csv, "
              "rerun the same command to resume", file=sys.stderr)
        return 130
    print(f"{len(rows)} points: {len(rows) - rows.failed} ok, {rows.failed} failed "
          f"({rows.computed} run, {rows.skipped} already done), {rows.elapsed:.1f} s -> {out}/")
    return EXIT_FAILED if rows.failed else 0


def cmd_accuracy(args) -> int:
    from . import api
    from .studies.accuracy import accuracy_study, write_study
    from .progress import check_interrupt, deferred_interrupts
    from .provenance import default_out_dir, overrides_dict
    scenario = api.load(args.scenario, args.overrides)
    out = Path(args.out) if args.out else default_out_dir(scenario.name, overrides_dict(args.overrides),
                                                          "-accuracy")
    check_out_dir(out)
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
    if args.data:
        check_out_dir(Path(args.data), "--data")
    paths = make_figures(out, only=only, scenarios_dir=args.scenarios, fmu_dir=args.fmu_dir,
                         rerun=args.rerun, quiet=args.quiet, data_dir=args.data)
    for path in paths:
        print(path)
    return 0


def write_result_csv(result, path: Path) -> None:
    """``time,X,V,x,v,F,f`` in SI units, one row per output point."""
    import numpy as np
    table = np.column_stack([result.time] + [getattr(result, k) for k in CSV_COLUMNS])
    np.savetxt(path, table, delimiter=",", header="time," + ",".join(CSV_COLUMNS), comments="", fmt="%.17g")


if __name__ == "__main__":
    sys.exit(main())
