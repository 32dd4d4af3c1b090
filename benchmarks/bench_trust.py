"""Issue 27's targets, measured: does ``--tol`` give the error the user gets, and does every
run that misses it say so?

    python benchmarks/bench_trust.py [--tols default,1e-3,1e-4] [--only SUBSTRING] [--out FILE.json]
    python benchmarks/bench_trust.py --one-run [--tols default] [--only SUBSTRING]
    python benchmarks/bench_trust.py --extra [--tols ...]   (EXTRA_POINTS instead of POINTS)
    python benchmarks/bench_trust.py --settings "coupling.max_ramp_gain=inf" ...   (other tuning)
    python benchmarks/bench_trust.py --variant no-force-term ...   (a bench_variants.py variant)
    python benchmarks/bench_trust.py --random 901:12 [--kinds boundary]   (seeded random points)

At Fig. 2's and Fig. 6's scenes and at parameter points no scene uses (dry, fluid, boundary and
mixed friction across docs/model.md's ranges), each run of ``tribofmu.api.simulate`` (whole
call, its checks included) is compared with the independent reference (``studies.reference``,
rtol 1e-10). Printed per run: the tol asked (``default`` is the scene's own, 1e-3), the error
reported (``stats["estimated_error"]["nrms_v"]``), the true nRMS(v) on the window, their
ratio, ``ok``, the wall time, the per-step tolerances run. Then the targets:

- silent misses: runs with true error past 3x tol that end ok (target: 0);
- reported / true within [0.5, 10] (or both below tol/10);
- true / tol within [0.03, 1.5];
- at the defaults every point meets 1e-3, each run under 30 s.

``--one-run`` asks instead whether one run could vouch for itself (issue 36): each point's
first run of a call (per-step tolerance = tol, no check), its own propagated estimate
(``coupling/estimate.py``) against its true error. A call could skip its check only where that
ratio stays within [0.5, 10] at every point. Its last column, ``near_melt``, is the run's
closest passage near a melt it did not take (``coupling/passages.py``; 1 or more: it cannot vouch).

Not collected by pytest (no test_ prefix). Timings are of a shared machine: see the load
printed at the start and the end.
"""
from __future__ import annotations

import argparse
import contextlib
import datetime
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

POINTS = [
    # the paper's scenes themselves (the band target names them)
    ("fig2 scene", "fig2_dry", {}),
    ("fig6 scene", "fig6_boundary", {}),
    # dry friction: slow drives, light and heavy blocks, another friction coefficient
    ("dry omega=3", "fig2_dry", {"drive.omega": 3.0}),
    ("dry M=0.05", "fig2_dry", {"block.M": 0.05}),
    ("dry omega=25 M=0.8", "fig2_dry", {"drive.omega": 25.0, "block.M": 0.8}),
    ("dry mu=0.2 omega=50", "fig2_dry", {"friction.mu_friction": 0.2, "drive.omega": 50.0}),
    # fluids
    ("pseudoplastic gamma=-0.4 m=15", "fig5_pseudoplastic", {"friction.gamma": -0.4, "friction.m": 15.0}),
    ("dilatant gamma=1 omega=40", "fig5_dilatant", {"friction.gamma": 1.0, "drive.omega": 40.0}),
    ("newtonian M=0.3 m=40", "fig5_newtonian", {"block.M": 0.3, "friction.m": 40.0}),
    # boundary friction: other viscous exponents, another frequency
    ("boundary gamma=-0.95", "fig6_boundary", {"friction.gamma": -0.95}),
    ("boundary gamma=-0.3", "fig6_boundary", {"friction.gamma": -0.3}),
    ("boundary gamma=0", "fig6_boundary", {"friction.gamma": 0.0}),
    ("boundary gamma=0.3", "fig6_boundary", {"friction.gamma": 0.3}),
    ("boundary gamma=1", "fig6_boundary", {"friction.gamma": 1.0}),
    ("boundary gamma=2", "fig6_boundary", {"friction.gamma": 2.0}),
    ("boundary omega=20", "fig6_boundary", {"drive.omega": 20.0}),
    # a lubricant that stays solid: the block creeps at |dv| ~ 1e-12 m/s on a viscous slope of
    # ~6.5e7 N/(m/s), where the solve's own resolution once collapsed the step (issue 36)
    ("boundary solid gamma=-0.85 K=2000", "fig6_boundary", {"friction.gamma": -0.85, "block.K": 2000.0}),
    # mixed (Stribeck) friction: other frequency, coefficients, Stribeck velocity and exponent
    ("mixed omega=18 mu_s=0.7", "mixed_stribeck", {"drive.omega": 18.0, "friction.mu_static": 0.7}),
    ("mixed v_s=0.03 delta=1", "mixed_stribeck", {"friction.v_stribeck": 0.03, "friction.stribeck_exponent": 1.0}),
    ("mixed M=0.3 m=0 mu_c=0.3", "mixed_stribeck", {"block.M": 0.3, "friction.m": 0.0, "friction.mu_friction": 0.3}),
]

