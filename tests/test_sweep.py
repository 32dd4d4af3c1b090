"""Issue "Sweeps at scale: regime maps on Dask".

- the metrics (tribofmu.studies.metrics) against synthetic signals with known answers;
- the grid: parsing, and bad keys/values caught on the client before any work (exit 2);
- sweeps through a real ``distributed.LocalCluster`` (2 worker processes): sweep.csv's
  columns and rows, portraits and pictures, resume after a row is lost, a failing point;
- the Fig. 4 trend of the paper as numbers (slowest test, ~1 min on 2 cores).
"""
from __future__ import annotations

import csv
import types
import subprocess
import socket
import sys
import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest

from tribofmu.studies import metrics as M

ROOT = Path(__file__).resolve().parent.parent
FIG2 = ROOT / "scenarios" / "fig2_dry.toml"
NEWTONIAN = ROOT / "scenarios" / "fig5_newtonian.toml"
SHORT = {"time.periods": 2, "time.window": [1, 2]}  # a short span: one period shown
FIG4_OMEGAS = [10, 20, 30, 50, 80, 130]


# -- metrics on synthetic signals ---------------------------------------------------------
def grid(periods: float, omega: float = 30.0, per_period: int = 1000, t0_periods: float = 5.0):
    T = 2 * math.pi / omega
    n = int(round(periods * per_period))
    return np.linspace(t0_periods * T, (t0_periods + periods) * T, n + 1), T


def test_pure_sinusoid_has_one_harmonic_whatever_its_phase_and_offset():
    t, T = grid(1.5)
    w = 2 * math.pi / T
    for phase, offset in ((0.0, 0.0), (1.0, 3e-4), (2.5, -1e-3)):
        x = 2e-3 * np.cos(w * t + phase) + offset
        assert M.harmonics(t, x, T) == 1
        a = M.harmonic_amplitudes(t, x, T)
        assert a[0] == pytest.approx(2e-3, rel=1e-6)


def test_harmonics_counts_those_above_one_percent_of_the_largest():
    t, T = grid(2.0)
    w = 2 * math.pi / T
    # amplitudes relative to the largest: 1, 0.2, 0.05, 0.011 (significant), 0.009, 0.001 (not)
    x = (np.sin(w * t) + 0.2 * np.sin(3 * w * t + 0.3) + 0.05 * np.cos(5 * w * t)
         + 0.011 * np.sin(7 * w * t) + 0.009 * np.sin(9 * w * t) + 0.001 * np.sin(2 * w * t))
    assert M.harmonics(t, x, T) == 4
    a = M.harmonic_amplitudes(t, x, T)
    assert a[2] == pytest.approx(0.2, rel=1e-6) and a[8] == pytest.approx(0.009, rel=1e-5)


def test_harmonics_of_a_constant_is_zero_and_of_less_than_a_period_is_nan():
    t, T = grid(1.5)
    assert M.harmonics(t, np.full_like(t, 1e-3), T) == 0
    t, T = grid(0.8)
    assert math.isnan(M.harmonics(t, np.sin(2 * math.pi / T * t), T))


def test_a_window_that_lost_its_end_sample_still_holds_its_whole_period():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    t = t[:-1]  # [t0, t0 + T): 1000 samples
    assert M.whole_periods(t, T) == (1, 1000)
    assert M.harmonics(t, np.sin(w * t) + 0.1 * np.sin(3 * w * t), T) == 2


def stuck_signal(t, T, stuck):
    """V = sin; v = V where stuck(phase in [0, 1)), else 0.3 V (slipping)."""
    w = 2 * math.pi / T
    V = 0.06 * np.sin(w * t)
    mask = stuck(((t - t[0]) / T) % 1.0)
    return V, np.where(mask, V, 0.3 * V), mask


def test_stuck_half_the_time_gives_stick_fraction_one_half():
    t, T = grid(1.0)
    V, v, _ = stuck_signal(t, T, lambda p: p < 0.5)
    assert M.stick_fraction(t, V, v) == pytest.approx(0.5, abs=2e-3)


def test_stick_fraction_is_time_weighted_on_a_non_uniform_grid():
    t = np.concatenate([np.linspace(0, 0.5, 11), np.linspace(0.5, 1.0, 1001)[1:]])  # coarse, fine
    V = np.ones_like(t)
    v = np.where(t <= 0.25, 1.0, 0.0)
    assert M.stick_fraction(t, V, v) == pytest.approx(0.25, abs=0.03)


