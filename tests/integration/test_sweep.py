"""Issue "Sweeps at scale: regime maps on Dask".

- the grid: parsing, and bad keys/values caught on the client before any work (exit 2);
- sweeps through a real ``distributed.LocalCluster`` (2 worker processes): sweep.csv's
  columns and rows, portraits and pictures, resume after a row is lost, a failing point;
- the Fig. 4 trend of the paper as numbers (slowest test, ~1 min on 2 cores).
"""
from __future__ import annotations

import contextlib
import json
import csv
import os
import tempfile
import types
import subprocess
import socket
import sys
import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest

from tribofmu import metrics as M

from cli_run import main, tribofmu
from scenes import FIG2, NEWTONIAN
SHORT = {"time.periods": 2, "time.window": [1, 2]}  # a short span: one period shown
FIG4_OMEGAS = [10, 20, 30, 50, 80, 130]


# -- the grid -------------------------------------------------------------------------------
@pytest.mark.parametrize("grid_arg, words", [
    ("drive.omega=10,-5", ["drive.omega", "-5"]),
    ("drive.omega=10,fast", ["drive.omega", "fast"]),
    ("drive.omegaa=10", ["drive.omegaa"]),
    ("time.periods=7,2", ["time.periods=2", "time.window"]),  # 2 periods: the window [5, 6.5] is out
    ("drive.omega=10,10.0", ["drive.omega", "repeats"]),
])
def test_a_bad_grid_is_one_line_exit_2_before_any_work(tmp_path, capsys, grid_arg, words):
    out = tmp_path / "out"
    refused = main("sweep", FIG2, "--grid", grid_arg, "--out", out, "--workers", "0", capsys=capsys)
    err = refused.stderr.strip()
    assert refused.returncode == 2
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (out / "sweep.csv").exists() and not (out / "fmus").exists()


def test_run_point_reports_a_missing_fmu_as_a_failed_point(tmp_path):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep.worker import run_point
    out = run_point(load_scenario(FIG2, SHORT), str(tmp_path / "no-fmus"))
    assert out["status"] == "failed" and "no-fmus" in out["message"] and "\n" not in out["message"]
    assert out["metrics"] == {} and out["x"] is None


def test_run_point_stops_a_point_past_its_time_limit(fmu_dir):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep.worker import run_point
    out = run_point(load_scenario(FIG2, SHORT), str(fmu_dir), timeout=1e-6)
    assert out["status"] == "failed" and out["message"].startswith("PointTimeout: stopped after")


def test_run_point_leaves_no_unzipped_fmu_on_sys_path(fmu_dir):
    import sys
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep.worker import run_point
    before = list(sys.path)
    out = run_point(load_scenario(FIG2, SHORT), str(fmu_dir))
    assert out["status"] == "ok" and sys.path == before


# -- sweeps on a real local Dask cluster -----------------------------------------------------
@contextlib.contextmanager
def dask_cluster(cwd: Path, workers: int = 2, env: dict | None = None, preload: Path | None = None):
    """A real Dask cluster (scheduler + single-threaded worker processes) started as fresh
    interpreters in ``cwd``, so nothing an earlier test loaded into this process (FMUs, whose
    pythonfmu resources stay on sys.path) reaches the workers."""
    distributed = pytest.importorskip("distributed")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    quiet = dict(cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], **quiet)]
    extra = ["--preload", str(preload)] if preload else []
    procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nworkers", str(workers),
                                   "--nthreads", "1", "--no-dashboard", *extra],
                                  env={**os.environ, **(env or {})}, **quiet))
    try:
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(workers, timeout=120)
        yield types.SimpleNamespace(scheduler_address=address)
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    with dask_cluster(tmp_path_factory.mktemp("dask")) as running:
        yield running


@pytest.fixture(scope="module")
def cluster_without_client_disk(tmp_path_factory):
    """Two workers started in a directory of their own, with their own temp dir, that cannot
    open anything in this test session's temp tree (the FMUs, the sweep's output)."""
    with tempfile.TemporaryDirectory(prefix="tribofmu-worker-") as home:
        worker_tmp = Path(home, "tmp")
        worker_tmp.mkdir()
        env = {"TMPDIR": str(worker_tmp), "TRIBOFMU_TEST_FORBIDDEN": str(tmp_path_factory.getbasetemp())}
        with dask_cluster(Path(home), env=env, preload=Path(__file__).with_name("forbid_client_disk.py")) as running:
            running.tmp = worker_tmp
            yield running


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], [dict(zip(rows[0], r)) for r in rows[1:]]


