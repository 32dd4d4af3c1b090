"""Accuracy and cost of the default settings, against the monolithic reference, in one run.

    python benchmarks/bench_stiff.py [--sets paper,hard,boundary,dry,memory] [--repeat 3]
                                     [--out FILE.json]

For every case: the reference solution (``studies.reference``, scipy, no FMI, its default
rtol 1e-10) is computed and timed once; the co-simulation runs with the scene's defaults
``--repeat`` times (median wall time quoted, whole ``api.simulate`` call); nRMS(v) on the
scene's window against the reference; the ratio of the co-simulation's median wall time to
the reference's, both measured here, in this process, on this machine. The ``memory`` set
runs a 1000-period fig2 simulation in a child process and reports its peak resident memory
and the energy residual of each tenth of the run.

Issue 10's targets, printed beside the numbers: nRMS <= 1e-3 for every case; fig6 no slower
than the reference; every boundary/dry scan point under 30 s; gamma = -0.9 at most 5x the
wall time of gamma = 0; fig2 default <= 5e-4; 1000 periods under 150 MB.
Not collected by pytest (no test_ prefix); absolute paths throughout.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenarios"

FIG2, FIG4, FIG6 = "fig2_dry", "fig4_dry_w130", "fig6_boundary"
PSEUDO, NEWTON, DILAT = "fig5_pseudoplastic", "fig5_newtonian", "fig5_dilatant"
SETS = {
    "paper": [(FIG2, {}), (FIG4, {}), (PSEUDO, {}), (NEWTON, {}), (DILAT, {}), (FIG6, {})],
    "hard": [(FIG2, {"block.K": 1e7}), (FIG2, {"friction.regime": "boundary"}),
             (PSEUDO, {"friction.gamma": 0.0}), (PSEUDO, {"friction.gamma": -0.9}),
             (DILAT, {"friction.gamma": 2.0})],
    "boundary": [(FIG6, {"conditions.T": 270.0}), (FIG6, {"conditions.T": 330.0}),
                 (FIG6, {"conditions.n": -3e5}), (FIG6, {"conditions.n": -3e6}),
                 (FIG6, {"drive.omega": 10.0}), (FIG6, {"drive.omega": 60.0}),
                 (FIG6, {"block.M": 0.3, "block.K": 3000.0})],
    "dry": [(FIG2, {"drive.omega": 10.0}), (FIG2, {"drive.omega": 80.0}), (FIG2, {"drive.omega": 130.0}),
            (FIG2, {"block.K": 500.0}), (FIG2, {"block.K": 2e4}), (FIG2, {"block.K": 1e6}),
            (FIG2, {"block.M": 2.0, "conditions.n": -60.0})],
}


def label(scene: str, overrides: dict) -> str:
    return scene + "".join(f" {k}={v:g}" if isinstance(v, float) else f" {k}={v}" for k, v in overrides.items())


def run_case(scene: str, overrides: dict, repeat: int, fmu_dir: Path) -> dict:
    from tribofmu import api
    from tribofmu.studies.reference import nrms, reference_solution

    sc = api.load(SCENES / f"{scene}.toml", overrides)
    begin = time.perf_counter()
    ref = reference_solution(sc)
    ref_wall = time.perf_counter() - begin
    walls, result = [], None
    for _ in range(repeat):
        begin = time.perf_counter()
        result = api.simulate(sc, fmu_dir=fmu_dir, build=False)
        walls.append(time.perf_counter() - begin)
    wall = statistics.median(walls)
    err = math.nan
    if result.ok and ref.ok:
        err = nrms(result.time, result.v, ref.time, ref.v, sc.window)
    s = result.stats
    return {"case": label(scene, overrides), "ok": result.ok, "message": result.message,
            "reference_ok": ref.ok, "nrms_v": err, "wall_median_s": wall, "wall_min_s": min(walls),
            "wall_max_s": max(walls), "reference_wall_s": ref_wall, "ratio_to_reference": wall / ref_wall,
            "tol": s["tol"], "steps": s["communication_steps"], "rejected": s["rejected_steps"],
            "fmu_calls": s["fmu_calls_total"],
            "calls_per_step": s["fmu_calls_total"] / max(1, s["communication_steps"]),
            "energy_residual_rel": s["energy"]["residual_rel"]}


MEMORY_CHILD = r"""
import json, sys
from tribofmu import api
from tribofmu.master.energy import EnergyAudit
periods = float(sys.argv[1])
sc = api.load(sys.argv[2], {"time.periods": periods, "time.window": [periods - 1.5, periods]})
# the energy residual of each tenth of the run, from the points as they stream past
tenths = [EnergyAudit(sc) for _ in range(10)]
span = sc.stop_time
class Split:
    def add(self, chunk):  # the chunk cut where a tenth ends, each piece to its tenth's audit
        tenth = lambda p: min(9, int(10 * p.t_ns / 1e9 / span))
        start = 0
        for i in range(1, len(chunk)):
            if tenth(chunk[i]) != tenth(chunk[start]) or i == len(chunk) - 1:
                end = i if i == len(chunk) - 1 and tenth(chunk[i]) == tenth(chunk[start]) else i
                tenths[tenth(chunk[start])].add(chunk[start:end + 1])
                start = end
import tribofmu.api as A
orig = A.EnergyAudit
class Both(orig):
    def add(self, chunk):
        Split().add(chunk)
        return super().add(chunk)
A.EnergyAudit = Both
r = api.simulate(sc, fmu_dir=sys.argv[3], build=False)
# VmHWM of this process's own address space (ru_maxrss would carry the parent's peak from fork)
hwm = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print(json.dumps({"ok": r.ok, "wall_s": r.stats["wall_time"], "steps": r.stats["communication_steps"],
                  "peak_rss_mb": hwm / 1024,
                  "output_points": r.stats["output_points"],
                  "residual_rel": r.stats["energy"]["residual_rel"],
                  "residual_rel_per_tenth": [t.result()["residual_rel"] for t in tenths]}))
"""


def run_memory(periods: float, fmu_dir: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", MEMORY_CHILD, str(periods), str(SCENES / f"{FIG2}.toml"),
                          str(fmu_dir)], capture_output=True, text=True, check=True)
    row = json.loads(out.stdout.strip().splitlines()[-1])
    row["case"] = f"{FIG2} time.periods={periods:g} (child process)"
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sets", default="paper,hard,boundary,dry,memory")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", default=None, help="also write the rows as JSON here")
    args = parser.parse_args(argv)
    from tribofmu.build import build_fmus

    fmu_dir = Path(ROOT / "build" / "bench").resolve()
    build_fmus(fmu_dir)
    rows = []
    for name in args.sets.split(","):
        if name == "memory":
            for periods in (10.0, 1000.0):
                row = run_memory(periods, fmu_dir)
                rows.append(row)
                print(json.dumps(row), flush=True)
            continue
        for scene, overrides in SETS[name]:
            row = run_case(scene, overrides, args.repeat, fmu_dir)
            row["set"] = name
            rows.append(row)
            print(f"{row['case']:<48} nRMS {row['nrms_v']:.2e}  wall {row['wall_median_s']:6.2f} s "
                  f"(ref {row['reference_wall_s']:6.2f} s, x{row['ratio_to_reference']:.2f})  "
                  f"{row['steps']} steps, {row['calls_per_step']:.0f} calls/step  {row['message'][:60]}",
                  flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