# Points for --extra: more dry, fluid and mixed points no scene (and no list above) uses, where a
# run's own estimate may vouch for it (issue 36's one-run answer)
EXTRA_POINTS = [
    ("y dry omega=8 M=0.2", "fig2_dry", {"drive.omega": 8.0, "block.M": 0.2}),
    ("y dry K=500", "fig2_dry", {"block.K": 500.0}),
    ("y dry n=-10 omega=30", "fig2_dry", {"conditions.n": -10.0, "drive.omega": 30.0}),
    ("y dry mu=0.8", "fig2_dry", {"friction.mu_friction": 0.8}),
    ("y newtonian m=5 omega=20", "fig5_newtonian", {"friction.m": 5.0, "drive.omega": 20.0}),
    ("y newtonian m=100 M=0.5", "fig5_newtonian", {"friction.m": 100.0, "block.M": 0.5}),
    ("y dilatant gamma=2 omega=20", "fig5_dilatant", {"friction.gamma": 2.0, "drive.omega": 20.0}),
    ("y dilatant gamma=0.3 m=10", "fig5_dilatant", {"friction.gamma": 0.3, "friction.m": 10.0}),
    ("y mixed v_s=0.005", "mixed_stribeck", {"friction.v_stribeck": 0.005}),
    ("y mixed delta=3 omega=12", "mixed_stribeck", {"friction.stribeck_exponent": 3.0, "drive.omega": 12.0}),
    ("y mixed mu_s=0.9 M=0.4", "mixed_stribeck", {"friction.mu_static": 0.9, "block.M": 0.4}),
    ("y mixed m=10 K=1500", "mixed_stribeck", {"friction.m": 10.0, "block.K": 1500.0}),
    ("y mixed v_s=0.05 delta=1.2", "mixed_stribeck", {"friction.v_stribeck": 0.05,
                                                       "friction.stribeck_exponent": 1.2}),
    # shear-thinning fluids (an unbounded force slope at rest) across gamma, frequencies, masses
    ("y pseudoplastic gamma=-0.3", "fig5_pseudoplastic", {"friction.gamma": -0.3}),
    ("y pseudoplastic gamma=-0.5 omega=20", "fig5_pseudoplastic", {"friction.gamma": -0.5, "drive.omega": 20.0}),
    ("y pseudoplastic gamma=-0.7 M=0.2", "fig5_pseudoplastic", {"friction.gamma": -0.7, "block.M": 0.2}),
    ("y pseudoplastic gamma=-0.9", "fig5_pseudoplastic", {"friction.gamma": -0.9}),
    ("y pseudoplastic gamma=-0.95 omega=80 m=10", "fig5_pseudoplastic",
     {"friction.gamma": -0.95, "drive.omega": 80.0, "friction.m": 10.0}),
    ("y pseudoplastic gamma=-0.8 M=1.5 K=2000", "fig5_pseudoplastic",
     {"friction.gamma": -0.8, "block.M": 1.5, "block.K": 2000.0}),
    # boundary friction, since its runs vouch (issue 36): other blocks, loads, temperatures,
    # frequencies and viscous terms than the list above
    ("y boundary M=0.3 K=800", "fig6_boundary", {"block.M": 0.3, "block.K": 800.0}),
    ("y boundary n=-5e5 T=300", "fig6_boundary", {"conditions.n": -5e5, "conditions.T": 300.0}),
    ("y boundary omega=45 gamma=-0.5", "fig6_boundary", {"drive.omega": 45.0, "friction.gamma": -0.5}),
    ("y boundary gamma=0.6 m=0.1", "fig6_boundary", {"friction.gamma": 0.6, "friction.m": 0.1}),
    ("y boundary A=2e-6 omega=12", "fig6_boundary", {"drive.A": 2e-6, "drive.omega": 12.0}),
    ("y boundary M=1.5 gamma=-0.8", "fig6_boundary", {"block.M": 1.5, "friction.gamma": -0.8}),
    # hot dilatant films that melt and re-solidify 8-12 times a period (bench_trust --random 906:8
    # --kinds boundary, 2026-11-27): at tol 1e-2 their runs down to per-step 1e-3 (and 1e-4 for
    # the second) agree with each other on a motion 0.47 and 0.12 of max|v| off the reference,
    # their estimates 1e-3 to 1e-2 of that, and the calls say ok: silent misses, found after
    # session 8's code, which misses them the same way (not yet understood; docs/coupling-record.md)
    ("y boundary hot omega=11.33 gamma=1.7", "fig6_boundary",
     {"drive.omega": 11.33, "block.M": 0.9606, "block.K": 1761.0, "friction.gamma": 1.7, "conditions.T": 344.0}),
    ("y boundary hot omega=43.04 gamma=0.828", "fig6_boundary",
     {"drive.omega": 43.04, "block.M": 0.4219, "block.K": 7134.0, "friction.gamma": 0.828, "conditions.T": 322.0}),
    # the film that melts and re-solidifies every half period (bench_trust --random 907:8: r907.3), whose
    # carried estimates read 0.2x until the Friction FMU's F_mean followed its sub-steps' own means
    ("y boundary flicker omega=9.509 gamma=0.926", "fig6_boundary",
     {"drive.omega": 9.509, "block.M": 0.3985, "block.K": 2861.0, "friction.gamma": 0.926, "conditions.T": 336.0}),
    # Fig. 6's rig where a run's error drifts by about 1 % of max|v| each half period and its carry
    # does not follow the drift (per-step 3e-3: 0.27x; session 7's call said ok 9.8 % off at 1e-2)
    ("y boundary drift omega=15 gamma=1.5 M=0.4", "fig6_boundary",
     {"drive.omega": 15.0, "friction.gamma": 1.5, "block.M": 0.4}),
    # a cold dilatant film (bench_trust --random 908:8: r908.6) whose runs at per-step 1e-2 and 3e-3 read
    # 0.19x and 0.33x, no passage near a melt to tell; unverified, a call at tol 1e-2 said ok 2.4x off
    ("y boundary cold omega=20.56 gamma=0.893 T=262", "fig6_boundary",
     {"drive.omega": 20.56, "block.M": 0.2035, "block.K": 4005.0, "friction.gamma": 0.893, "conditions.T": 262.0}),
]


