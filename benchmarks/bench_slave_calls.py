"""Cost per FMU call: the raw C functions the master's hot path uses vs fmpy's public calls.

    python tests/bench_slave_calls.py [--calls N]

Three ways to make the calls a coupling step repeats thousands of times (set two reals,
get two reals, do a step, get and set the FMU state) on one BlockSpring instance:

- ``raw``: the ctypes functions fmpy loaded (``FMU2Slave._functions``, private), with value
  reference and value arrays built once (what :class:`tribofmu.master.instance.FMUInstance` does);
- ``fmpy-low``: fmpy's public ``fmi2SetReal(component, vr, n, values)`` methods, same arrays;
- ``fmpy``: fmpy's public ``setReal(vr, values)``, ``getReal``, ``doStep``, ``getFMUstate``.

Prints microseconds per call (median of 5 repeats) and the ratio to ``raw``.
"""
from __future__ import annotations

import argparse
import ctypes
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fmu_src"))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--calls", type=int, default=20000)
    args = parser.parse_args()

    from fmpy.fmi2 import fmi2FMUstate, fmi2Real, fmi2ValueReference
    from tribofmu.build import build_fmus
    from tribofmu.master.instance import FMUInstance

    with tempfile.TemporaryDirectory() as tmp:
        build_fmus(tmp, ("BlockSpring",))
        slave = FMUInstance(Path(tmp) / "BlockSpring.fmu", "block", {"M": 0.6, "K": 7000.0})
        fmu, comp = slave._fmu, slave._fmu.component
        refs = [slave.refs["F"], slave.refs["V"]]
        outs = [slave.refs["x"], slave.refs["v"]]
        vr_in, vr_out = (fmi2ValueReference * 2)(*refs), (fmi2ValueReference * 2)(*outs)
        buf_in, buf_out = (fmi2Real * 2)(), (fmi2Real * 2)()
        raw = fmu._functions
        h, t = 1e-5, [0.0]

        def raw_cycle():
            buf_in[:] = [1.0, 0.01]
            raw["fmi2SetReal"](comp, vr_in, 2, buf_in)
            raw["fmi2DoStep"](comp, t[0], h, 1)
            raw["fmi2GetReal"](comp, vr_out, 2, buf_out)
            state = fmi2FMUstate()
            raw["fmi2GetFMUstate"](comp, ctypes.byref(state))
            raw["fmi2SetFMUstate"](comp, state)
            raw["fmi2FreeFMUstate"](comp, ctypes.byref(state))
            t[0] += h
            return buf_out[:]

        def low_cycle():
            buf_in[:] = [1.0, 0.01]
            fmu.fmi2SetReal(comp, vr_in, 2, buf_in)
            fmu.fmi2DoStep(comp, t[0], h, 1)
            fmu.fmi2GetReal(comp, vr_out, 2, buf_out)
            state = fmi2FMUstate()
            fmu.fmi2GetFMUstate(comp, ctypes.byref(state))
            fmu.fmi2SetFMUstate(comp, state)
            fmu.fmi2FreeFMUstate(comp, ctypes.byref(state))
            t[0] += h
            return buf_out[:]

        def public_cycle():
            fmu.setReal(refs, [1.0, 0.01])
            fmu.doStep(t[0], h)
            values = fmu.getReal(outs)
            state = fmu.getFMUstate()
            fmu.setFMUstate(state)
            fmu.freeFMUstate(state)
            t[0] += h
            return values

        cycles = max(1, args.calls // 6)  # 6 calls per cycle
        results = {}
        for name, cycle in (("raw", raw_cycle), ("fmpy-low", low_cycle), ("fmpy", public_cycle)):
            runs = []
            for _ in range(5):
                begin = time.perf_counter()
                for _ in range(cycles):
                    cycle()
                runs.append((time.perf_counter() - begin) / (6 * cycles) * 1e6)
            results[name] = statistics.median(runs)
        slave.close()
    for name, us in results.items():
        print(f"{name:9s} {us:6.2f} us/call  ({us / results['raw']:.2f}x raw)")


if __name__ == "__main__":
    main()
