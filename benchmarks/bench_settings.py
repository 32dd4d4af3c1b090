"""What a tuning value buys: one run per case (the reported run's per-step tolerance, no check)
with coupling/settings.py's values as shipped and with the values given, in one process.

    python benchmarks/bench_settings.py ["errors.stuck_hold_growth=1.0" ...] [--only LABEL]

A variant is ``group.name=value[;group.name=value...]``, the group one of ``coupling``
(CouplingSettings, the implicit step), ``errors`` (ErrorSettings, the embedded estimate) and
``step`` (STEP_CONTROL, the step-size rule); ``inf`` is a value. Per case it prints accepted
steps, rejected / accepted, FMU calls per accepted step, coupling iterations, forced steps, the
run's own error estimate and its true error against the reference solution (none for
boundary_heating, whose reference has no Thermal), and the FMU calls of all cases. Counts, not
timings: they hold on a shared machine. Each variant's instance values are set on the classes
that read them (as an instance may be given others: ``settings``, ``errors``, ``controller``).
Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
from pathlib import Path

# (label, scene, overrides, per-step tol): the shipped scenes' reported runs and off-scene
# boundary, solid-lubricant, mixed and shear-thinning points
CASES = [
    ("fig6", "fig6_boundary", {}, 3e-4),
    ("fig6@1e-3", "fig6_boundary", {}, 1e-3),
    ("fig2", "fig2_dry", {}, 1e-3),
    ("b g=-0.3", "fig6_boundary", {"friction.gamma": -0.3}, 1e-4),
    ("b g=0", "fig6_boundary", {"friction.gamma": 0.0}, 1e-4),
    ("b g=2", "fig6_boundary", {"friction.gamma": 2.0}, 1e-4),
    ("solid", "fig6_boundary", {"friction.gamma": -0.85, "block.K": 2000.0}, 3e-5),
    ("mixed", "mixed_stribeck", {}, 1e-3),
    ("pseudo-0.9", "fig5_pseudoplastic", {"friction.gamma": -0.9}, 1e-3),
    ("heating", "boundary_heating", {}, 1e-3),
]


def setting(item: str):
    """(the class that reads it, its attribute, the new settings object) of one
    ``group.name=value``."""
    from tribofmu.coupling import controlled, embedded, implicit

    owners = {"coupling": (implicit.ImplicitCoupling, "settings"), "errors": (embedded.EmbeddedCoupling, "errors"),
              "step": (controlled.ErrorControlledCoupling, "controller")}
    key, value = item.split("=")
    group, name = key.strip().split(".")
    owner, attribute = owners[group]
    return owner, attribute, dataclasses.replace(getattr(owner, attribute), **{name: float(value)})


def apply(variant: str) -> None:
    """Set the variant's values on the classes that read them."""
    for item in filter(None, variant.split(";")):
        owner, attribute, value = setting(item)
        setattr(owner, attribute, value)


def run_cases(only: str | None) -> int:
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.scene.library import resolve_scene
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms, reference_solution

    fmu_dir = Path(find_fmus(("Drive", "BlockSpring", "Friction", "Thermal", "Load")))
    total = 0
    for label, scene, overrides, step_tol in CASES:
        if only is not None and only not in label:
            continue
        scenario = load_scenario(resolve_scene(scene), overrides)
        result = api.one_run(scenario, step_tol, fmu_dir, 300.0)
        stats = result.stats
        true = math.nan
        if scene != "boundary_heating" and result.ok:
            reference = reference_solution(scenario)
            true = nrms(result.time, result.v, reference.time, reference.v, scenario.window)
        estimate = stats["estimated_error"]["nrms_v"]
        steps = stats["communication_steps"]
        total += stats["fmu_calls_total"]
        print(f"  {label:11s} per-step {step_tol:.0e}: steps {steps:6d}, rejected {stats['rejected_steps'] / steps:.3f}, "
              f"calls/step {stats['fmu_calls_per_step']['total']:5.2f}, iterations {stats['coupling_iterations']:6d}, "
              f"forced {stats['forced_steps']:3d}, estimate {estimate if estimate is not None else math.nan:.2e}, "
              f"true {true:.2e}", flush=True)
    print(f"  FMU calls of all cases: {total}", flush=True)
    return total


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("variants", nargs="*", help='e.g. "errors.stuck_hold_growth=1.0"')
    parser.add_argument("--only", default=None, help="run only the cases whose label holds this")
    args = parser.parse_args()
    print(f"# bench_settings {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC", flush=True)
    from tribofmu.coupling import controlled, embedded, implicit

    shipped = (implicit.ImplicitCoupling.settings, embedded.EmbeddedCoupling.errors,
               controlled.ErrorControlledCoupling.controller)
    for variant in [""] + args.variants:
        implicit.ImplicitCoupling.settings, embedded.EmbeddedCoupling.errors, \
            controlled.ErrorControlledCoupling.controller = shipped
        apply(variant)
        print(f"{variant or 'as shipped'}:", flush=True)
        run_cases(args.only)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