# --random: the ranges points are drawn from (log-uniform where a value spans decades), the four
# laws in turn. Wider than any scene or list above, inside docs/model.md's declared ranges and
# the paper's regimes (a compressive load; a Stribeck drop mu_s > mu_c; gamma > -1).
RANDOM_SCENES = {"dry": "fig2_dry", "fluid": "fig5_newtonian", "boundary": "fig6_boundary", "mixed": "mixed_stribeck"}


def random_points(seed: int, count: int, kinds: list[str]) -> list[tuple[str, str, dict]]:
    """count points (label, scene, overrides) drawn with random.Random(seed), cycling through
    kinds (of RANDOM_SCENES): the same seed gives the same points on any machine."""
    import math
    import random

    rng = random.Random(seed)

    def log_uniform(low: float, high: float) -> float:
        return float(f"{10 ** rng.uniform(math.log10(low), math.log10(high)):.4g}")

    def uniform(low: float, high: float) -> float:
        return float(f"{rng.uniform(low, high):.3g}")

    points = []
    for i in range(count):
        kind = kinds[i % len(kinds)]
        overrides = {"drive.omega": log_uniform(5.0, 80.0), "block.M": log_uniform(0.1, 1.5),
                     "block.K": log_uniform(500.0, 15000.0)}
        if kind == "dry":
            overrides |= {"friction.mu_friction": uniform(0.15, 0.9), "conditions.n": -log_uniform(5.0, 60.0)}
        elif kind == "fluid":
            overrides |= {"friction.gamma": uniform(-0.9, 1.8), "friction.m": log_uniform(3.0, 80.0)}
        elif kind == "boundary":
            overrides |= {"friction.gamma": uniform(-0.9, 1.8), "conditions.T": uniform(250.0, 350.0),
                          "block.K": log_uniform(500.0, 8000.0)}
        else:
            mu = uniform(0.2, 0.5)
            overrides |= {"friction.mu_friction": mu, "friction.mu_static": float(f"{mu + uniform(0.05, 0.4):.3g}"),
                          "friction.v_stribeck": log_uniform(0.003, 0.05),
                          "friction.stribeck_exponent": uniform(0.8, 3.0), "friction.m": uniform(0.0, 10.0)}
        label = f"r{seed}.{i} {kind} " + " ".join(f"{key.split('.')[1]}={value:g}" for key, value in overrides.items())
        points.append((label, RANDOM_SCENES[kind], overrides))
    return points