def stamp(row):
    return dt.datetime.fromisoformat(row["finished_at"])


@pytest.mark.integration
def test_small_sweep_on_two_dask_workers_writes_rows_portraits_pictures(tmp_path, fmu_dir, cluster):
    from tribofmu.metrics import METRICS
    from tribofmu.studies.sweep import sweep
    out = tmp_path / "s"
    rows = sweep(FIG2, {"drive.omega": [30, 80, 130]}, out, scheduler=cluster.scheduler_address,
                 overrides=SHORT, fmu_dir=fmu_dir, progress=False)
    assert rows.computed == 3 and rows.skipped == 0 and rows.failed == 0
    header, csv_rows = read_csv(out / "sweep.csv")
    assert header[:3] == ["drive.omega", "status", "message"]
    assert header[3:3 + len(METRICS)] == list(METRICS)
    assert [r["drive.omega"] for r in csv_rows] == ["30", "80", "130"]  # grid order
    for r in csv_rows:
        assert r["status"] == "ok"
        for m in METRICS:
            # dry friction: no melting, and it sticks rather than creeps
            assert (r[m] == "") == (m in ("melt_fraction", "creep_fraction", "creep_episodes_per_period"))
        assert 0 <= float(r["stick_fraction"]) <= 1 and float(r["harmonics"]) >= 1
        assert float(r["dissipated_per_cycle"]) >= 0
    with np.load(out / "portraits.npz") as z:
        assert z["x"].shape == z["v"].shape == (3, 400) and np.isfinite(z["x"]).all()
        assert list(z["grid:drive.omega"]) == [30, 80, 130]
    for name in ("sweep.png", "portraits.png", "sweep.json"):
        assert (out / name).stat().st_size > 0
    # the same points in a plain loop (no Dask) give the same numbers
    plain = sweep(FIG2, {"drive.omega": [30, 130]}, tmp_path / "plain", workers=0, overrides=SHORT,
                  fmu_dir=fmu_dir, progress=False, plots=False)
    for p, d in zip(plain, (rows[0], rows[2])):
        for m in ("stick_fraction", "harmonics", "dissipated_per_cycle"):
            assert p[m] == pytest.approx(d[m], rel=1e-9)


