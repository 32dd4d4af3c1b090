"""sweep.csv says what its columns are (columns.json, as simulate's result.csv), its
finished_at is UTC with its zone (as stats.json), and ``sweep --quiet`` prints nothing on
stderr ("starting a local Dask cluster" came through before)."""
import csv
import datetime as dt
import json

import pytest

from cli_run import tribofmu

pytestmark = pytest.mark.integration


def test_a_quiet_sweep_writes_its_columns_and_utc_times_and_says_nothing_else(tmp_path, fmu_dir, env):
    out = tmp_path / "s"
    run = tribofmu("sweep", "fig2_dry", "--grid", "drive.omega=30,50", "--workers", "1", "--quiet", "--no-plots",
               "--set", "time.periods=1", "--set", "time.window=[0, 1]", "--out", out, "--fmu-dir", fmu_dir,
                   cwd=tmp_path, env=env)  # its own process: its own Dask cluster
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""
    assert "2 points: 2 ok" in run.stdout
    with open(out / "sweep.csv", newline="") as fh:
        header, *rows = list(csv.reader(fh))
    sidecar = json.loads((out / "columns.json").read_text())
    assert sidecar["file"] == "sweep.csv"
    assert [c["name"] for c in sidecar["columns"]] == header
    units = {c["name"]: c["unit"] for c in sidecar["columns"]}
    assert units["drive.omega"] == "rad/s" and units["wall_time"] == "s" and units["dissipated_per_cycle"] == "J"
    assert all(c["meaning"] for c in sidecar["columns"])
    for row in rows:
        stamp = dt.datetime.fromisoformat(dict(zip(header, row))["finished_at"])
        assert stamp.utcoffset() == dt.timedelta(0)
        assert abs((dt.datetime.now(dt.timezone.utc) - stamp).total_seconds()) < 600
