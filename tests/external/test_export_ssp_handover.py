"""What ``tribofmu export-ssp`` prints is what the user pastes: the stop time and step, and
an OMSimulator and an fmpy command line that run the archive to the stop time exactly (fmpy's
README snippet overshot it by a step: 13,614 steps of 1e-4 s past 1.3614 s)."""
import csv
import os
import subprocess
import sys

import pytest

from cli_run import main
from scenes import ROOT

pytestmark = [pytest.mark.integration]
OMS_BIN = ROOT.parent / "shared" / "tools" / "omsimulator" / "bin"
SHORT = ["--set", "time.periods=0.5", "--set", "time.window=[0, 0.5]"]


@pytest.fixture
def printed(tmp_path, fmu_dir, capsys):
    run = main("export-ssp", "fig2_dry", "--pair", "--out", tmp_path / "p.ssp", "--fmu-dir", fmu_dir, *SHORT,
               capsys=capsys)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == str(tmp_path / "p.ssp")
    from tribofmu import api
    stop = api.load("fig2_dry", SHORT[1::2]).stop_time
    assert lines[1].startswith(f"stop time {stop!r} s, step 0.0001 s (")
    oms = next(line.strip() for line in lines if line.strip().startswith("OMSimulator "))
    fmpy = next(line.strip() for line in lines if line.strip().startswith("python -c "))
    return stop, oms, fmpy


def test_the_printed_fmpy_line_runs_the_archive_to_the_stop_time(printed, tmp_path):
    stop, _, fmpy = printed
    proc = subprocess.run(["bash", "-c", fmpy], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert proc.returncode == 0, proc.stderr
    assert float(proc.stdout.strip()) == pytest.approx(stop, rel=1e-12, abs=0)  # the last row's step ends there


@pytest.mark.external
@pytest.mark.skipif(not (OMS_BIN / "OMSimulator").is_file(), reason=f"OMSimulator is not in {OMS_BIN}")
def test_the_printed_omsimulator_line_runs_the_archive_to_the_stop_time(printed, tmp_path):
    stop, oms, _ = printed
    env = {**os.environ, "PATH": f"{OMS_BIN}{os.pathsep}{os.environ['PATH']}"}
    proc = subprocess.run(["bash", "-c", oms], cwd=tmp_path, capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    with open(tmp_path / "p.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert float(rows[-1][0]) == pytest.approx(stop, rel=1e-9, abs=0)
