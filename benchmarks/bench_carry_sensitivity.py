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
import math
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
    from tribofmu.coupling import embedded, estimate
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.studies.reference import reference_solution

    overrides = {key: float(value) for key, value in (item.split("=", 1) for item in args.set)}
    scenario = api.load("fig6_boundary", overrides)
    period, delta = scenario.drive.period, args.delta * scenario.drive.A

    carry = estimate.GlobalErrorEstimate.advance
    started = []

    def carry_alone(self, h, damping, local_x, local_v, stuck, x_scale=math.inf, v_scale=math.inf,
                    stuck_through=False, slopes=None, f_scale=math.inf, local_f=0.0, transition=None):
        if not started:  # exact less computed: the computed run is the one from x0
            self.ex = delta
            started.append(True)
        return carry(self, h, damping, 0.0, 0.0, stuck, math.inf, math.inf, stuck_through, slopes, math.inf, 0.0,
                     transition)

    carried = []
    carry_error = embedded.EmbeddedCoupling._carry_error

    def logged(self, point, new, local, h):
        carry_error(self, point, new, local, h)
        carried.append((new.t_ns / 1e9, self.estimate.ex, self.estimate.ev, self.estimate.ef))

    estimate.GlobalErrorEstimate.advance = carry_alone
    embedded.EmbeddedCoupling._carry_error = logged
    try:
        api._run_once(scenario, "adaptive", None, args.step_tol, Path(find_fmus(("Drive", "BlockSpring", "Friction"))),
                      api.output_samples(scenario), None, False, 600.0, None, None, False)
    finally:
        estimate.GlobalErrorEstimate.advance = carry
        embedded.EmbeddedCoupling._carry_error = carry_error
    log = np.array(carried)
    t = log[:, 0]
    base = reference_solution(scenario, t_eval=t)
    moved = reference_solution(api.load("fig6_boundary", {**overrides, "block.x0": scenario.block.x0 + delta}),
                               t_eval=t)
    exact = {"x": moved.x - base.x, "v": moved.v - base.v, "f": moved.f - base.f}
    print(f"# bench_carry_sensitivity {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}; {overrides or 'fig6'}, per-step {args.step_tol:g}, "
          f"delta {args.delta:g} A", flush=True)
    print(f"{'t/T':>6s} {'ref f':>11s} {'x ratio':>8s} {'v ratio':>8s} {'f ratio':>8s} {'exact v':>9s} {'carried v':>9s}")
    for k in range(1, int(round(args.periods / args.bin)) + 1):
        inside = np.where((t >= (k - 1) * args.bin * period) & (t < k * args.bin * period))[0]
        if len(inside) == 0:
            continue

        def rms(values):
            return float(np.sqrt(np.mean(values[inside] ** 2)))

        ratios = [rms(log[:, j]) / rms(exact[name]) if rms(exact[name]) > 0 else math.nan
                  for j, name in ((1, "x"), (2, "v"), (3, "f"))]
        print(f"{k * args.bin:6.2f} {base.f[inside].min():5.2f}-{base.f[inside].max():5.2f} "
              f"{ratios[0]:8.2f} {ratios[1]:8.2f} {ratios[2]:8.2f} {rms(exact['v']):9.2e} {rms(log[:, 2]):9.2e}")


if __name__ == "__main__":
    main()
