"""Issue 36's two hard points, timed as a user's default call, with the check's workers 1 and 2
interleaved in one process (medians over --repeat rounds, CPU time beside):

- pseudoplastic friction at gamma = -0.9 against the Newtonian scene (target: at most 5x its time);
- the solid lubricant, Fig. 6's rig at gamma = -0.85 and K = 2000 N/m, at --tol 1e-4 (target: ok,
  under 5 s, no step below 1e-6 of the drive's period: the smallest step of its reported run is
  printed as a fraction of the period, with how many steps lie below 1e-6 of it).

    python benchmarks/bench_hard_points.py [--repeat 3]
"""
from __future__ import annotations

import argparse
import datetime
import os
import statistics
import sys
import time

CASES = {
    "newtonian scene": ("fig5_newtonian", {}, None),
    "pseudoplastic gamma=-0.9": ("fig5_pseudoplastic", {"friction.gamma": -0.9}, None),
    "solid lubricant tol 1e-4": ("fig6_boundary", {"friction.gamma": -0.85, "block.K": 2000.0}, 1e-4),
}


def smallest_steps(scenario, step_tol: float) -> tuple[float, int]:
    """The reported run again, in this process with its points: its smallest step over the
    drive's period, and how many steps lie below 1e-6 of it."""
    from tribofmu import api

    result = api.one_run(scenario, step_tol, api.find_fmus(scenario.fmus, None), keep_points=True)
    t = [p.t_ns for p in result.points]
    steps = [(b - a) / 1e9 / scenario.drive.period for a, b in zip(t, t[1:])]
    return min(steps), sum(1 for s in steps if s < 1e-6)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from tribofmu import api
    from tribofmu.forked_runs import cpu_seconds

    print(f"bench_hard_points {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.2f}", flush=True)
    scenes = {name: (api.load(scene, overrides), tol) for name, (scene, overrides, tol) in CASES.items()}
    api.simulate(scenes["newtonian scene"][0])  # the FMUs found or built, the imports warm: not timed
    rows: dict = {}
    for _ in range(args.repeat):
        for name, (scenario, tol) in scenes.items():
            for workers in (1, 2):
                begin, cpu = time.perf_counter(), cpu_seconds()
                result = api.simulate(scenario, tol=tol, check_workers=workers)
                rows.setdefault((name, workers), []).append(
                    (time.perf_counter() - begin, cpu_seconds() - cpu, result))
    for (name, workers), runs in rows.items():
        result = runs[-1][2]
        print(f"{name:26s} workers {workers}: wall {statistics.median(r[0] for r in runs):6.2f} s, "
              f"cpu {statistics.median(r[1] for r in runs):6.2f} s, runs {len(result.stats['check']['runs'])}, "
              f"ok {result.ok}, reported nRMS(v) {result.stats['estimated_error']['nrms_v']:.2g}")
    for workers in (1, 2):
        ratio = (statistics.median(r[0] for r in rows[("pseudoplastic gamma=-0.9", workers)])
                 / statistics.median(r[0] for r in rows[("newtonian scene", workers)]))
        print(f"workers {workers}: pseudoplastic gamma=-0.9 / newtonian scene {ratio:.1f}x (target <= 5x)")
    scenario, _ = scenes["solid lubricant tol 1e-4"]
    smallest, below = smallest_steps(scenario, rows[("solid lubricant tol 1e-4", 1)][-1][2].stats["step_tol"])
    print(f"solid lubricant: smallest step {smallest:.2e} of the period, {below} steps below 1e-6 of it")
    print(f"load at the end {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
