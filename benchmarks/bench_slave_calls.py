"""Cost per FMU call: how the master's hot path reaches the FMU's C functions, three ways.

    python benchmarks/bench_slave_calls.py [--calls N] [--fmi 2|3]
    python benchmarks/bench_slave_calls.py --scene fig6_boundary [--repeats N]

The calls a coupling step repeats thousands of times (set two reals, do a step, get two reals,
get, set and free the FMU state) on one BlockSpring instance, with value-reference and value
arrays built once:

- ``functions``: the ctypes functions of the FMU's library called directly (here from fmpy's
  private ``_functions`` dict, fmpy >= 0.3.26; :class:`tribofmu.master.instance.FMUInstance`
  makes its own, with their C signatures, ``hot_path_functions``, and checks the status itself);
- ``fmpy-low``: fmpy's public per-function methods, ``fmi2SetReal(component, vr, n, values)``
  and the like (fmpy >= 0.3.20: each checks the status and raises on an error), what
  :class:`~tribofmu.master.instance.FMUInstance` called before 2026-11-27;
- ``fmpy``: fmpy's public convenience calls ``setReal(vr, values)``, ``getReal``, ``doStep``,
  ``getFMUstate`` (FMI 3.0: ``setFloat64`` ...), which build the ctypes arrays on every call.

With ``--scene``: the scene's default call (``tribofmu.api.simulate``) in this process, its
instances' hot path bound to ``functions`` (FMUInstance's own) or to ``fmpy-low`` in turn (both
check the calls' statuses), the CPU time's minimum over the repeats; both print their steps and
error, which must agree.

Measured 2026-11-26 23:29 UTC, fmpy 0.3.32, load average 10-11 on 2 cores (us a call, FMI 2.0 /
3.0): ``functions`` 3.02 / 3.35-3.45, ``fmpy-low`` 3.33-3.39 / 3.57-3.73, ``fmpy`` 3.66 / 4.05-4.18.
On whole default calls (``--scene``, 23:30-23:32 UTC, load 12), ``fmpy-low`` against
``functions``: fig6_boundary 3.386 s against 3.373 s (min of 3), fig2_dry 0.313 s against
0.317 s (min of 5), the same steps and errors: below 1 %, within the noise of a busy machine.
The master then kept fmpy's public methods; since 2026-11-27 it calls the functions itself
(the FMUInstance layer around each call also got leaner: together about 0.8 us a call).

Prints microseconds of CPU time per call (the FMU runs in this process: its Python is in this
process's CPU time, which a busy machine disturbs far less than the wall clock), the median of
5 repeats taken in turn, and the ratio to the first way.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fmu_src"))


def cycles(fmu, comp, fmi: int, refs, outs):
    """The three ways to make one cycle of the six calls, by name."""
    if fmi == 3:
        from fmpy.fmi3 import fmi3Boolean, fmi3Float64, fmi3FMUState as State, fmi3ValueReference as VR
        real = fmi3Float64
        flags = (fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64())
        step_tail = (False,) + tuple(ctypes.byref(flag) for flag in flags)
        names = ("fmi3SetFloat64", "fmi3DoStep", "fmi3GetFloat64", "fmi3GetFMUState", "fmi3SetFMUState",
                 "fmi3FreeFMUState")
    else:
        from fmpy.fmi2 import fmi2FMUstate as State, fmi2Real, fmi2ValueReference as VR
        real = fmi2Real
        step_tail = (1,)
        names = ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal", "fmi2GetFMUstate", "fmi2SetFMUstate",
                 "fmi2FreeFMUstate")
    vr_in, vr_out = (VR * 2)(*refs), (VR * 2)(*outs)
    buf_in, buf_out = (real * 2)(), (real * 2)()
    counts = (vr_in, 2, buf_in, 2) if fmi == 3 else (vr_in, 2, buf_in)
    counts_out = (vr_out, 2, buf_out, 2) if fmi == 3 else (vr_out, 2, buf_out)
    h, t = 1e-5, [0.0]

    def by(functions):
        set_real, do_step, get_real, get_state, set_state, free_state = functions

        def cycle():
            buf_in[:] = [1.0, 0.01]
            set_real(comp, *counts)
            do_step(comp, t[0], h, *step_tail)
            get_real(comp, *counts_out)
            state = State()
            get_state(comp, ctypes.byref(state))
            set_state(comp, state)
            free_state(comp, ctypes.byref(state))
            t[0] += h
            return buf_out[:]
        return cycle

    def convenience():
        if fmi == 3:
            fmu.setFloat64(refs, [1.0, 0.01])
            fmu.doStep(t[0], h, noSetFMUStatePriorToCurrentPoint=False)
            values = fmu.getFloat64(outs)
            state = fmu.getFMUState()
            fmu.setFMUState(state)
            fmu.freeFMUState(state)
        else:
            fmu.setReal(refs, [1.0, 0.01])
            fmu.doStep(t[0], h)
            values = fmu.getReal(outs)
            state = fmu.getFMUstate()
            fmu.setFMUstate(state)
            fmu.freeFMUstate(state)
        t[0] += h
        return values

    ways = {}
    private = getattr(fmu, "_functions", None)
    if private is not None:
        ways["functions"] = by([private[name] for name in names])
    ways["fmpy-low"] = by([getattr(fmu, name) for name in names])
    ways["fmpy"] = convenience
    return ways


def whole_calls(scene: str, repeats: int) -> None:
    """The scene's default call with the instances' hot path bound each way in turn."""
    from tribofmu.api import simulate
    from tribofmu.master.instance import FMUInstance

    own = FMUInstance._bind_hot_path  # the library's functions with their C signatures

    def public(self):  # fmpy's per-function methods (they return the status, raising above Warning)
        own(self)
        for key, name in self._names.items():
            setattr(self, f"_{key}_c", getattr(self._fmu, name))

    ways = {"functions": own, "fmpy-low": public}
    cpu: dict[str, list[float]] = {name: [] for name in ways}
    outcome = {}
    simulate(scene)  # imports, FMUs built or found, libraries loaded
    for _ in range(repeats):
        for name, bind in ways.items():
            FMUInstance._bind_hot_path = bind
            begin = time.process_time()
            stats = simulate(scene).stats
            cpu[name].append(time.process_time() - begin)
            outcome[name] = (stats["communication_steps"], stats["estimated_error"]["nrms_v"])
    FMUInstance._bind_hot_path = own
    print(f"{scene}: default call, CPU time, min of {repeats} (load average {os.getloadavg()[0]:.1f})")
    first = min(cpu["functions"])
    for name, times in cpu.items():
        steps, error = outcome[name]
        print(f"{name:9s} {min(times):7.3f} s  ({min(times) / first:.3f}x)  {steps} steps, error {error:.6e}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--calls", type=int, default=30000)
    parser.add_argument("--fmi", type=int, choices=(2, 3), default=2)
    parser.add_argument("--scene", help="time the scene's whole default call instead")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if args.scene:
        whole_calls(args.scene, args.repeats)
        return

    import fmpy
    from tribofmu.build import build_fmus
    from tribofmu.master.instance import FMUInstance

    with tempfile.TemporaryDirectory() as tmp:
        build_fmus(tmp, ("BlockSpring",), fmi=args.fmi)
        slave = FMUInstance(Path(tmp) / "BlockSpring.fmu", "block", {"M": 0.6, "K": 7000.0})
        refs = [slave.refs["F"], slave.refs["V"]]
        outs = [slave.refs["x"], slave.refs["v"]]
        ways = cycles(slave._fmu, slave._fmu.component, args.fmi, refs, outs)
        n = max(1, args.calls // 6)  # 6 calls per cycle
        runs: dict[str, list[float]] = {name: [] for name in ways}
        for _ in range(5):  # interleaved: a load that changes hits every way alike
            for name, cycle in ways.items():
                begin = time.process_time()
                for _ in range(n):
                    cycle()
                runs[name].append((time.process_time() - begin) / (6 * n) * 1e6)
        slave.close()
    results = {name: statistics.median(us) for name, us in runs.items()}
    first = next(iter(results.values()))
    print(f"fmpy {fmpy.__version__}, FMI {args.fmi}.0, BlockSpring, {6 * n} calls a way, median of 5 "
          f"(CPU time; load average {os.getloadavg()[0]:.1f})")
    for name, us in results.items():
        print(f"{name:9s} {us:6.2f} us/call  ({us / first:.2f}x)")


if __name__ == "__main__":
    main()
