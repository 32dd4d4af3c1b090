"""Benchmark of ``tribofmu sweep``: speed-up from 1 to 2 Dask workers, per-point Dask overhead.

    python benchmarks/bench_sweep.py [--repeats 3] [--cases fig4,short]

Not a test (pytest does not collect it): it prints numbers measured in one run, on this machine.

Cases: ``fig4``, the paper's Fig. 4 sweep (6 points, full 6.5-period spans, points of very
unequal cost); ``short``, 12 cheap points (2 periods each) where fixed per-point costs show.
Configurations, each with plots off and a fresh directory per run (no resume):

- ``plain``: ``sweep(workers=0)``, a plain loop in this process, no Dask;
- ``dask-1``, ``dask-2``: ``sweep(scheduler=...)`` on a LocalCluster of 1 or 2 single-threaded
  worker processes, both started once at the beginning (their start-up is timed separately:
  ``tribofmu sweep`` pays it once per command on top of these numbers).

The runs are interleaved (each repeat runs every case in every configuration), after one
uncounted warm-up repeat, so that a change in the machine's load hits all configurations
alike; the medians over ``--repeats`` are printed. Reported: speed-up ``dask-1 / dask-2``;
Dask overhead per point ``(dask-1 - plain) / points``; and, less sensitive to the load,
``(wall - sim) / points`` per configuration, where ``sim`` is the sum of the points' own
simulate+metrics times: what the sweep machinery costs per point.
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

ROOT = Path(__file__).resolve().parent.parent
FIG2 = ROOT / "scenarios" / "fig2_dry.toml"
CASES = {
    "fig4": (FIG2, {"drive.omega": [10, 20, 30, 50, 80, 130]}, {}),
    "short": (FIG2, {"drive.omega": [20, 25, 30, 35, 40, 50, 60, 70, 80, 100, 115, 130]},
              {"time.periods": 2, "time.window": [1, 2]}),
}


def timed_sweep(case, out: Path, fmu_dir: Path, **kw) -> tuple[float, float]:
    from tribofmu.studies.sweep import sweep
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

    from distributed import LocalCluster

    from tribofmu.build import build_fmus

    print(f"cores: {len(os.sched_getaffinity(0))}, load average at start: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    results: dict[tuple[str, str], list[tuple[float, float]]] = {}
    startup: dict[int, float] = {}
    configs = ("plain", "dask-1", "dask-2")
    with tempfile.TemporaryDirectory(prefix="bench_sweep_") as tmp, contextlib.ExitStack() as stack:
        tmp = Path(tmp)
        fmu_dir = tmp / "fmus"
        build_fmus(fmu_dir)
        addresses = {}
        for n in (1, 2):
            t0 = time.perf_counter()
            cluster = stack.enter_context(LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                scheduler_kwargs={"dashboard_address": ":0"}, silence_logs=logging.ERROR))
            startup[n] = time.perf_counter() - t0
            addresses[f"dask-{n}"] = cluster.scheduler_address
        kwargs = {"plain": {"workers": 0}, **{c: {"scheduler": a} for c, a in addresses.items()}}
        run = 0
        for repeat in range(args.repeats + 1):  # repeat 0 warms up (imports, caches), not counted
            for case in cases:
                for config in configs:  # interleaved, so a change of machine load hits all alike
                    run += 1
                    timing = timed_sweep(case, tmp / f"run{run}", fmu_dir, **kwargs[config])
                    if repeat:
                        results.setdefault((case, config), []).append(timing)
            print(f"repeat {repeat}/{args.repeats} done", flush=True)

    med = {k: (statistics.median(w for w, _ in v), statistics.median(w - s for w, s in v))
           for k, v in results.items()}
    print()
    print(f"medians of {args.repeats} runs [s]; load average at end: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'case':<6} {'points':>6} {'plain':>7} {'dask-1':>7} {'dask-2':>7} {'speed-up 1->2':>14} "
          f"{'dask-1/plain':>12} {'overhead/point':>15} {'(wall-sim)/point plain, dask-1':>31}")
    for case in cases:
        n = len(CASES[case][1]["drive.omega"])
        plain, d1, d2 = (med[(case, c)][0] for c in configs)
        e_plain, e_d1 = med[(case, "plain")][1], med[(case, "dask-1")][1]
        print(f"{case:<6} {n:>6} {plain:>7.2f} {d1:>7.2f} {d2:>7.2f} {d1 / d2:>14.2f} {d1 / plain:>12.3f} "
              f"{1e3 * (d1 - plain) / n:>12.1f} ms {1e3 * e_plain / n:>14.1f} ms, {1e3 * e_d1 / n:>6.1f} ms")
    print(f"LocalCluster start-up: 1 worker {startup[1]:.2f} s, 2 workers {startup[2]:.2f} s "
          f"(once per 'tribofmu sweep' command)")
    print("overhead/point = (dask-1 - plain) / points; (wall-sim)/point = what a sweep spends per point "
          "outside the points' own simulate+metrics time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
