"""Per-step cost of the Friction FMU in each regime ("simulate only the effects a scene
calls for": dry never touches the kinetics; boundary with melting on/off).

    python benchmarks/bench_regimes.py [--periods 0.25] [--step 1e-4]

Every regime runs the same fixed-step implicit coupling (h = 1e-4 s) over a short span;
each fmi2DoStep of the friction instance is timed; medians are printed, with the whole
run's friction calls for context. Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FMU_DIR = ROOT / "build"
CASES = (("dry", "fig2_dry", []), ("fluid", "fig5_newtonian", []),
         ("fluid gamma=-2/3", "fig5_pseudoplastic", []),
         ("boundary", "fig6_boundary", []),
         ("boundary melting=false", "fig6_boundary", ["effects.melting=false"]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--periods", type=float, default=0.25)
    parser.add_argument("--step", type=float, default=1e-4)
    args = parser.parse_args(argv)
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.master.instance import FMUInstance

    original = FMUInstance.do_step
    timings: list[float] = []

    def timed(self, t, h):
        if self.instance != "friction":
            return original(self, t, h)
        begin = time.perf_counter()
        try:
            return original(self, t, h)
        finally:
            timings.append(time.perf_counter() - begin)

    print(f"implicit h={args.step:g} s over {args.periods:g} periods; friction fmi2DoStep")
    print(f"{'regime':24s} {'median us':>10s} {'p90 us':>9s} {'do_steps':>9s} {'steps':>7s} {'run s':>7s}")
    FMUInstance.do_step = timed
    try:
        for label, scene, overrides in CASES:
            sc = api.load(ROOT / "scenarios" / f"{scene}.toml", overrides + [f"time.periods={args.periods}",
                                                                              "time.window=[0,0.1]"])
            find_fmus(sc.fmus, FMU_DIR, build=None)
            timings.clear()
            r = api.simulate(sc, fmu_dir=FMU_DIR, build=False, algorithm="implicit", step=args.step)
            ts = sorted(timings)
            print(f"{label:24s} {statistics.median(ts) * 1e6:10.1f} {ts[int(0.9 * len(ts))] * 1e6:9.1f} "
                  f"{len(ts):9d} {r.stats['communication_steps']:7d} {r.stats['wall_time']:7.2f}"
                  + ("" if r.ok else f"  ({r.message})"))
    finally:
        FMUInstance.do_step = original
    return 0


if __name__ == "__main__":
    sys.exit(main())
