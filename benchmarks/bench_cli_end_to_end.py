"""End to end cost of ``tribofmu simulate fig2_dry`` against its simulation time.

    python benchmarks/bench_cli_end_to_end.py [--repeat 7] [--scene fig2_dry]

Runs the installed command (a fresh process each time, as a user does) with plots and with
``--no-plots``, after one warm-up run that fills the FMU cache; prints the medians of the wall
time of the whole command and of the simulation itself (``stats.json``'s ``wall_time``), and
their ratio. The issue's target: with plots, at most 2x the simulation time.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def one(scene: str, folder: Path, plots: bool) -> tuple[float, float]:
    argv = [sys.executable, "-m", "tribofmu", "simulate", scene, "-q", "--out", str(folder)]
    if not plots:
        argv.append("--no-plots")
    start = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True)
    total = time.perf_counter() - start
    return total, json.loads((folder / "stats.json").read_text())["wall_time"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--scene", default="fig2_dry")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "run"
        one(args.scene, folder, True)  # warm-up: FMU cache, file caches
        for plots in (True, False):
            runs = [one(args.scene, folder, plots) for _ in range(args.repeat)]
            total = statistics.median(r[0] for r in runs)
            sim = statistics.median(r[1] for r in runs)
            label = "with plots" if plots else "--no-plots"
            print(f"{args.scene} {label}: end to end {total:.2f} s, simulation {sim:.2f} s, "
                  f"ratio {total / sim:.1f} (medians of {args.repeat})")


if __name__ == "__main__":
    main()
