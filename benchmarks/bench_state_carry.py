"""What carrying a friction state's error costs a run (coupling/estimate.py, issue 36).

    python benchmarks/bench_state_carry.py [--rounds 3] [--tol 1e-3]

Fig. 6's run at a per-step tolerance (the first run of its default call), in one process, with
the lubricant's error carried by each slip step's own map (``map``: the law's step sensitivities,
``coupling/variational.py`` ``lubricant_step``, the shipped carry), by the law's slopes at the
step's middle (``middle``: ``GlobalErrorEstimate.state_slopes`` and ``state_flow``) and without
(the slopes withheld: the block's 2x2 carry, ``_flow``), rounds interleaved. Prints each run's wall and CPU time and the time spent inside those pieces (timed
call by call: a whole run's time moves by more than they cost on a shared machine). The runs
take the same steps either way: the estimate does not steer a boundary run.
"""
from __future__ import annotations

import argparse
import datetime
import os
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tol", type=float, default=1e-3)
    args = parser.parse_args()

    import bench_front
    from tribofmu import api
    from tribofmu.coupling import embedded, estimate
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.scene.library import resolve_scene
    from tribofmu.scene.scenario import load_scenario

    scenario = load_scenario(resolve_scene("fig6_boundary"), {})
    fmu_dir = Path(find_fmus(scenario.fmus))
    spent: dict[str, float] = {}

    def timed(name, function):
        return bench_front.timed(spent, name, function)

    carry = estimate.GlobalErrorEstimate
    slopes, state_flow, flow = carry.state_slopes, estimate.state_flow, carry._flow
    estimate.state_flow, carry._flow = timed("state_flow", state_flow), timed("_flow", flow)
    print(f"# bench_state_carry {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}; fig6_boundary, per-step tol {args.tol:g}", flush=True)
    variants = ("map", "middle", "without")
    inside: dict[str, list[float]] = {name: [] for name in variants}
    step_map = embedded.lubricant_step
    for i in range(args.rounds):
        for variant in (variants if i % 2 == 0 else variants[::-1]):
            spent.clear()
            carry.state_slopes = timed("state_slopes", slopes) if variant != "without" else (lambda self, *a: None)
            embedded.lubricant_step = timed("lubricant_step", step_map) if variant == "map" else (lambda *a: None)
            wall, cpu = time.perf_counter(), time.process_time()
            result = api.one_run(scenario, args.tol, fmu_dir)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            inside[variant].append(sum(spent.values()))
            pieces = ", ".join(f"{name} {seconds * 1e3:.1f} ms" for name, seconds in sorted(spent.items()))
            print(f"{variant:8s} the state's carry: {result.stats['communication_steps']} steps, wall {wall:.3f} s, "
                  f"CPU {cpu:.3f} s; inside {pieces}", flush=True)
    carry.state_slopes, estimate.state_flow, carry._flow, embedded.lubricant_step = slopes, state_flow, flow, step_map
    for variant in variants[:2]:
        more = min(inside[variant]) - min(inside["without"])
        print(f"the state's carry by {variant} costs {more * 1e3:.1f} ms a run more (the fastest of each)")

if __name__ == "__main__":
    main()
