"""The ``tribofmu`` command: a thin layer over :mod:`tribofmu.api`.

    tribofmu build [--out DIR]
    tribofmu simulate SCENARIO [--out DIR] [--set KEY=VALUE ...] [--algorithm NAME] [--step S] [--tol TOL]
    tribofmu export-ssp SCENARIO --out FILE.ssp [--set KEY=VALUE ...] [--fmu-dir DIR]
    tribofmu accuracy SCENARIO [--out DIR] [--set KEY=VALUE ...] [--quick]
    tribofmu sweep SCENARIO --grid KEY=V1,V2,... [--grid ...] [--out DIR] [--scheduler ADDR] [--workers N]

Bad input (a scenario key, a value, a missing FMU) is one line on stderr and exit code 2;
results are written whole or not at all.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .master.run import COLUMNS

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1


class UsageError(Exception):
    """Bad input from the command line: reported as one line, exit code 2."""


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except KeyboardInterrupt:
        print("tribofmu: interrupted; nothing was written", file=sys.stderr)
        return 130
    except Exception as exc:  # every expected failure becomes one line, never a traceback
        from .api import FMUSetupError
        from .master.slave import FMUCallError, FMUFileError
        from .scene.scenario import ScenarioError
        if isinstance(exc, (UsageError, ScenarioError, FMUFileError, FileNotFoundError, FMUSetupError,
                            FMUCallError)):
            print(f"tribofmu: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
        raise


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tribofmu", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build", help="build Friction.fmu, Drive.fmu, BlockSpring.fmu")
    p.add_argument("--out", default="build", help="output directory (default: build)")
    p.set_defaults(run=cmd_build)

    p = sub.add_parser("simulate", help="co-simulate a scenario")
    p.add_argument("scenario")
    p.add_argument("--out", default=None, help="output directory (default: out/<scenario name>)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. drive.omega=80 (repeatable)")
    p.add_argument("--algorithm", default=None, help="jacobi, gauss-seidel, implicit, adaptive")
    p.add_argument("--step", type=float, default=None, help="communication step [s] (fixed-step algorithms)")
    p.add_argument("--tol", type=float, default=None, help="tolerance of the adaptive algorithm")
    p.add_argument("--fmu-dir", default="build", help="where the .fmu files are (default: build)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.set_defaults(run=cmd_simulate)

    p = sub.add_parser("export-ssp", help="write the scenario's coupled system as an SSP 1.0 archive")
    p.add_argument("scenario")
    p.add_argument("--out", required=True, help="the .ssp file to write")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--fmu-dir", default="build", help="where the .fmu files are (default: build)")
    p.set_defaults(run=cmd_export_ssp)

    p = sub.add_parser("sweep", help="run a grid of overrides on Dask; sweep.csv, regime maps")
    p.add_argument("scenario")
    p.add_argument("--grid", action="append", default=[], required=True, metavar="KEY=V1,V2,...",
                   help="swept values of a scenario key (repeatable: the cartesian product)")
    p.add_argument("--out", default=None, help="output directory (default: out/<scenario name>-sweep)")
    p.add_argument("--scheduler", default=None, help="address of an existing Dask scheduler")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: one per core; 0: no Dask, a plain loop)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--algorithm", default=None, help="jacobi, gauss-seidel, implicit, adaptive")
    p.add_argument("--step", type=float, default=None, help="communication step [s]")
    p.add_argument("--tol", type=float, default=None, help="tolerance of the adaptive algorithm")
    p.add_argument("--fmu-dir", default=None, help="use these FMUs (default: build into OUT/fmus)")
    p.add_argument("--retry-failed", action="store_true", help="rerun the points sweep.csv has as failed")
    p.add_argument("--timeout", type=float, default=None, help="per-point time limit [s]: then failed")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.set_defaults(run=cmd_sweep)

    p = sub.add_parser("accuracy", help="error vs cost of every algorithm against the reference solution")
    p.add_argument("scenario")
    p.add_argument("--out", default=None, help="output directory (default: out/<scenario name>-accuracy)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--quick", action="store_true", help="a shorter ladder of steps and tolerances")
    p.add_argument("--fmu-dir", default="build", help="where the .fmu files are (default: build)")
    p.set_defaults(run=cmd_accuracy)
    return parser


def cmd_build(args) -> int:
    from .build import build_fmus
    for path in build_fmus(args.out):
        print(path)
    return 0


def cmd_simulate(args) -> int:
    from . import api
    from .atomic import atomic_directory

    scenario = api.load(args.scenario, args.overrides)
    for name, value in (("--step", args.step), ("--tol", args.tol)):
        if value is not None and not value > 0:
            raise UsageError(f"{name} must be > 0, got {value}")
    api.ensure_fmus(Path(args.fmu_dir), scenario.fmus, build=False)
    result = api.simulate(scenario, algorithm=args.algorithm, step=args.step, tol=args.tol,
                          fmu_dir=args.fmu_dir, build=False)
    out = Path(args.out) if args.out else Path("out") / scenario.name
    with atomic_directory(out) as tmp:
        (tmp / "stats.json").write_text(json.dumps(result.stats, indent=2) + "\n")
        if result.ok:  # a failed run leaves its stats (with the message), never a partial result
            write_result_csv(result, tmp / "result.csv")
            if not args.no_plots:
                from .plots import plot_result
                plot_result(result, tmp)
    print(f"{scenario.name}: {result.message}; {result.stats['communication_steps']} steps, "
          f"{result.stats['wall_time']:.2f} s -> {out}/")
    if not result.ok:
        print(f"tribofmu: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return 0


def cmd_export_ssp(args) -> int:
    from . import api
    from .scene.ssp import export_ssp
    scenario = api.load(args.scenario, args.overrides)
    path = export_ssp(scenario, Path(args.out), Path(args.fmu_dir))
    print(path)
    return 0


def cmd_sweep(args) -> int:
    """Exit 0 when every point is ok, 1 when some failed (see their rows), 2 on bad input."""
    from .studies.sweep import parse_grid, sweep
    out = Path(args.out) if args.out else Path("out") / f"{Path(args.scenario).stem}-sweep"
    try:
        rows = sweep(args.scenario, parse_grid(args.grid), out, scheduler=args.scheduler,
                     workers=args.workers, overrides=args.overrides, algorithm=args.algorithm,
                     step=args.step, tol=args.tol, fmu_dir=args.fmu_dir,
                     retry_failed=args.retry_failed, timeout=args.timeout, plots=not args.no_plots)
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
    scenario = api.load(args.scenario, args.overrides)
    api.ensure_fmus(Path(args.fmu_dir), scenario.fmus, build=False)
    rows, summary = accuracy_study(scenario, fmu_dir=args.fmu_dir, quick=args.quick)
    out = Path(args.out) if args.out else Path("out") / f"{scenario.name}-accuracy"
    write_study(rows, summary, scenario, out)
    print(f"{len(rows)} runs, {summary['total_wall_time_s']:.1f} s -> {out}/")
    return 0


def write_result_csv(result, path: Path) -> None:
    """``time,X,V,x,v,F,f`` in SI units, one row per output point."""
    import numpy as np
    table = np.column_stack([result.time] + [getattr(result, k) for k in COLUMNS])
    np.savetxt(path, table, delimiter=",", header="time," + ",".join(COLUMNS), comments="", fmt="%.17g")


if __name__ == "__main__":
    sys.exit(main())