def test_four_stick_episodes_per_period_whatever_the_window_phase():
    # stuck on [0.05, 0.2), [0.3, 0.45), [0.55, 0.7), [0.8, 0.95) of each period
    def four(p):
        return ((p % 0.25) >= 0.05) & ((p % 0.25) < 0.2)
    for t0 in (5.0, 5.1, 5.37):  # windows starting inside a stick, inside a slip
        t, T = grid(1.5, t0_periods=t0)
        V, v, _ = stuck_signal(t, T, lambda p, s=t0: four((p + s) % 1.0))
        assert M.stick_episodes_per_period(t, V, v, T) == 4
        assert M.stick_fraction(t, V, v) == pytest.approx(0.6, abs=0.01)


def test_a_run_crossing_the_whole_period_end_counts_once():
    t, T = grid(2.0)
    V, v, _ = stuck_signal(t, T, lambda p: (p < 0.1) | (p >= 0.6))  # one run per period, wrapping
    assert M.stick_episodes_per_period(t, V, v, T) == 1


def test_always_or_never_stuck_has_no_stick_episodes():
    t, T = grid(1.5)
    V, v, _ = stuck_signal(t, T, lambda p: np.ones_like(p, dtype=bool))
    assert M.stick_episodes_per_period(t, V, v, T) == 0 and M.stick_fraction(t, V, v) == 1
    v = V - 0.02  # always slipping
    assert M.stick_episodes_per_period(t, V, v, T) == 0 and M.stick_fraction(t, V, v) == 0


def test_a_slipping_reversal_through_v_equals_V_is_not_a_stick_episode():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    V = 0.06 * np.sin(w * t)
    v = V + 0.01 * np.sin(2 * w * t + 0.3)  # dv crosses 0 four times per period, never dwells
    assert np.count_nonzero(M.stuck(V, v)) > 0  # the crossings do sample below the threshold
    assert M.stick_episodes_per_period(t, V, v, T) == 0


def test_dissipated_per_cycle_of_a_viscous_force():
    # F = c (V - v), v = 0, V = A w sin(w t): one period dissipates c A^2 w^2 T / 2 = pi c A^2 w
    t, T = grid(1.5)
    A, c = 2e-3, 25.0
    w = 2 * math.pi / T
    V = -A * w * np.sin(w * t)
    v = np.zeros_like(t)
    assert M.dissipated_per_cycle(t, c * (V - v), V, v, T) == pytest.approx(math.pi * c * A**2 * w, rel=1e-4)


def test_amplitude_ratio_and_melt_fraction():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    assert M.amplitude_ratio(3e-3 * np.sin(w * t), 2e-3) == pytest.approx(1.5, rel=1e-6)
    f = 1.025 + 0.5 * np.sin(w * t)
    assert M.melt_fraction(t, f, 1.025) == pytest.approx(0.5, abs=2e-3)
    assert M.melt_fraction(t, f, 1.025 + 0.5 * math.sin(math.pi / 4)) == pytest.approx(0.25, abs=2e-3)
    assert math.isnan(M.melt_fraction(t, f, None))


def test_compute_metrics_gives_every_metric():
    t, T = grid(1.5)
    V, v, _ = stuck_signal(t, T, lambda p: p < 0.5)
    out = M.compute_metrics(t, V, np.sin(t), v, V - v, np.zeros_like(t), T, 1.0)
    assert list(out) == list(M.METRICS)


# -- the grid -------------------------------------------------------------------------------
def test_parse_grid_reads_values_like_set():
    from tribofmu.studies.sweep import grid_points, parse_grid
    g = parse_grid(["drive.omega=10, 20.5,1e2", "time.window=[1,2],[2, 3]", "friction.regime=dry,fluid"])
    assert g == {"drive.omega": [10, 20.5, 100.0], "time.window": [[1, 2], [2, 3]],
                 "friction.regime": ["dry", "fluid"]}
    points = grid_points({"a.b": [1, 2], "c.d": [3, 4, 5]})
    assert len(points) == 6 and points[0] == {"a.b": 1, "c.d": 3} and points[3] == {"a.b": 2, "c.d": 3}


