"""Issue 39: no temp file outlives its run. Killed runs left their check spools
(``tribofmu-spool-*.pickle``, up to 64 MB each: 57 files, 170 MB after 60 kills) and a
SIGHUP (a closed terminal) left the spools and the unzipped FMUs too. Now both live in one
folder per run (:mod:`tribofmu.run_folder`), removed at exit and on SIGINT, SIGTERM and
SIGHUP; the next run removes those of runs whose process is gone.
(``benchmarks/measure_kill_leftovers.py`` runs the issue's 60 kills.)"""
from __future__ import annotations

import os
import random
import signal
import subprocess
import time
from pathlib import Path

import pytest

from cli_run import command, tribofmu

LEFTOVER_PATTERNS = ("tribofmu-spool-*", "tribofmu-fmus-*", "tribofmu-run-*")


def leftovers(tmp: Path) -> list[str]:
    return sorted(p.name for pattern in LEFTOVER_PATTERNS for p in tmp.glob(pattern))


def spools(tmp: Path) -> list[Path]:
    """The spools under tmp now (a run removes a gone process's folder while this walks it:
    the walk is then made again)."""
    while True:
        try:
            return list(tmp.rglob("tribofmu-spool-*"))
        except FileNotFoundError:
            continue


def start(tmp_path, env, fmu_dir, out: str) -> subprocess.Popen:
    return subprocess.Popen(command("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", tmp_path / out,
                                    "--no-plots", "-q"),
                            cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)


def wait_for_spool(tmp: Path, proc: subprocess.Popen, timeout: float = 60.0) -> bool:
    began = time.monotonic()
    while time.monotonic() - began < timeout and proc.poll() is None:
        if spools(tmp):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGTERM, signal.SIGINT])
def test_a_signal_during_the_check_leaves_no_temp_file(tmp_path, env, fmu_dir, sig):
    tmp = Path(env["TMPDIR"])
    proc = start(tmp_path, env, fmu_dir, "o")
    assert wait_for_spool(tmp, proc), "the run made no spool"
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err  # stopped cleanly, said so
    assert leftovers(tmp) == [], leftovers(tmp)


def test_a_run_under_nohup_outlives_a_hangup(tmp_path, env, fmu_dir):
    """SIGHUP stops a run only where the user left it on: under nohup it goes on."""
    tmp = Path(env["TMPDIR"])
    proc = subprocess.Popen(command("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", tmp_path / "o",
                                    "--no-plots", "-q"), cwd=tmp_path, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    assert wait_for_spool(tmp, proc), "the run made no spool"
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert (tmp_path / "o" / "result.csv").is_file() and leftovers(tmp) == []


def test_kills_at_random_moments_then_one_run_leave_nothing(tmp_path, env, fmu_dir):
    """Six kills (SIGKILL, SIGHUP, SIGTERM, twice each) at random moments of a run, then one
    normal run: no spool and no unzipped FMU is left."""
    tmp = Path(env["TMPDIR"])
    rng = random.Random(39)
    kinds = [signal.SIGKILL, signal.SIGHUP, signal.SIGTERM] * 2
    killed_with_spool = 0
    for i, sig in enumerate(kinds):
        proc = start(tmp_path, env, fmu_dir, f"o{i}")
        if i % 2 == 0:  # half of them once the check's spools exist, half at any moment
            killed_with_spool += wait_for_spool(tmp, proc)
            time.sleep(rng.uniform(0.0, 0.5))
        else:
            time.sleep(rng.uniform(0.2, 3.0))
        if proc.poll() is None:
            os.killpg(proc.pid, sig)
        proc.communicate(timeout=60)  # reaped: its pid is gone
    assert killed_with_spool >= 2  # SIGKILL's leftovers are there to be cleaned up
    done = tribofmu("simulate", "fig2_dry", "--fmu-dir", fmu_dir, "--out", tmp_path / "last", "--no-plots", "-q",
                    cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert leftovers(tmp) == [] and spools(tmp) == [], leftovers(tmp)


def test_a_folder_of_a_live_process_or_not_ours_is_kept(tmp_path, monkeypatch):
    from tribofmu import run_folder
    live = tmp_path / f"tribofmu-run-{os.getppid()}-abc"  # the parent is alive
    other = tmp_path / "tribofmu-run-notapid-abc"
    gone = tmp_path / "tribofmu-run-999999999-abc"
    link = tmp_path / "tribofmu-run-999999998-abc"
    for folder in (live, other, gone):
        folder.mkdir()
    link.symlink_to(live)
    assert run_folder.remove_gone_runs(tmp_path) == 1
    assert live.is_dir() and other.is_dir() and link.is_symlink() and not gone.exists()
