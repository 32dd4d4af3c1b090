"""What a call's first run decides some drive periods before its window (coupling/lead_in.py).

    python benchmarks/bench_lead_in.py [--tol 1e-3] [--only SUBSTRING] [--extra]
    python benchmarks/bench_lead_in.py --scene fig6_boundary --set conditions.T=300 [--set ...]
    python benchmarks/bench_lead_in.py --scene fig6_boundary --marks --variant no-force-term

For each point of bench_trust.py's list (or ``--extra``'s), the call's first run (per-step
tolerance = tol, aiming at tol): the error's RMS before the decision and what is left of it as
the window opens, each over the budget (0.9 tol / 2), d (how much of an error is left a period
on), k (the periods before the window it tightened at), the factor on the per-step tolerance,
the tolerance the window ran at, and the run's own estimate (a call ends on this run where twice
it meets tol) against the true error. ``--marks``
also prints what each mark measured: its k, the error now over the budget, d, what d^k leaves
over the budget, and the k it found cheapest (0: none within the budget).
Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def show_marks() -> None:
    """Print each mark's measure as the lead-in takes it (LeadIn.observe wrapped in place)."""
    from tribofmu.coupling.lead_in import LeadIn

    observe = LeadIn.observe

    def told(self, t, whole, old, v, order=1.0):
        stage = self.stage
        said = observe(self, t, whole, old, v, order)
        if said is not None and stage >= 2:  # (a period after a mark: measured)
            print(f"    mark t={t:.3f} s k={self.periods} now/b={self.now / self.budget:.3g} d={self.decay:.3g} "
                  f"left/b={self.left / self.budget:.3g} cheapest k={self.cheapest(order)}", flush=True)
        return said

    LeadIn.observe = told


def main(argv=None) -> int:
    import bench_trust
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.scene.library import resolve_scene
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, default=1e-3)
    parser.add_argument("--only", default=None)
    parser.add_argument("--extra", action="store_true")
    parser.add_argument("--scene", default=None, help="one point: this scene with --set's overrides")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--marks", action="store_true", help="print what each mark measured")
    parser.add_argument("--variant", default="", metavar="NAME",
                        help="the first runs with one of bench_variants.py's variants patched in")
    args = parser.parse_args(argv)
    if args.variant:
        bench_trust.patch_variant(args.variant)
    if args.marks:
        show_marks()
    points = bench_trust.EXTRA_POINTS if args.extra else bench_trust.POINTS
    if args.scene:
        overrides = {key: float(value) for key, value in (item.split("=", 1) for item in args.set)}
        points = [(" ".join([args.scene, *args.set]), args.scene, overrides)]
    fmu_dir = find_fmus(("Drive", "BlockSpring", "Friction"))
    print(f"# bench_lead_in {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, tol {args.tol:g}, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'point':36s} {'now/b':>6s} {'d':>6s} {'k':>3s} {'left/b':>6s} {'factor':>7s} {'window tol':>10s} "
          f"{'estimate':>9s} {'true':>9s} {'one run':>7s} {'wall s':>6s}", flush=True)
    for label, scene, overrides in points:
        if args.only and args.only not in label:
            continue
        scenario = load_scenario(resolve_scene(scene), overrides)
        result = api.one_run(scenario, args.tol, fmu_dir, 300.0, aim=args.tol)
        decision = result.stats.get("lead_in") or {}
        reference = bench_trust.trusted_reference(scenario, label)
        true = nrms(result.time, result.v, reference.time, reference.v, scenario.window) if reference.ok else math.nan
        own = result.stats["estimated_error"]
        estimate = own.get("nrms_v") if own.get("vouches") else None
        ends = estimate is not None and 2.0 * estimate <= args.tol  # (ESTIMATE_SAFETY x it meets tol)

        def cell(key, width=6):
            value = decision.get(key)
            return f"{value:{width}.3g}" if value is not None else f"{'-':>{width}s}"

        print(f"{label:36s} {cell('error_now_over_budget')} {cell('decay_per_period')} "
              f"{cell('periods_before_window', 3)} {cell('left_over_budget')} "
              f"{cell('factor', 7)} {result.stats['window_step_tol']:10.2g} "
              f"{estimate if estimate is not None else math.nan:9.2e} {true:9.2e} {str(ends):>7s} "
              f"{result.stats['wall_time']:6.2f}", flush=True)
    print(f"# load at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
