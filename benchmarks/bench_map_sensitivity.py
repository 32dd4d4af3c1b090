"""How well a lubricated slip step's map is differentiated (physics/laws/tangent.py, issue 36).

    python benchmarks/bench_map_sensitivity.py [--scene fig6_boundary] [--set KEY=VALUE ...]
                                               [--step-tol 1e-3] [--tols 1e-5,1e-6]
                                               [--samples 40] [--variant NAME]

Records the slip steps one run takes (``BoundaryLaw.step_sensitivities``' arguments: f0, dv0, dv1,
h, n, T) at the per-step tolerance --step-tol, then for a sample of them compares the step map's
sensitivities (d f1 and d F_mean against f0, dv0, dv1; the carry's, coupling/variational.py) at
each kinetics tolerance of --tols with central differences of ``BoundaryLaw.advance`` itself at
1e-12, the inputs moved by 1e-5 of themselves (at 1e-11 and 1e-7 of the input, sub-steps that
change with the input made the differences noisy on microsecond steps), its ``MAX_SUBSTEPS``
raised (at this tolerance a millisecond step reached half of it and held dv from there, another
map). Steps that cross the melt threshold (the kink of the elastic modulus and of the rate's
slope) and steps that do not are sampled apart, all crossing steps up to --samples. Prints per group the median, 90th
percentile and largest error of each row: f's row scaled by the inputs' sizes (f0 ~ 1, dv ~ the
step's |dv|), and the mean force's dv entries against their larger one. --variant patches one of
bench_variants.py's variants in for the differentiated map (e.g. map-tangent-ends).
"""
from __future__ import annotations

import argparse
import datetime
import os

import numpy as np


def record_steps(scene: str, overrides: dict, step_tol: float) -> list:
    """(law, f0, dv1, n, T, h, dv0) of every step map one run at step_tol differentiates."""
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.physics.laws.boundary import BoundaryLaw

    scenario = api.load(scene, overrides)
    steps = []
    shipped = BoundaryLaw.step_sensitivities

    def recording(law, f, dv, n, T, h, rtol=1e-6, atol=1e-6, dv_start=None):
        steps.append((law, f, dv, n, T, h, dv_start))
        return shipped(law, f, dv, n, T, h, rtol, atol, dv_start)

    import bench_variants
    with bench_variants.patched(BoundaryLaw, "step_sensitivities", recording):
        api.one_run(scenario, step_tol, find_fmus(tuple(scenario.fmus)))
    return steps


def differenced(law, f, dv, n, T, h, dv0, tol: float = 1e-12, relative: float = 1e-5) -> np.ndarray:
    """Rows (f1, F_mean), columns (f0, dv0, dv1): central differences of advance at tol."""
    import bench_variants
    from tribofmu.physics.laws.boundary import BoundaryLaw

    with bench_variants.patched(BoundaryLaw, "MAX_SUBSTEPS", 100 * BoundaryLaw.MAX_SUBSTEPS):
        return _differenced(law, f, dv, n, T, h, dv0, tol, relative)


def _differenced(law, f, dv, n, T, h, dv0, tol: float, relative: float) -> np.ndarray:
    base, columns = [f, dv0, dv], []
    for k in range(3):
        step = relative * max(abs(base[k]), 1e-6 if k else 1e-3)
        up, down = list(base), list(base)
        up[k] += step
        down[k] -= step
        a = law.advance(up[0], up[2], n, T, h, tol, tol, up[1])
        b = law.advance(down[0], down[2], n, T, h, tol, tol, down[1])
        columns.append((np.array(a) - np.array(b)) / (2.0 * step))
    return np.array(columns).T


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="fig6_boundary")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--step-tol", type=float, default=1e-3)
    parser.add_argument("--tols", default="1e-5,1e-6")
    parser.add_argument("--samples", type=int, default=40)
    parser.add_argument("--variant", default=None)
    args = parser.parse_args()
    overrides = {key: float(value) for key, value in (item.split("=", 1) for item in args.set)}
    tols = [float(tol) for tol in args.tols.split(",")]

    steps = record_steps(args.scene, overrides, args.step_tol)
    crossing, other = [], []
    for step in steps:
        law, f, dv, n, T, h, dv0 = step
        threshold = law.melt_threshold()
        f1 = law.advance(f, dv, n, T, h, 1e-10, 1e-10, dv0)[0]
        (crossing if threshold is not None and (f - threshold) * (f1 - threshold) < 0.0 else other).append(step)
    rng = np.random.default_rng(0)
    groups = {"crossing": crossing[:: max(1, len(crossing) // args.samples)][: args.samples],
              "other": [other[i] for i in rng.choice(len(other), min(len(other), args.samples), replace=False)]}
    print(f"# bench_map_sensitivity {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}; {args.scene} {overrides or ''}, per-step {args.step_tol:g}, "
          f"{len(steps)} steps, {len(crossing)} across the melt threshold; variant {args.variant or 'shipped'}",
          flush=True)
    print(f"{'steps':9s} {'tol':>6s} {'n':>4s}   {'f row: median':>13s} {'p90':>8s} {'max':>8s}   "
          f"{'F dv entries: median':>20s} {'p90':>8s} {'max':>8s}")
    if args.variant:  # (after the run is recorded: its steps are the shipped code's)
        import bench_trust
        bench_trust.patch_variant(args.variant)
    for name, group in groups.items():
        truth = [differenced(law, f, dv, n, T, h, dv0) for law, f, dv, n, T, h, dv0 in group]
        for tol in tols:
            f_errors, F_errors = [], []
            for (law, f, dv, n, T, h, dv0), exact in zip(group, truth):
                got = law.step_sensitivities(f, dv, n, T, h, tol, tol, dv_start=dv0)
                if got is None:
                    continue
                rows = np.array(got[1])
                scale = np.array([1.0, max(abs(dv0), abs(dv)), max(abs(dv0), abs(dv))])
                f_errors.append(np.max(np.abs((rows[0] - exact[0]) * scale)) / np.max(np.abs(exact[0] * scale)))
                F_errors.append(np.max(np.abs(rows[1, 1:] - exact[1, 1:])) / np.max(np.abs(exact[1, 1:])))
            if not f_errors:
                continue
            f_e, F_e = np.array(f_errors), np.array(F_errors)
            print(f"{name:9s} {tol:6.0e} {len(f_e):4d}   {np.median(f_e):13.1e} {np.percentile(f_e, 90):8.1e} "
                  f"{f_e.max():8.1e}   {np.median(F_e):20.1e} {np.percentile(F_e, 90):8.1e} {F_e.max():8.1e}",
                  flush=True)


if __name__ == "__main__":
    main()