_VARIANT = contextlib.ExitStack()  # --variant's patches, held until the process ends


def patch_variant(name: str) -> None:
    """One of bench_variants.py's variants patched in for the rest of the process (the calls
    fork their runs from it)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_variants import patched, variant_patches

    for owner, attribute, value in variant_patches(name):
        _VARIANT.enter_context(patched(owner, attribute, value))
    print(f"# variant: {name}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tols", default="default,1e-3,1e-4")
    parser.add_argument("--only", default=None, help="run only the points whose label holds this")
    parser.add_argument("--max-wall", type=float, default=300.0, help="each run's budget [s]")
    parser.add_argument("--out", default=None)
    parser.add_argument("--table", default=None, metavar="ROWS.json[,ROWS.json]",
                        help="print the markdown summary of rows saved by --out (a point in a later file "
                             "replaces its row in an earlier one), run nothing")
    parser.add_argument("--extra", action="store_true",
                        help="the points of EXTRA_POINTS instead (dry, fluid and mixed points off the list)")
    parser.add_argument("--random", default=None, metavar="SEED:N",
                        help="N points drawn at random (seeded: the same points on any machine) instead")
    parser.add_argument("--kinds", default=",".join(RANDOM_SCENES),
                        help="--random's frictions, drawn in turn (default: all four)")
    parser.add_argument("--one-run", action="store_true",
                        help="each point's first run only: its propagated estimate against its true error")
    parser.add_argument("--settings", default="", metavar="VARIANT",
                        help="run with these tuning values instead of coupling/settings.py's, as "
                             "benchmarks/bench_settings.py takes them (group.name=value;...)")
    parser.add_argument("--variant", default="", metavar="NAME",
                        help="run with one of benchmarks/bench_variants.py's variants patched in (its "
                             "--variant names: no-force-term, a+b, ...) for the whole benchmark")
    args = parser.parse_args(argv)
    if args.variant:
        patch_variant(args.variant)
    if args.settings:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from bench_settings import apply

        apply(args.settings)
        print(f"# settings: {args.settings}", flush=True)
    global POINTS
    if args.extra:
        POINTS = EXTRA_POINTS
    if args.random:
        seed, count = (int(part) for part in args.random.split(":"))
        POINTS = random_points(seed, count, args.kinds.split(","))
    if args.one_run:
        return one_run([None if t == "default" else float(t) for t in args.tols.split(",")], args.only)
    if args.table:
        # a point measured again in a later file replaces its earlier row
        latest = {(row["point"], row["tol"]): row for path in args.table.split(",")
                  for row in json.loads(Path(path).read_text())}
        rows = list(latest.values())
        print(summary_table(rows))
        return 0

    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms
    from tribofmu.scene.library import resolve_scene

    tols = [None if t == "default" else float(t) for t in args.tols.split(",")]
    points = [p for p in POINTS if args.only is None or args.only in p[0]]
    fmu_dir = find_fmus(("Drive", "BlockSpring", "Friction"))
    print(f"# bench_trust {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'point':32s} {'tol':>7s} {'reported':>9s} {'true':>9s} {'rep/true':>8s} {'ok':>5s} "
          f"{'wall s':>7s}  per-step tols", flush=True)
    rows = []
    for label, scene, overrides in points:
        scenario = load_scenario(resolve_scene(scene), overrides)
        reference = trusted_reference(scenario, label)
        for tol in tols:
            begin = time.perf_counter()
            result = api.simulate(scenario, tol=tol, fmu_dir=fmu_dir, build=False, max_wall=args.max_wall)
            wall = time.perf_counter() - begin
            true = nrms(result.time, result.v, reference.time, reference.v, scenario.window) \
                if result.stats.get("completed", result.ok) else float("nan")
            reported = result.stats["estimated_error"]["nrms_v"]
            asked = result.stats["tol"]
            row = {"point": label, "tol": asked, "tol_given": tol, "reported": reported, "true": true,
                   "propagated": result.stats["estimated_error"].get("propagated"),
                   "ok": result.ok, "warned": bool(result.stats.get("warnings")), "wall": wall,
                   "step_tols": [r["step_tol"] for r in result.stats.get("check", {}).get("runs", [])],
                   # (where a run tightened for its window, coupling/lead_in.py: the tolerance it ended at)
                   "window_step_tols": [r.get("window_step_tol") for r in result.stats.get("check", {}).get("runs", [])]}
            rows.append(row)
            ratio = reported / true if reported and true else float("nan")
            print(f"{label:32s} {asked:7.0e} {reported if reported is not None else float('nan'):9.2e} "
                  f"{true:9.2e} {ratio:8.2f} {str(result.ok):>5s} {wall:7.1f}  "
                  f"{', '.join(_tols(s, w) for s, w in zip(row['step_tols'], row['window_step_tols']))}", flush=True)
    silent = [r for r in rows if r["true"] > 3 * r["tol"] and r["ok"]]
    off = [r for r in rows if r["ok"] and r["reported"] and not (
        0.5 <= r["reported"] / r["true"] <= 10 or max(r["reported"], r["true"]) < r["tol"] / 10)]
    band = [r for r in rows if r["ok"] and not 0.03 <= r["true"] / r["tol"] <= 1.5]
    defaults = [r for r in rows if r["tol_given"] is None]
    print(f"\nsilent misses (true > 3x tol, ok): {len(silent)} of {len(rows)}"
          + "".join(f"\n  {r['point']} tol {r['tol']:g}: true {r['true']:.2g}" for r in silent))
    print(f"reported/true outside [0.5, 10] (ok runs): {len(off)}"
          + "".join(f"\n  {r['point']} tol {r['tol']:g}: {r['reported']:.2g} vs {r['true']:.2g}" for r in off))
    print(f"true/tol outside [0.03, 1.5] (ok runs): {len(band)}"
          + "".join(f"\n  {r['point']} tol {r['tol']:g}: {r['true'] / r['tol']:.3g}" for r in band))
    if defaults:
        met = [r for r in defaults if r["true"] <= 1e-3]
        print(f"defaults meeting 1e-3: {len(met)} of {len(defaults)}; slowest "
              f"{max(r['wall'] for r in defaults):.1f} s")
    print(one_run_summary(rows))
    print(f"# load at the end {os.getloadavg()[0]:.1f}")
    print("\n" + summary_table(rows))
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


def _tols(asked: float, window: float | None) -> str:
    """A run's per-step tolerance, and the one it tightened to for its window (a > b)."""
    return f"{asked:.2g}" + (f">{window:.2g}" if window is not None and window < asked else "")


