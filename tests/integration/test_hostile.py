"""Issue 30: hostile input and interruptions of the ``tribofmu`` command. Each case failed
before: a traceback, an ``ok`` run whose result does not resolve its drive, an option
accepted and ignored, a whole run wasted, a result silently replaced, a lost sweep.

The rule (README, "Bad input"): one line naming the culprit, exit 2 for usage, 1 for errors,
130 for an interruption; never a traceback, never a half-written or replaced result.
"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from cli_run import command, tribofmu

pytestmark = pytest.mark.integration

SCENES = Path(__file__).resolve().parents[2] / "fmu_src" / "tribofmu" / "scenarios"
SHORT = ["--set", "time.periods=2", "--set", "time.window=[1,2]"]


def one_line(done, code: int, *words: str) -> str:
    """Exit ``code``, one line on stderr holding ``words``, no traceback."""
    assert done.returncode == code, (done.returncode, done.stderr[-3000:])
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# -- a run that cannot resolve its drive is refused before it starts -------------------------
@pytest.mark.parametrize("args, words", [
    (["--set", "drive.omega=1e-100"], ["drive.omega = 1e-100", "longer than the time grid"]),
    (["--set", "drive.omega=1e12"], ["drive.omega = 1e+12", "must be <= 1.57e+08"]),
    (["--set", "drive.omega=1e10"], ["drive.omega = 1e+10", "must be <= 1.57e+08"]),
    (["--algorithm", "jacobi", "--step", "1e3"], ["--step 1000 s", "at least 10"]),
    (["--algorithm", "jacobi", "--step", "0.2"], ["--step 0.2 s gives 1.05", "at least 10"]),
    (["--algorithm", "gauss-seidel", "--set", "drive.omega=1e6"], ["default step 0.0001 s", "at least 10"]),
    (["--max-wall", "1e-100"], ["--max-wall", "at least 1 s"]),
], ids=["omega-1e-100", "omega-1e12", "omega-1e10", "jacobi-step-1e3", "jacobi-step-0.2",
        "default-step-omega-1e6", "max-wall-1e-100"])
def test_unresolvable_drive_is_refused_before_the_run(tmp_path, env, fmu_dir, args, words):
    out = tmp_path / "out"
    done = tribofmu("simulate", "fig2_dry", *args, "--fmu-dir", fmu_dir, "--out", out, "--no-plots",
                    cwd=tmp_path, env=env, timeout=120)
    one_line(done, 2, *words)
    assert not out.exists()


def test_sweep_point_that_cannot_resolve_its_drive_is_refused_before_any_run(tmp_path, env, fmu_dir):
    out = tmp_path / "sweep"
    done = tribofmu("sweep", "fig2_dry", "--grid", "drive.omega=30,1e12", "--workers", "0", "--fmu-dir", fmu_dir,
                    "--out", out, "-q", cwd=tmp_path, env=env, timeout=120)
    one_line(done, 2, "--grid point drive.omega=1000000000000.0", "must be <= 1.57e+08")
    assert not out.exists()


# -- plot: a stats.json that is no record ----------------------------------------------------
@pytest.mark.parametrize("stats", [{"scenario": 5}, {"scenario": {"drive": 5}}, {"scenario": [1, 2]},
                                   [1], {"scenario": {"drive": {"omega": "x"}}},
                                   {"scenario": {"nosuch": {}}}],
                         ids=["number", "table-of-number", "list", "not-a-table", "bad-value", "unknown-table"])
def test_plot_of_a_stats_json_without_a_scenario_is_one_line(tmp_path, env, stats):
    folder = tmp_path / "D"
    folder.mkdir()
    (folder / "result.csv").write_text("time,X,V,x,v\n0,0,0,0,0\n1,0,0,0,0\n")
    (folder / "stats.json").write_text(json.dumps(stats))
    done = tribofmu("plot", folder, "--out", tmp_path / "plots", cwd=tmp_path, env=env, timeout=120)
    one_line(done, 2, "stats.json")
    assert not (tmp_path / "plots").exists()


# -- --out that cannot be swapped; two runs into one --out -------------------------------------
@pytest.mark.alone
@pytest.mark.parametrize("out", [".", "..", "./"], ids=["dot", "dotdot", "dot-slash"])
def test_out_that_cannot_be_swapped_is_refused_before_the_run(tmp_path, env, fmu_dir, out):
    work = tmp_path / "empty" / "here"
    work.mkdir(parents=True)
    started = time.monotonic()
    done = tribofmu("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", out, "--no-plots",
                    cwd=work, env=env, timeout=120)
    one_line(done, 2, "--out")
    assert time.monotonic() - started < 30  # refused up front, not after the simulation
    assert list(work.iterdir()) == []


def test_second_run_into_the_same_out_is_refused_while_the_first_writes(tmp_path, env, fmu_dir):
    out = tmp_path / "shared"
    first = subprocess.Popen(command("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", out, "--no-plots",
                                     "--set", "time.periods=40", "--set", "time.window=[39,40]"),
                             cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    locks = Path(env["TMPDIR"]) / f"tribofmu-{os.getuid()}-locks"
    deadline = time.monotonic() + 120
    while not (locks.is_dir() and any(locks.iterdir())) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert locks.is_dir() and any(locks.iterdir()), "the first run never took its lock"
    second = tribofmu("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", out, "--no-plots",
                      *SHORT, cwd=tmp_path, env=env, timeout=120)
    one_line(second, 2, "another tribofmu run", f"(process {first.pid})")
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    stats = json.loads((out / "stats.json").read_text())
    assert stats["scenario"]["time"]["periods"] == 40  # the first run's set, not replaced
    assert not locks.exists()  # released, the temp dir as it was
    third = tribofmu("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", out, "--no-plots",
                     *SHORT, cwd=tmp_path, env=env, timeout=300)
    assert third.returncode == 0, third.stderr  # nobody writes now: allowed


# -- interruptions --------------------------------------------------------------------------
@pytest.mark.alone
@pytest.mark.parametrize("delay", [0.15, 0.3, 0.45, 0.6])
def test_interrupt_during_start_up_is_one_line_and_130(tmp_path, env, fmu_dir, delay):
    # 80 periods: a run of a second or more (Fig. 2's own is one run of 0.15 s), so that every
    # delay lands before its end
    proc = subprocess.Popen(command("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", tmp_path / "out",
                                    "--no-plots", "--set", "time.periods=80"),
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the run ended before the signal")
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines() == ["tribofmu: interrupted; no result was written (earlier results are as they were)"]


def sweep_args(out: Path, fmu_dir, *extra, masses: str = "0.5,0.6") -> list:
    return ["sweep", "fig2_dry", "--grid", "drive.omega=20,30,40,50", "--grid", f"block.M={masses}",
            *SHORT, "--fmu-dir", fmu_dir, "--no-plots", "--out", out, "-q", *extra]


# (A terminal's Ctrl-C about 1.5 s in, while the local Dask cluster starts, ended the process
# by SIGINT without the line in 2 of 6 tries on 2026-11-25; after the teardown fix below,
# 0 of 21 tries between 0.3 and 2.0 s did, by /tmp-scripted runs. The delays here are past
# the cluster's start-up to keep the suite short.)
@pytest.mark.alone
@pytest.mark.parametrize("delay", [3.0, 5.0])
@pytest.mark.parametrize("group", [False, True], ids=["process", "terminal-ctrl-c"])
def test_interrupted_dask_sweep_is_one_line_and_130(tmp_path, env, fmu_dir, delay, group):
    pytest.importorskip("distributed")
    out = tmp_path / "sweep"
    # 512 points (the signal ends it at 3 or 5 s): still running at 5 s on a fast machine, so
    # the signal interrupts work and the test does not skip (32 points finished within 5 s once
    # dry friction's stick steps got cheaper, 2026-11-25; 64 once a dry point was one run,
    # 2026-11-27; 128 once a stick a slip step passed over was landed on, 2026-11-27 09:45)
    masses = ",".join(f"{m / 10:g}" for m in range(3, 131))
    proc = subprocess.Popen(command(*sweep_args(out, fmu_dir, "--workers", "2", masses=masses)), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(delay)
    if group:  # what a terminal's Ctrl-C does: every process of the foreground group
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=180)
    time.sleep(1.0)  # anything the workers would still print
    lines = [line for line in err.strip().splitlines() if not line.startswith("starting a local Dask cluster")]
    if proc.returncode == 0:
        pytest.skip("the sweep ended before the signal")
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "Error" not in err, err
    assert len(lines) == 1 and lines[0].startswith("tribofmu: "), err


@pytest.mark.alone
@pytest.mark.parametrize("workers", ["0", "2"])
def test_a_signal_after_the_sweep_is_done_changes_nothing(tmp_path, env, fmu_dir, workers):
    """A Ctrl-C as the summary appears lands in the teardown (Dask's atexit handlers, the
    interpreter's finalization): the complete sweep keeps exit 0, with no traceback and no
    death by SIGINT (CI, 2026-11-25: exit -2 with nothing said; here: atexit tracebacks)."""
    if workers != "0":
        pytest.importorskip("distributed")
    out = tmp_path / "sweep"
    proc = subprocess.Popen(command(*sweep_args(out, fmu_dir, "--workers", workers)), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    summary = proc.stdout.readline()  # printed once sweep.csv holds every point
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=180)
    assert summary.startswith("8 points: 8 ok"), (summary, err)
    assert proc.returncode == 0, err
    assert "Traceback" not in err and "interrupted" not in err, err
    assert len((out / "sweep.csv").read_text().strip().splitlines()) == 9


@pytest.mark.alone
def test_interrupted_recompute_leaves_the_earlier_sweep_whole_and_resumes(tmp_path, env, fmu_dir):
    out = tmp_path / "sweep"
    done = tribofmu(*sweep_args(out, fmu_dir, "--workers", "0"), cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    before = (out / "sweep.csv").read_bytes()
    assert len(before.decode().strip().splitlines()) == 9
    points_before = sorted(p.name for p in (out / "points").iterdir())
    proc = subprocess.Popen(command(*sweep_args(out, fmu_dir, "--workers", "0", "--recompute")), cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120  # until the recompute has finished a point or two
    staged = out / ".recompute" / "sweep.csv"
    while time.monotonic() < deadline and not (staged.is_file() and len(staged.read_text().splitlines()) >= 3):
        if (out / "sweep.csv").read_bytes() != before:  # (a recompute that writes over the earlier sweep)
            time.sleep(1.0)
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the recompute ended before the signal")
    assert proc.returncode == 130, err
    assert "the earlier sweep in" in err and "as it was" in err
    assert (out / "sweep.csv").read_bytes() == before  # every row, every column
    assert sorted(p.name for p in (out / "points").iterdir()) == points_before
    again = tribofmu(*sweep_args(out, fmu_dir, "--workers", "0", "--recompute"), cwd=tmp_path, env=env)
    assert again.returncode == 0, again.stderr
    # resumed: the points recomputed before the interrupt kept (-q: the summary line says so)
    resumed = re.search(r"\((\d+) run, (\d+) already done\)", again.stdout)
    assert resumed and int(resumed.group(2)) >= 1, again.stdout
    after = (out / "sweep.csv").read_text().strip().splitlines()
    assert len(after) == 9 and after[0] == before.decode().splitlines()[0]
    assert after != before.decode().strip().splitlines()  # new rows (new finish times)
    assert not (out / ".recompute").exists()
