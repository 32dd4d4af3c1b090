"""Benchmark: speed-up and efficiency of a 128-point sweep on 1, 2, ... Dask workers.

    python benchmarks/bench_sweep_scaling.py [--workers 1,2] [--repeats 1]

Not a test: it prints numbers measured in one run, on this machine. The sweep is Fig. 2's
scene over 16 drive frequencies x 8 loads (2 periods each, one shown), plots off, a fresh
output directory per run. Each worker count gets a ``LocalCluster`` of that many
single-threaded worker processes, started before the clock runs (``tribofmu sweep`` pays the
start-up once per command); the FMUs reach the workers through Dask, as on a cluster without
a shared disk, and the points run longest expected first. Reported per worker count: the
sweep's wall time (median over repeats), the speed-up over 1 worker and the efficiency
(speed-up / workers), plus the sum of the points' own times and the workers' utilisation
(that sum / (workers x wall)): on a machine other jobs load, the points themselves slow down
and the speed-up shows it, while the utilisation still says whether the scheduling kept
every worker busy to the end.
"""
from __future__ import annotations

import argparse
import contextlib
import logging
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIG2 = ROOT / "scenarios" / "fig2_dry.toml"
GRID = {"drive.omega": [20, 25, 30, 35, 40, 45, 50, 60, 70, 80, 90, 100, 110, 120, 130, 140],
        "conditions.n": [-10, -15, -20, -25, -30, -35, -40, -45]}
OVERRIDES = {"time.periods": 2, "time.window": [1, 2]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workers", default=f"1,{len(os.sched_getaffinity(0))}")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    counts = sorted({int(n) for n in args.workers.split(",")})

    from distributed import LocalCluster

    from tribofmu.build import build_fmus
    from tribofmu.studies.sweep import sweep

    points = len(GRID["drive.omega"]) * len(GRID["conditions.n"])
    print(f"{points} points; cores: {len(os.sched_getaffinity(0))}; load average at start: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    walls: dict[int, list[float]] = {}
    sims: dict[int, list[float]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_scaling_") as tmp:
        tmp = Path(tmp)
        fmu_dir = tmp / "fmus"
        build_fmus(fmu_dir)
        run = 0
        for n in counts:
            with contextlib.ExitStack() as stack:
                cluster = stack.enter_context(LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                    scheduler_kwargs={"dashboard_address": ":0"}, silence_logs=logging.ERROR))
                for _ in range(args.repeats):
                    run += 1
                    t0 = time.perf_counter()
                    rows = sweep(FIG2, GRID, tmp / f"run{run}", scheduler=cluster.scheduler_address,
                                 overrides=OVERRIDES, fmu_dir=fmu_dir, plots=False, progress=False,
                                 log=lambda msg: None)
                    walls.setdefault(n, []).append(time.perf_counter() - t0)
                    sims.setdefault(n, []).append(sum(r["wall_time"] for r in rows))
                    if rows.failed:
                        raise SystemExit(f"{rows.failed} points failed")
            print(f"{n} worker(s): {statistics.median(walls[n]):.2f} s", flush=True)
    base = statistics.median(walls[counts[0]]) * counts[0]
    print(f"\nload average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'workers':>7} {'wall [s]':>9} {'sum of points [s]':>18} {'speed-up':>9} {'efficiency':>10} "
          f"{'utilisation':>11}")
    for n in counts:
        wall = statistics.median(walls[n])
        speedup = base / wall
        busy = statistics.median(sims[n])
        print(f"{n:>7} {wall:>9.2f} {busy:>18.2f} {speedup:>9.2f} {speedup / n:>10.2f} {busy / (n * wall):>11.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
