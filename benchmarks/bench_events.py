"""How late or early the adaptive coupling locates stick onsets and breakaways, over many
drive frequencies (tests/master/test_contract.py checks three).

    python benchmarks/bench_events.py [--tols 1e-3,1e-4] [--omegas 10:88.9:22 | --omegas 13,30,80]

Fig. 2's rig (fake slaves, the exact dry motion known: tests/master/fakes.py) over two drive
periods at each frequency and per-step tolerance: the run's events against the exact ones,
the largest miss in drive periods, and over the frequencies its median, 90th percentile and
maximum, and how many pass 2.5e-5 T. A frequency where the run sticks or breaks away other
than as often or in the order the exact motion does is counted apart (its events are not
compared). Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import datetime
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests" / "master"), str(ROOT / "tests")]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tols", default="1e-3,1e-4")
    parser.add_argument("--omegas", default="10:88.9:22", metavar="FIRST:LAST:COUNT or W1,W2,...")
    args = parser.parse_args()
    from fakes import drive_scales, fig2_system
    from test_contract import exact_events, located_events

    from tribofmu.coupling.algorithms import make_algorithm
    from tribofmu.master.run import run

    if ":" in args.omegas:
        first, last, count = args.omegas.split(":")
        omegas = [float(first) + k * (float(last) - float(first)) / max(int(count) - 1, 1) for k in range(int(count))]
    else:
        omegas = [float(omega) for omega in args.omegas.split(",")]
    count = len(omegas)
    print(f"# bench_events {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"{count} frequencies {omegas[0]:g}-{omegas[-1]:g} rad/s", flush=True)
    for tol in (float(t) for t in args.tols.split(",")):
        misses, apart = [], []
        for omega in omegas:
            scales = drive_scales(omega)
            stop = 2 * scales.period
            out = run(fig2_system(omega=omega), make_algorithm("adaptive", tol=tol), stop, scales)
            located, exact = located_events(out.points), exact_events(stop, omega)
            if [kind for kind, _ in located] != [kind for kind, _ in exact]:
                apart.append(omega)
                continue
            misses.append(max(abs(t - t_exact) for (_, t), (_, t_exact) in zip(located, exact)) / scales.period)
        ranked = sorted(misses)
        print(f"per-step {tol:g}: {len(misses)} frequencies, miss median {statistics.median(ranked):.2e} T, "
              f"p90 {ranked[int(0.9 * len(ranked))]:.2e} T, max {ranked[-1]:.2e} T, "
              f"past 2.5e-5 T at {sum(m > 2.5e-5 for m in ranked)}; other events at {len(apart)} "
              f"({', '.join(f'{o:g}' for o in apart) or 'none'})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
