"""Benchmark of ``tribofmu sweep``: speed-up from 1 to 2 Dask workers, per-point Dask overhead.

    python tests/bench_sweep.py [--repeats 3] [--cases fig4,short]

Not a test (pytest does not collect it): it prints numbers measured in one run, on this machine.

Cases: ``fig4``, the paper's Fig. 4 sweep (6 points, full 6.5-period spans, points of very
unequal cost); ``short``, 12 cheap points (2 periods each) where fixed per-point costs show.
For each case, every configuration runs ``--repeats`` times into a fresh directory (no resume)
with plots off; the medians are printed:

- ``plain``: ``sweep(workers=0)``, a plain loop in this process, no Dask;
- ``dask-1``, ``dask-2``: ``sweep(scheduler=...)`` on a LocalCluster of 1 or 2 single-threaded
  worker processes, started once per configuration (its start-up is timed separately, and is
  what ``tribofmu sweep`` adds once per command on top of these numbers).

Reported: speed-up ``dask-1 / dask-2``; Dask overhead per point ``(dask-1 - plain) / points``;
``sim`` is the sum of the points' own simulate+metrics times (the work that can be parallel).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIG2 = ROOT / "scenarios" / "fig2_dry.toml"
CASES = {
    "fig4": (FIG2, {"drive.omega": [10, 20, 30, 50, 80, 130]}, {}),
    "short": (FIG2, {"drive.omega": [20, 25, 30, 35, 40, 50, 60, 70, 80, 100, 115, 130]},
              {"time.periods": 2, "time.window": [1, 2]}),
}


def timed_sweep(case, out: Path, fmu_dir: Path, **kw) -> tuple[float, float]:
    from tribofmu.sweep import sweep
    scenario, grid, overrides = CASES[case]
    t0 = time.perf_counter()
    rows = sweep(scenario, grid, out, overrides=overrides, fmu_dir=fmu_dir, plots=False, progress=False,
                 log=lambda msg: None, **kw)
    wall = time.perf_counter() - t0
    bad = [r for r in rows if r["status"] != "ok"]
    if bad:
        raise SystemExit(f"{case}: {len(bad)} points failed, e.g. {bad[0]['message']}")
    return wall, sum(r["wall_time"] for r in rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cases", default="fig4,short")
    args = parser.parse_args()
    cases = [c for c in args.cases.split(",") if c]

    import logging

    from distributed import LocalCluster

    from tribofmu.build import build_fmus

    print(f"cores: {len(os.sched_getaffinity(0))}, load average at start: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    results: dict[tuple[str, str], list[tuple[float, float]]] = {}
    startup: dict[int, list[float]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory(prefix="bench_sweep_") as tmp:
        tmp = Path(tmp)
        fmu_dir = tmp / "fmus"
        build_fmus(fmu_dir)
        run = 0

        def out_dir() -> Path:
            nonlocal run
            run += 1
            return tmp / f"run{run}"

        for case in cases:  # warm-up: imports, page cache, one untimed pass
            timed_sweep(case, out_dir(), fmu_dir, workers=0)
        for case in cases:
            results[(case, "plain")] = [timed_sweep(case, out_dir(), fmu_dir, workers=0)
                                        for _ in range(args.repeats)]
            print(f"{case} plain done", flush=True)
        for n in (1, 2):
            t0 = time.perf_counter()
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                              scheduler_kwargs={"dashboard_address": ":0"},
                              silence_logs=logging.ERROR) as cluster:
                startup[n].append(time.perf_counter() - t0)
                address = cluster.scheduler_address
                timed_sweep(cases[-1], out_dir(), fmu_dir, scheduler=address)  # warm the workers
                for case in cases:
                    results[(case, f"dask-{n}")] = [timed_sweep(case, out_dir(), fmu_dir, scheduler=address)
                                                    for _ in range(args.repeats)]
                    print(f"{case} dask-{n} done", flush=True)

    med = {k: (statistics.median(w for w, _ in v), statistics.median(s for _, s in v))
           for k, v in results.items()}
    print()
    print(f"medians of {args.repeats} runs [s]; load average at end: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'case':<6} {'points':>6} {'plain':>8} {'dask-1':>8} {'dask-2':>8} {'sim(plain)':>10} "
          f"{'speed-up 1->2':>14} {'dask/plain':>10} {'overhead/point':>15}")
    for case in cases:
        n = len(CASES[case][1]["drive.omega"])
        plain, d1, d2 = (med[(case, c)][0] for c in ("plain", "dask-1", "dask-2"))
        print(f"{case:<6} {n:>6} {plain:>8.2f} {d1:>8.2f} {d2:>8.2f} {med[(case, 'plain')][1]:>10.2f} "
              f"{d1 / d2:>14.2f} {d1 / plain:>10.3f} {1e3 * (d1 - plain) / n:>12.1f} ms")
    print(f"LocalCluster start-up: 1 worker {startup[1][0]:.2f} s, 2 workers {startup[2][0]:.2f} s "
          f"(once per 'tribofmu sweep' command)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
