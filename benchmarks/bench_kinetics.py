"""The lubricant kinetics alone (``BoundaryLaw.advance``), on the inputs a scene's run gives it.

    python benchmarks/bench_kinetics.py record [--scene fig6_boundary] [--out FILE.pickle]
    python benchmarks/bench_kinetics.py replay [--calls FILE.pickle] [--repeat 5]

``record`` runs the scene's default call in this process (``tribofmu.api.simulate``, one check
worker, so every run of its check is here) on the FMUs built from this source, and keeps the
arguments of every ``BoundaryLaw.advance`` the Friction FMU made (a profile hook on the FMU's
own copy of physics/laws/boundary.py), with the law's parameters: the kinetics' whole workload
in one Fig. 6 call, in the order the FMU saw it (rejected steps included).

``replay`` calls ``BoundaryLaw.advance`` of the source on PYTHONPATH (tribofmu.physics, no FMI)
with those arguments, in order: per round the wall time of all calls (``--repeat`` rounds,
min and median), then once more with a profile hook counting the calls of every function of
boundary.py per advance (sub-steps, rate evaluations), and a digest of the results (f and the
mean force of every call): two sources whose digests are equal computed the same numbers, bit
for bit. Replay one recording under two PYTHONPATHs to compare them; the recording is the
same whichever code replays it.

Not collected by pytest (no test_ prefix); a timing: the machine's load is printed.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import pickle
import statistics
import struct
import sys
import time
from collections import Counter
from dataclasses import fields
from pathlib import Path

BOUNDARY_FILE = os.path.join("physics", "laws", "boundary.py")
ARGS = ("f", "dv", "n", "T", "h", "rtol", "atol", "dv_start")


def load_avg() -> str:
    try:
        return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()) + f" on {os.cpu_count()} cores"
    except OSError:
        return "load average n/a"


def law_parameters(law) -> dict:
    """The law's dataclass fields, nested dataclasses (lubricant, effects) as dicts."""
    out = {}
    for f in fields(law):
        value = getattr(law, f.name)
        out[f.name] = {g.name: getattr(value, g.name) for g in fields(value)} if hasattr(
            value, "__dataclass_fields__") else value
    return out


def record(scene: str, out: Path) -> None:
    from tribofmu import api

    calls: list[tuple] = []
    laws: list[dict] = []

    def hook(frame, event, arg):
        if event == "call" and frame.f_code.co_name == "advance" and frame.f_code.co_filename.endswith(BOUNDARY_FILE):
            args = frame.f_locals
            if not laws:
                laws.append(law_parameters(args["self"]))
            calls.append(tuple(args[name] for name in ARGS))

    start = time.perf_counter()
    sys.setprofile(hook)
    try:
        result = api.simulate(scene, check_workers=1, max_wall=None)
    finally:
        sys.setprofile(None)
    print(f"{scene}: ok={result.ok}, {result.stats['communication_steps']} steps in the reported run; "
          f"{len(calls)} advance calls recorded in {time.perf_counter() - start:.1f} s (hooked)")
    if not calls:
        raise SystemExit("no BoundaryLaw.advance call seen: is the scene's law boundary friction?")
    with open(out, "wb") as fh:
        pickle.dump({"scene": scene, "law": laws[0], "calls": calls}, fh)
    print(f"-> {out}")


def make_boundary_law(parameters: dict):
    from tribofmu.physics.friction import Effects, LubricantConstants
    from tribofmu.physics.laws import BoundaryLaw

    own = {k: v for k, v in parameters.items() if k not in ("lubricant", "effects")}
    return BoundaryLaw(**own, lubricant=LubricantConstants(**parameters["lubricant"]),
                       effects=Effects(**parameters["effects"]))


def replay_once(law, calls) -> list[tuple[float, float]]:
    advance = law.advance
    return [advance(f, dv, n, T, h, rtol, atol, dv_start) for f, dv, n, T, h, rtol, atol, dv_start in calls]


def digest(results) -> str:
    h = hashlib.sha256()
    for f, F in results:
        h.update(struct.pack("<dd", f, F))
    return h.hexdigest()[:16]


def count_functions(law, calls) -> Counter:
    counts: Counter = Counter()

    def hook(frame, event, arg):
        if event == "call" and frame.f_code.co_filename.endswith(BOUNDARY_FILE):
            counts[frame.f_code.co_name] += 1

    sys.setprofile(hook)
    try:
        replay_once(law, calls)
    finally:
        sys.setprofile(None)
    return counts


def replay(path: Path, repeat: int) -> None:
    import tribofmu.physics.laws.boundary as boundary

    with open(path, "rb") as fh:
        data = pickle.load(fh)
    calls = data["calls"]
    law = make_boundary_law(data["law"])
    print(f"{load_avg()}; {time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime())} UTC")
    print(f"replaying {len(calls)} advance calls of {data['scene']} on {boundary.__file__}")
    times, cpu = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        results = replay_once(law, calls)
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    print(f"wall per round: min {min(times):.3f} s, median {statistics.median(times):.3f} s "
          f"({1e6 * min(times) / len(calls):.1f} us per advance at the min); CPU min {min(cpu):.3f} s; "
          "rounds " + " ".join(f"{t:.3f}" for t in times))
    counts = count_functions(law, calls)
    per_call = ", ".join(f"{name} {n / len(calls):.2f}" for name, n in counts.most_common())
    print(f"calls per advance (functions of boundary.py): {per_call}")
    print(f"digest of (f, mean force) of every call: {digest(results)}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record")
    rec.add_argument("--scene", default="fig6_boundary")
    rec.add_argument("--out", type=Path, default=Path("/tmp/kinetics-calls.pickle"))
    rep = sub.add_parser("replay")
    rep.add_argument("--calls", type=Path, default=Path("/tmp/kinetics-calls.pickle"))
    rep.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    if args.command == "record":
        record(args.scene, args.out)
    else:
        replay(args.calls, args.repeat)


if __name__ == "__main__":
    main()
