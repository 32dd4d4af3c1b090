"""Master overhead per communication step against the bare cost of its FMU calls (fig2_dry).

    python benchmarks/bench_overhead.py [--repeats 5] [--profile]

1. Record every hot-path FMU call (set/get reals, do_step, save/restore/free state) that a
   simulate() run makes, with its arguments.
2. Replay the same sequence on fresh instances with a minimal loop: pre-built ctypes
   arguments, one direct C call per recorded call (what the calls cost with no master).
3. Time full simulate() runs (the run loop's own wall time, and the whole call including
   instantiation, sampling and the energy audit).

master overhead = (run loop time - replay time) / replay time. Target: <= 50 %.
Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import ctypes
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "fig2_dry.toml"
FMU_DIR = ROOT / "build"
CASES = (("jacobi h=1e-4", dict(algorithm="jacobi", step=1e-4)),
         ("adaptive default", dict(algorithm="adaptive")))


def record(scenario, **kw):
    """Run simulate() with every hot-path FMUInstance call logged: [(instance, op, args)]."""
    from tribofmu import api
    from tribofmu.master.instance import FMUInstance

    log = []
    ids = {}
    originals = {name: getattr(FMUInstance, name) for name in
                 ("set_reals", "get_reals", "do_step", "save", "restore", "free_state")}

    def wrap(name):
        fn = originals[name]

        def wrapper(self, *args):
            out = fn(self, *args)
            if name == "save":
                ids[id(out)] = len(ids)  # handles are ctypes objects: key by identity
                log.append((self.instance, name, (ids[id(out)], out)))
            elif name in ("restore", "free_state"):
                log.append((self.instance, name, (ids[id(args[0])],)))
            else:
                log.append((self.instance, name, tuple(list(a) if isinstance(a, list) else a for a in args)))
            return out
        return wrapper

    try:
        for name in originals:
            setattr(FMUInstance, name, wrap(name))
        result = api.simulate(scenario, fmu_dir=FMU_DIR, build=False, **kw)
    finally:
        for name, fn in originals.items():
            setattr(FMUInstance, name, fn)
    # drop the saved handles (kept alive above so that ids stay unique during the run)
    return [(i, op, a[:1] if op == "save" else a) for i, op, a in log], result


def fresh_slaves(scenario):
    from tribofmu.master.instance import FMUInstance
    from tribofmu.scene.wiring import fmu_parameters
    return {fmu.lower(): FMUInstance(FMU_DIR / f"{fmu}.fmu", instance=fmu.lower(), parameters=params)
            for fmu, params in fmu_parameters(scenario).items()}


def build_replay(log, slaves):
    """Pre-built (C function, args) pairs for the recorded calls."""
    from fmpy.fmi2 import fmi2FMUstate, fmi2Real, fmi2ValueReference

    states = {}
    ops = []
    for inst, op, args in log:
        s = slaves[inst]
        comp, c = s._component, s._c
        if op == "set_reals":
            refs, values = args
            ops.append((c["set"], (comp, (fmi2ValueReference * len(refs))(*refs), len(refs),
                                           (fmi2Real * len(values))(*values))))
        elif op == "get_reals":
            (refs,) = args
            ops.append((c["get"], (comp, (fmi2ValueReference * len(refs))(*refs), len(refs),
                                           (fmi2Real * len(refs))())))
        elif op == "do_step":
            t, h = args
            ops.append((c["step"], (comp, t, h, 1)))
        elif op == "save":
            st = states[args[0]] = fmi2FMUstate()
            ops.append((c["save"], (comp, ctypes.byref(st))))
        elif op == "restore":
            ops.append((c["restore"], (comp, states[args[0]])))
        elif op == "free_state":
            ops.append((c["free"], (comp, ctypes.byref(states[args[0]]))))
    return ops


def replay_time(scenario, log) -> float:
    slaves = fresh_slaves(scenario)
    try:
        ops = build_replay(log, slaves)
        begin = time.perf_counter()
        for fn, args in ops:
            fn(*args)
        return time.perf_counter() - begin
    finally:
        for s in slaves.values():
            s.close()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--profile", action="store_true", help="cProfile one run of each case")
    args = parser.parse_args(argv)
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    scenario = api.load(SCENARIO)
    find_fmus(scenario.fmus, FMU_DIR, build=True)  # from this source, never stale
    print(f"fig2_dry, {args.repeats} repeats, medians")
    print(f"{'case':18s} {'steps':>7s} {'calls':>8s} {'FMU-only':>9s} {'run loop':>9s} {'simulate':>9s} "
          f"{'us/step FMU':>11s} {'us/step master':>14s} {'overhead':>9s}")
    worst = 0.0
    for label, kw in CASES:
        log, result = record(scenario, **kw)
        steps = result.stats["communication_steps"]
        bare, loop, whole = [], [], []
        for _ in range(args.repeats):
            bare.append(replay_time(scenario, log))
            t0 = time.perf_counter()
            r = api.simulate(scenario, fmu_dir=FMU_DIR, build=False, **kw)
            whole.append(time.perf_counter() - t0)
            loop.append(r.stats["wall_time"])
        b, l, w = (statistics.median(x) for x in (bare, loop, whole))
        overhead = (l - b) / b
        worst = max(worst, overhead)
        print(f"{label:18s} {steps:7d} {len(log):8d} {b:8.3f}s {l:8.3f}s {w:8.3f}s {b / steps * 1e6:11.1f} "
              f"{(l - b) / steps * 1e6:14.1f} {overhead:8.0%}")
        if args.profile:
            import cProfile
            import pstats
            prof = cProfile.Profile()
            prof.enable()
            api.simulate(scenario, fmu_dir=FMU_DIR, build=False, **kw)
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(15)
    print(f"worst master overhead: {worst:.0%} (target <= 50 %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