@pytest.mark.parametrize("grid_arg, words", [
    ("drive.omega=10,-5", ["drive.omega", "-5"]),
    ("drive.omega=10,fast", ["drive.omega", "fast"]),
    ("drive.omegaa=10", ["drive.omegaa"]),
    ("time.periods=7,2", ["time.periods=2", "time.window"]),  # 2 periods: the window [5, 6.5] is out
    ("drive.omega=10,10.0", ["drive.omega", "repeats"]),
])
def test_a_bad_grid_is_one_line_exit_2_before_any_work(tmp_path, capsys, grid_arg, words):
    from tribofmu.cli import main
    out = tmp_path / "out"
    code = main(["sweep", str(FIG2), "--grid", grid_arg, "--out", str(out), "--workers", "0"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (out / "sweep.csv").exists() and not (out / "fmus").exists()


def test_run_point_reports_a_missing_fmu_as_a_failed_point(tmp_path):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep import run_point
    out = run_point(load_scenario(FIG2, SHORT), str(tmp_path / "no-fmus"))
    assert out["status"] == "failed" and "no-fmus" in out["message"] and "\n" not in out["message"]
    assert out["metrics"] == {} and out["x"] is None


def test_run_point_stops_a_point_past_its_time_limit(fmu_dir):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep import run_point
    out = run_point(load_scenario(FIG2, SHORT), str(fmu_dir), timeout=1e-6)
    assert out["status"] == "failed" and out["message"].startswith("PointTimeout: stopped after")


def test_run_point_leaves_no_unzipped_fmu_on_sys_path(fmu_dir):
    import sys
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep import run_point
    before = list(sys.path)
    out = run_point(load_scenario(FIG2, SHORT), str(fmu_dir))
    assert out["status"] == "ok" and sys.path == before


# -- sweeps on a real local Dask cluster -----------------------------------------------------
@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    from tribofmu.build import build_fmus
    path = tmp_path_factory.mktemp("fmus")
    build_fmus(path)
    return path


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A real local Dask cluster (scheduler + 2 single-threaded worker processes) started as
    fresh interpreters, so nothing an earlier test loaded into this process (FMUs, whose
    pythonfmu resources stay on sys.path) reaches the workers."""
    distributed = pytest.importorskip("distributed")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    cwd = tmp_path_factory.mktemp("dask")
    quiet = dict(cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], **quiet)]
    procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nworkers", "2",
                                   "--nthreads", "1", "--no-dashboard"], **quiet))
    try:
        with distributed.Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield types.SimpleNamespace(scheduler_address=address)
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], [dict(zip(rows[0], r)) for r in rows[1:]]


def stamp(row):
    return dt.datetime.fromisoformat(row["finished_at"])


@pytest.mark.integration
def test_small_sweep_on_two_dask_workers_writes_rows_portraits_pictures(tmp_path, fmu_dir, cluster):
    from tribofmu.studies.metrics import METRICS
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
            assert (r[m] == "") == (m == "melt_fraction")  # dry friction: no melting
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
    from tribofmu.studies.sweep import LOCK_NAME, SweepError, sweep
    out = tmp_path / "busy"
    out.mkdir()
    with open(out / LOCK_NAME, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as a running sweep holds it
        with pytest.raises(SweepError, match="another sweep is running"):
            sweep(FIG2, {"drive.omega": [30]}, out, workers=0, overrides=SHORT, progress=False)
    assert not (out / "sweep.csv").exists()


@pytest.mark.integration
def test_cli_sweep_on_an_embedded_cluster_two_dimensional_map(tmp_path):
    """The command as a user runs it, in its own process: its own LocalCluster, FMUs built
    into OUT/fmus."""
    out = tmp_path / "map"
    proc = subprocess.run([sys.executable, "-m", "tribofmu.cli", "sweep", str(FIG2),
                           "--grid", "drive.omega=30,130", "--grid", "conditions.n=-20,-10",
                           "--set", "time.periods=2", "--set", "time.window=[1,2]", "--out", str(out),
                           "--workers", "2"], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in (out / "fmus").iterdir()) == ["BlockSpring.fmu", "Drive.fmu", "Friction.fmu"]
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