@pytest.mark.integration
def test_resume_runs_only_the_points_missing_from_sweep_csv(tmp_path, fmu_dir, cluster):
    from tribofmu.studies.sweep import sweep
    out = tmp_path / "r"
    args = (FIG2, {"drive.omega": [30, 80, 130]}, out)
    kw = dict(scheduler=cluster.scheduler_address, overrides=SHORT, fmu_dir=fmu_dir, progress=False, plots=False)
    sweep(*args, **kw)
    header, first = read_csv(out / "sweep.csv")
    end_of_first = max(stamp(r) for r in first)
    # lose the row of omega = 80, and tear the file's last line as a crash mid-write would
    kept = [r for r in first if r["drive.omega"] != "80"]
    with open(out / "sweep.csv", "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(header)
        w.writerows([[r[c] for c in header] for r in kept])
        fh.write("80,ok,compl")
    rows = sweep(*args, **kw)
    assert (rows.computed, rows.skipped) == (1, 2)
    _, second = read_csv(out / "sweep.csv")
    assert [r["drive.omega"] for r in second] == ["30", "80", "130"]
    by = {r["drive.omega"]: r for r in second}
    old = {r["drive.omega"]: r for r in first}
    for w in ("30", "130"):
        assert by[w] == old[w]  # untouched, same time stamp
    assert stamp(by["80"]) > end_of_first  # recomputed
    assert float(by["80"]["stick_fraction"]) == pytest.approx(float(old["80"]["stick_fraction"]), rel=1e-9)
    # and a third run has nothing to do
    again = sweep(*args, **kw)
    assert (again.computed, again.skipped) == (0, 3)
    assert read_csv(out / "sweep.csv")[1] == second


@pytest.mark.integration
def test_resume_refuses_a_directory_of_another_sweep(tmp_path, fmu_dir):
    from tribofmu.studies.sweep import SweepError, sweep
    out = tmp_path / "o"
    sweep(FIG2, {"drive.omega": [130]}, out, workers=0, overrides=SHORT, fmu_dir=fmu_dir,
          progress=False, plots=False)
    with pytest.raises(SweepError, match="block.M"):
        sweep(FIG2, {"block.M": [0.6]}, out, workers=0, overrides=SHORT, fmu_dir=fmu_dir, progress=False)
    with pytest.raises(SweepError, match="scenario"):
        sweep(FIG2, {"drive.omega": [130]}, out, workers=0, overrides={**SHORT, "block.K": 5000.0},
              fmu_dir=fmu_dir, progress=False)


@pytest.mark.integration
def test_a_failing_point_is_reported_in_its_row_and_the_others_complete(tmp_path, fmu_dir, cluster):
    from tribofmu.studies.sweep import sweep
    # explicit (Jacobi) coupling with a 1 ms step is unstable for a 1 mg block: that point diverges
    overrides = {**SHORT, "simulation.algorithm": "jacobi", "simulation.step": 1e-3}
    out = tmp_path / "f"
    rows = sweep(NEWTONIAN, {"block.M": [0.6, 1e-6, 0.3]}, out, scheduler=cluster.scheduler_address,
                 overrides=overrides, fmu_dir=fmu_dir, progress=False)
    assert [r["status"] for r in rows] == ["ok", "failed", "ok"]
    _, csv_rows = read_csv(out / "sweep.csv")
    bad = csv_rows[1]
    assert bad["block.M"] == "1e-06" and bad["status"] == "failed" and bad["message"]
    assert all(bad[m] == "" for m in ("stick_fraction", "harmonics", "dissipated_per_cycle"))
    assert all(r["status"] == "ok" and r["harmonics"] for r in (csv_rows[0], csv_rows[2]))
    with np.load(out / "portraits.npz") as z:
        assert np.isnan(z["x"][1]).all() and np.isfinite(z["x"][[0, 2]]).all()
    assert (out / "portraits.png").is_file()
    # a rerun keeps the failed row; with retry_failed it runs that point (only) again
    again = sweep(NEWTONIAN, {"block.M": [0.6, 1e-6, 0.3]}, out, workers=0, overrides=overrides,
                  fmu_dir=fmu_dir, progress=False, plots=False)
    assert (again.computed, again.failed) == (0, 1)
    again = sweep(NEWTONIAN, {"block.M": [0.6, 1e-6, 0.3]}, out, workers=0, overrides=overrides,
                  fmu_dir=fmu_dir, progress=False, plots=False, retry_failed=True)
    assert (again.computed, again.failed) == (1, 1)
    assert stamp(read_csv(out / "sweep.csv")[1][1]) > stamp(bad)


def test_one_sweep_at_a_time_in_a_directory(tmp_path):
    import fcntl
    from tribofmu.studies.sweep import SweepError, sweep
    from tribofmu.studies.sweep.store import LOCK_NAME
    out = tmp_path / "busy"
    out.mkdir()
    with open(out / LOCK_NAME, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as a running sweep holds it
        with pytest.raises(SweepError, match="another sweep is running"):
            sweep(FIG2, {"drive.omega": [30]}, out, workers=0, overrides=SHORT, progress=False)
    assert not (out / "sweep.csv").exists()


@pytest.mark.integration
def test_cli_sweep_on_an_embedded_cluster_two_dimensional_map(tmp_path):
    """The command as a user runs it, in its own process: its own LocalCluster, the FMUs of
    the per-user cache, whose source sweep.json records."""
    out = tmp_path / "map"
    proc = tribofmu("sweep", FIG2, "--grid", "drive.omega=30,130", "--grid", "conditions.n=-20,-10",
                    "--set", "time.periods=2", "--set", "time.window=[1,2]", "--out", out, "--workers", "2",
                    cwd=tmp_path, env=os.environ)
    assert proc.returncode == 0, proc.stderr
    from tribofmu.build import private_package_name
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["fmu_source"] == private_package_name() and meta["tribofmu"]
    header, rows = read_csv(out / "sweep.csv")
    assert header[:2] == ["drive.omega", "conditions.n"]
    assert [(r["drive.omega"], r["conditions.n"]) for r in rows] == [
        ("30", "-20"), ("30", "-10"), ("130", "-20"), ("130", "-10")]
    for m in ("stick_fraction", "harmonics", "amplitude_ratio", "dissipated_per_cycle"):
        assert (out / f"map_{m}.png").stat().st_size > 0
    assert not (out / "map_melt_fraction.png").exists()  # dry friction: nothing to map
    assert (out / "portraits.png").stat().st_size > 0
    assert "4 points: 4 ok, 0 failed" in proc.stdout


@pytest.mark.integration
def test_fig4_fewer_stick_episodes_and_harmonics_as_omega_rises(tmp_path, fmu_dir, cluster):
    """Paper, Fig. 4: w = 10 ... 130 rad/s; the motion simplifies, at 130 the blocks stay stuck."""
    from tribofmu.studies.sweep import sweep
    rows = sweep(FIG2, {"drive.omega": FIG4_OMEGAS}, tmp_path / "fig4", scheduler=cluster.scheduler_address,
                 fmu_dir=fmu_dir, progress=False)
    table = "\n".join(f"w={r['drive.omega']:>4}: stick {r['stick_fraction']:.3f}, episodes "
                      f"{r['stick_episodes_per_period']:.2f}, harmonics {r['harmonics']:.0f}, "
                      f"|x|/A {r['amplitude_ratio']:.3f}, diss {r['dissipated_per_cycle']:.4f} J"
                      for r in rows)
    print(table)
    assert all(r["status"] == "ok" for r in rows), table
    episodes = [r["stick_episodes_per_period"] for r in rows]
    harmonics = [r["harmonics"] for r in rows]
    by = {r["drive.omega"]: r for r in rows}
    # stick-slip at low frequency: several stick episodes per period (four at w = 30, Fig. 2)
    assert by[30]["stick_episodes_per_period"] >= 2, table
    # non-increasing, roughly: never up by more than one episode from one omega to the next,
    # and the high frequencies have fewer than the low ones
    assert all(b <= a + 1 for a, b in zip(episodes, episodes[1:])), table
    assert max(episodes[3:]) < max(episodes[:3]), table
    # the number of harmonics decreases with frequency (the paper's words), at most a blip of one
    assert all(b <= a + 1 for a, b in zip(harmonics, harmonics[1:])), table
    assert harmonics[-1] < harmonics[0], table
    # w = 130: stuck almost all the time, x(t) follows the drive: one harmonic
    assert by[130]["stick_fraction"] > 0.9, table
    assert by[130]["harmonics"] <= 2, table
    assert by[130]["dissipated_per_cycle"] < 0.2 * min(by[w]["dissipated_per_cycle"] for w in FIG4_OMEGAS[:-1]), table


@pytest.mark.integration
def test_a_sweep_runs_on_workers_that_cannot_see_the_clients_disk(tmp_path, fmu_dir, cluster_without_client_disk):
    """The FMUs reach the workers through Dask; the numbers equal a plain loop's."""
    from distributed import Client
    from tribofmu.studies.sweep import sweep
    with Client(cluster_without_client_disk.scheduler_address) as client:  # the workers really are blind
        with pytest.raises(PermissionError, match="cannot see the client's disk"):
            client.submit(Path.read_bytes, fmu_dir / "Drive.fmu", pure=False).result()
    kw = dict(overrides=SHORT, fmu_dir=fmu_dir, plots=False, progress=False, log=lambda msg: None)
    grid = {"drive.omega": [30, 80], "conditions.n": [-10, -20]}
    remote = sweep(FIG2, grid, tmp_path / "remote", scheduler=cluster_without_client_disk.scheduler_address, **kw)
    assert [r["status"] for r in remote] == ["ok"] * 4, [r["message"] for r in remote]
    local = sweep(FIG2, grid, tmp_path / "local", workers=0, **kw)
    for a, b in zip(remote, local):
        assert all(a[m] == b[m] or (math.isnan(a[m]) and math.isnan(b[m])) for m in M.METRICS)
    copies = list(cluster_without_client_disk.tmp.glob("**/tribofmu-fmus-*/bundle-*/Friction.fmu"))
    assert copies and all(c.read_bytes() == (fmu_dir / "Friction.fmu").read_bytes() for c in copies)


@pytest.mark.integration
def test_dask_runs_the_longest_expected_points_first(tmp_path, fmu_dir):
    from tribofmu.studies.sweep import sweep
    rows = sweep(FIG2, {"drive.omega": [130, 30, 10]}, tmp_path / "out", workers=1, overrides=SHORT,
                 fmu_dir=fmu_dir, plots=False, progress=False, log=lambda msg: None)
    assert [r["drive.omega"] for r in rows] == [130, 30, 10]  # grid order in the results
    by_finish = sorted(rows, key=lambda r: r["finished_at"])
    assert [r["drive.omega"] for r in by_finish] == [10, 30, 130]