def trusted_reference(scenario, label: str):
    """The reference (studies.reference.converged_reference: rtol 1e-10, or where its stiff solver
    cannot step there, as at a shear-thinning boundary film at a random point, omega = 13.95,
    gamma = -0.689, T = 273, 1e-9 or 1e-8), the looser rtol said on its own line: still far below
    the tolerances judged (1e-4 and up)."""
    from tribofmu.studies.reference import converged_reference, looser_rtol

    reference = converged_reference(scenario)
    if not reference.ok:
        print(f"# {label}: no reference ({reference.message}): its rows cannot be judged", flush=True)
    elif looser_rtol(reference):
        print(f"# {label}: the reference at {looser_rtol(reference)}", flush=True)
    return reference


def one_run(tols: list, only: str | None) -> int:
    """Each point's first run (per-step tolerance = tol, unchecked): propagated / true."""
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.scene.library import resolve_scene
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms

    fmu_dir = find_fmus(("Drive", "BlockSpring", "Friction"))
    print(f"# bench_trust --one-run {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'point':36s} {'tol':>7s} {'propagated':>10s} {'true':>9s} {'prop/true':>9s} {'wall s':>7s} "
          f"{'near_melt':>9s}", flush=True)
    ratios = []
    for label, scene, overrides in POINTS:
        if only is not None and only not in label:
            continue
        scenario = load_scenario(resolve_scene(scene), overrides)
        reference = trusted_reference(scenario, label)
        for tol in tols:
            step_tol = tol if tol is not None else (scenario.simulation.tol or api.DEFAULT_TOL)
            begin = time.perf_counter()
            # one run of the adaptive coupling, as a checked call's first run
            result = api.one_run(scenario, step_tol, fmu_dir, 300.0)
            wall = time.perf_counter() - begin
            true = nrms(result.time, result.v, reference.time, reference.v, scenario.window) \
                if result.ok else float("nan")
            propagated = result.stats["estimated_error"]["nrms_v"]
            ratio = propagated / true if propagated is not None and true > 0 else float("nan")
            ratios.append(ratio)
            # (its closest passage near a melt it did not take: >= 1 cannot vouch, coupling/passages.py)
            near = result.stats["estimated_error"].get("near_melt")
            print(f"{label:36s} {step_tol:7.0e} {propagated if propagated is not None else float('nan'):10.2e} "
                  f"{true:9.2e} {ratio:9.3g} {wall:7.1f} {near if near is not None else float('nan'):9.3g}",
                  flush=True)
    finite = [q for q in ratios if q == q]
    inside = [q for q in finite if 0.5 <= q <= 10.0]
    if finite:
        print(f"propagated / true within [0.5, 10] at {len(inside)} of {len(finite)} runs "
              f"(range {min(finite):.2g}-{max(finite):.2g})")
    print(f"# load at the end {os.getloadavg()[0]:.1f}")
    return 0


