"""Issue 39's target for temp files: N kills (SIGKILL, SIGHUP, SIGTERM in turn) of
``tribofmu simulate fig2_dry`` at random moments, then one normal run: how many spool files
(``tribofmu-spool-*``) and unzipped-FMU folders (``tribofmu-fmus-*``) are left in the temp
dir, before and after that run.

    python benchmarks/measure_kill_leftovers.py [--kills 60] [--seed 39]

Runs in a private temp dir (TMPDIR) with the FMUs of the per-user cache (built if needed).
tests/integration/test_no_leftovers.py runs six kills.
"""
from __future__ import annotations

import argparse
import datetime
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def count(tmp: Path) -> dict[str, int]:
    return {"spool files": len(list(tmp.rglob("tribofmu-spool-*"))),
            "spool MB": round(sum(p.stat().st_size for p in tmp.rglob("tribofmu-spool-*")) / 1e6, 1),
            "extraction folders": len(list(tmp.rglob("tribofmu-fmus-*"))),
            "run folders": len(list(tmp.glob("tribofmu-run-*")))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=60)
    parser.add_argument("--seed", type=int, default=39)
    args = parser.parse_args()
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.fmu.registry import fmu_names
    fmu_dir = find_fmus(fmu_names())
    rng = random.Random(args.seed)
    kinds = [signal.SIGKILL, signal.SIGHUP, signal.SIGTERM]
    began = datetime.datetime.now(datetime.timezone.utc)
    with tempfile.TemporaryDirectory(prefix="measure-kills-") as work:
        work = Path(work)
        tmp = work / "tmp"
        tmp.mkdir()
        env = dict(os.environ, TMPDIR=str(tmp))
        codes: dict[str, int] = {}
        for i in range(args.kills):
            sig = kinds[i % len(kinds)]
            proc = subprocess.Popen([sys.executable, "-m", "tribofmu", "simulate", "fig2_dry", "--fmu-dir",
                                     str(fmu_dir), "--out", str(work / f"o{i}"), "--no-plots", "-q"],
                                    env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                    start_new_session=True,  # SIGHUP as a closed terminal sends it
                                    preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL))
            time.sleep(rng.uniform(0.1, 4.0))  # a run takes ~2-5 s: start-up, unzip, the check's runs
            if proc.poll() is None:
                os.killpg(proc.pid, sig)
            proc.wait()
            key = f"{signal.Signals(sig).name} -> exit {proc.returncode}"
            codes[key] = codes.get(key, 0) + 1
        before = count(tmp)
        done = subprocess.run([sys.executable, "-m", "tribofmu", "simulate", "fig2_dry", "--fmu-dir", str(fmu_dir),
                               "--out", str(work / "last"), "--no-plots", "-q"], env=env, capture_output=True,
                              text=True)
        after = count(tmp)
    print(f"{args.kills} kills, seed {args.seed}, {began:%Y-%m-%d %H:%M} UTC, load {os.getloadavg()[0]:.1f}")
    for key in sorted(codes):
        print(f"  {key}: {codes[key]}")
    print(f"left before the normal run: {before}")
    print(f"normal run: exit {done.returncode}; left after it: {after}")


if __name__ == "__main__":
    main()
