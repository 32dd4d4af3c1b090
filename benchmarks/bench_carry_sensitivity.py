"""Does the carry propagate an error as the exact motion does? (coupling/estimate.py, issue 36)

    python benchmarks/bench_carry_sensitivity.py [--set KEY=VALUE ...] [--step-tol 3e-3]
                                                 [--delta 1e-5] [--bin 0.25] [--periods 2]

An error put into the block's position at the start, delta x A (the drive's amplitude), carried
by a run's linearised carry alone (its local errors withheld, its saturation at the motion's own
size lifted, ``GlobalErrorEstimate.advance``), against the exact difference it makes: the
reference (rtol 1e-10) from x0 + delta A less the reference from x0, both sampled at the run's
points. Prints per bin of the drive's period the RMS of the carried and the exact differences in
x, v and f, their ratio (1: the carry is exact to first order) and the reference's range of f in
the bin (a film that melts and re-solidifies there shows f from its solid value to past 10).
Scene: fig6_boundary with the --set values.
"""
from __future__ import annotations

import argparse
import datetime
import os
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--step-tol", type=float, default=3e-3)
    parser.add_argument("--delta", type=float, default=1e-5, help="the error put into x, in drive amplitudes")
    parser.add_argument("--bin", type=float, default=0.25, help="periods per printed line")
    parser.add_argument("--periods", type=float, default=2.0, help="periods printed")
    args = parser.parse_args()

    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.studies.carry import carried_error

    overrides = {key: float(value) for key, value in (item.split("=", 1) for item in args.set)}
    period = api.load("fig6_boundary", overrides).drive.period
    run = carried_error("fig6_boundary", overrides, args.step_tol, args.delta,
                        Path(find_fmus(("Drive", "BlockSpring", "Friction"))))
    print(f"# bench_carry_sensitivity {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}; {overrides or 'fig6'}, per-step {args.step_tol:g}, "
          f"delta {args.delta:g} A", flush=True)
    print(f"{'t/T':>6s} {'ref f':>11s} {'x ratio':>8s} {'v ratio':>8s} {'f ratio':>8s} {'exact v':>9s} {'carried v':>9s}")
    for k in range(1, int(round(args.periods / args.bin)) + 1):
        start, end = (k - 1) * args.bin * period, k * args.bin * period
        inside = (run.t >= start) & (run.t < end)
        if not inside.any():
            continue
        exact_v = float(np.sqrt(np.mean(run.exact["v"][inside] ** 2)))
        carried_v = float(np.sqrt(np.mean(run.carried[inside, 1] ** 2)))
        ratios = [run.ratio(start, end, name) for name in ("x", "v", "f")]
        print(f"{k * args.bin:6.2f} {run.f_reference[inside].min():5.2f}-{run.f_reference[inside].max():5.2f} "
              f"{ratios[0]:8.2f} {ratios[1]:8.2f} {ratios[2]:8.2f} {exact_v:9.2e} {carried_v:9.2e}")


if __name__ == "__main__":
    main()