def one_run_summary(rows: list[dict]) -> str:
    """What one run could vouch for (issue 36): the reported run's own propagated estimate
    (coupling/estimate.py, ``stats["estimated_error"]["propagated"]``) against its true
    error, and how many runs each call took."""
    ratios = [(r["propagated"] / r["true"], r) for r in rows
              if r.get("propagated") and r["true"] and r["true"] == r["true"]]
    inside = [q for q, _ in ratios if 0.5 <= q <= 10.0]
    runs = [len(r["step_tols"]) for r in rows]
    lines = [f"one run: propagated / true within [0.5, 10] at {len(inside)} of {len(ratios)} runs"
             + (f" (range {min(q for q, _ in ratios):.2g}-{max(q for q, _ in ratios):.2g})" if ratios else ""),
             "  runs per call: " + ", ".join(f"{n}: {runs.count(n)}" for n in sorted(set(runs)))]
    lines += [f"  {r['point']} tol {r['tol']:g}: propagated {r['propagated']:.2g} true {r['true']:.2g}"
              for q, r in ratios if not 0.5 <= q <= 10.0]
    return "\n".join(lines)


def family(label: str) -> str:
    """The friction a point runs: the label's first word, the three fluids as one."""
    word = label.split()[0]
    return "fluid" if word in ("pseudoplastic", "dilatant", "newtonian") else word


def summary_table(rows: list[dict]) -> str:
    """One markdown row per tol asked and friction: points, silent misses, the runs not met
    (ok false, said), reported / true and true / tol over the ok runs, wall times."""
    def span(values, fmt):
        if not values:
            return "–"
        low, high = fmt.format(min(values)), fmt.format(max(values))
        return low if low == high else f"{low}–{high}"

    lines = ["| tol | friction | points | silent misses | not met (said) | reported / true | true / tol | wall s |",
             "|---|---|---|---|---|---|---|---|"]
    order = ["fig2", "fig6", "dry", "fluid", "boundary", "mixed"]
    keys = sorted({(r["tol"], family(r["point"])) for r in rows},
                  key=lambda k: (-k[0], order.index(k[1]) if k[1] in order else len(order)))
    for tol, fam in keys:
        group = [r for r in rows if r["tol"] == tol and family(r["point"]) == fam]
        ok = [r for r in group if r["ok"]]
        silent = sum(1 for r in group if r["ok"] and r["true"] > 3 * r["tol"])
        ratios = [r["reported"] / r["true"] for r in ok if r["reported"] and r["true"]]
        lines.append(f"| {tol:g} | {fam} | {len(group)} | {silent} | {len(group) - len(ok)} | "
                     f"{span(ratios, '{:.2g}')} | {span([r['true'] / r['tol'] for r in ok], '{:.2g}')} | "
                     f"{span([r['wall'] for r in group], '{:.1f}')} |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
