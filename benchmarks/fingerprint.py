"""The coupling's fingerprint: what a structural change of coupling/ must leave identical.

    python benchmarks/fingerprint.py [--fmu-dir DIR] [--scenes fig2_dry,fig6_boundary,...]

Runs shipped scenes in process (``tribofmu.api.simulate``, the default call: an adaptive run's
check runs included) and, on in-process parts, fig. 2's rig under every registered algorithm and
the step-doubling coupling of ``benchmarks/doubling.py``; prints per run the accepted and
rejected steps, the FMU calls, the estimated error and a hash of the result arrays (time, x, v,
F, f, stuck). A refactoring that is meant to change nothing must print the same lines, digit
for digit (diff two outputs). Not a timing: wall times are left out on purpose.

``--fmu-dir`` runs the scenes on FMUs built once (e.g. ``tribofmu build --out DIR`` before the
change): the master-side coupling is then the only thing that differs between two runs
(the default, the per-source FMU cache, rebuilds the FMUs after every change of coupling/,
which the pair FMU ships).
"""
from __future__ import annotations

import argparse
import hashlib
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

SCENES = ("fig2_dry", "fig6_boundary", "mixed_stribeck", "fig5_newtonian", "boundary_heating")


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for array in arrays:
        h.update(np.ascontiguousarray(np.asarray(array, dtype=float)).tobytes())
    return h.hexdigest()[:16]


def scene_line(name: str, fmu_dir: str | None) -> str:
    from tribofmu import api

    result = api.simulate(name, fmu_dir=fmu_dir, build=False if fmu_dir else None, max_wall=None)
    s = result.stats
    estimate = s.get("estimated_error") or {}
    return (f"{name:22s} ok={result.ok} steps={s['communication_steps']} rejected={s['rejected_steps']} "
            f"landed={s['landed_events']} iterations={s['coupling_iterations']} calls={s['fmu_calls_total']} "
            f"estimated={estimate.get('nrms_v')!r} "
            f"hash={digest(result.time, result.x, result.v, result.F, result.f, result.stuck)}")


def harmonic_drive(A: float, omega: float):
    """Fig. 2's drive X = A cos(omega t) as an in-process part (the coupling's own slave shape)."""
    from tribofmu.coupling.inprocess import InProcessSlave
    from tribofmu.physics import drive

    class HarmonicDrive(InProcessSlave):
        variables = ("X", "V", "a")
        state = ("X", "V", "a")

        def __init__(self):
            super().__init__("drive")
            self.X, self.V, self.a = drive(0.0, A, omega)

        def advance(self, t, h):
            self.X, self.V, self.a = drive(t + h, A, omega)

    return HarmonicDrive()


def inprocess_line(name: str, tol: float) -> str:
    """Fig. 2's rig (dry, omega = 30) on the coupling's in-process parts, one period."""
    from tribofmu.coupling.algorithms import Scales, make_algorithm
    from tribofmu.coupling.inprocess import BlockPart, FrictionPart
    from tribofmu.coupling.system import CoupledSystem
    from tribofmu.master.run import run
    from tribofmu.physics import DryLaw, MixedLaw

    A, omega = 2e-3, 30.0
    scales = Scales(A, A * omega, 2 * math.pi / omega)
    results = []
    for law in (DryLaw(mu_friction=0.5, S=1.0),
                MixedLaw(mu_friction=0.4, mu_static=0.6, v_stribeck=0.03, stribeck_exponent=1.0, m=5.0, S=1.0)):
        system = CoupledSystem(BlockPart("block", 0.6, 7000.0, 0.0, 0.0), harmonic_drive(A, omega),
                               FrictionPart("friction", law, 0.0, -20.0, 290.0), {"n": -20.0, "T": 290.0})
        algorithm = make_algorithm(name, step=2e-4, tol=tol)
        outcome = run(system, algorithm, scales.period, scales)
        p = outcome.points
        arrays = [[q.t_ns for q in p], [q.x for q in p], [q.v for q in p], [q.F for q in p], [q.f for q in p],
                  [q.global_error for q in p]]
        c = outcome.counters
        results.append(f"{type(law).__name__}: ok={outcome.ok} steps={c['steps']} rejected={c['rejected']} "
                       f"landed={c.get('landed', 0)} iterations={c['iterations']} "
                       f"calls={sum(outcome.calls.values())} hash={digest(*arrays)}")
    return f"inprocess {name:12s} " + " | ".join(results)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", default=None)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--no-scenes", action="store_true", help="only the in-process runs")
    args = parser.parse_args(argv)
    try:
        import doubling
        doubling.register()  # ("doubling" beside the package's algorithms)
    except ImportError:  # (a tree from before it moved out of the package)
        pass
    from tribofmu.coupling.algorithms import ALGORITHMS

    for name in sorted(ALGORITHMS):
        print(inprocess_line(name, 1e-4), flush=True)
    if not args.no_scenes:
        for scene in args.scenes.split(","):
            print(scene_line(scene, args.fmu_dir), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
