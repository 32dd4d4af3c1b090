"""A run that cannot meet its tolerance keeps its result set but is not ok: stats.json says
so with the checked error and what to do, the CLI prints one line and exits 3 (issue 27)."""
from __future__ import annotations

import json

import pytest

from tribofmu import checked

from cli_run import main

pytestmark = pytest.mark.integration
SHORT = ["--set", "time.periods=1", "--set", "time.window=[0,1]"]


def test_a_tolerance_not_met_keeps_the_results_says_so_and_exits_3(tmp_path, fmu_dir, monkeypatch, capsys):
    monkeypatch.setattr(checked, "MAX_RUNS", 1)  # the sequence stops before its check
    out = tmp_path / "o"
    # dry friction under a load program: a Load FMU changes n over the run, so its runs' own
    # estimates cannot vouch for them (a check is needed)
    captured = main("simulate", "dry_load_oscillation", *SHORT, "--tol", "1e-5", "--max-wall", "0", "--fmu-dir", fmu_dir,
                    "--out", out, "--no-plots", "-q", capsys=capsys)
    assert captured.returncode == 3, captured.stderr
    lines = captured.stderr.strip().splitlines()
    assert len(lines) == 1 and "tolerance 1e-05 not checked" in lines[0] and "Traceback" not in captured.stderr
    stats = json.loads((out / "stats.json").read_text())
    assert stats["ok"] is False and stats["completed"] is True and stats["tolerance_met"] is False
    assert stats["tol"] == 1e-5 and stats["estimated_error"]["nrms_v"] is None
    assert (out / "result.csv").is_file()  # kept: the user decides


def _simulated_ok(scene: str, tmp_path, fmu_dir, capsys):
    """`tribofmu simulate SCENE` over one period, quiet: what it printed (it exited 0) and its
    stats.json."""
    out = tmp_path / "o"
    captured = main("simulate", scene, *SHORT, "--fmu-dir", fmu_dir, "--out", out, "--no-plots", "-q", capsys=capsys)
    assert captured.returncode == 0, captured.stderr
    return captured, json.loads((out / "stats.json").read_text())


def test_a_met_tolerance_is_ok_and_reports_the_checked_error(tmp_path, fmu_dir, capsys):
    captured, stats = _simulated_ok("dry_load_oscillation", tmp_path, fmu_dir, capsys)
    assert "checked nRMS(v)" in captured.stdout and "(tol 0.001)" in captured.stdout
    assert stats["ok"] and stats["tolerance_met"] and stats["estimated_error"]["nrms_v"] <= 1e-3
    assert len(stats["check"]["runs"]) >= 2 and stats["step_tol"] == stats["check"]["runs"][-1]["step_tol"]
    assert stats["wall_time"] >= sum(r["wall_time"] for r in stats["check"]["runs"])
    # the reported run's stepping calls per accepted step, by kind (the check's runs apart)
    per_step = stats["fmu_calls_per_step"]
    assert set(per_step["by_kind"]) == {"get", "set", "doStep", "save", "restore", "free"}
    assert per_step["total"] == sum(per_step["by_kind"].values()) and 5 < per_step["total"] < 100


def test_a_run_whose_own_estimate_vouches_is_reported_alone_and_says_so(tmp_path, fmu_dir, capsys):
    captured, stats = _simulated_ok("fig2_dry", tmp_path, fmu_dir, capsys)
    assert "estimated nRMS(v)" in captured.stdout and "one run: its own estimate vouches" in captured.stdout
    error = stats["estimated_error"]
    assert stats["ok"] and len(stats["check"]["runs"]) == 1 and error["vouches"]
    assert error["nrms_v"] == checked.ESTIMATE_SAFETY * error["propagated"] <= 1e-3


def test_a_call_whose_last_run_vouches_after_others_says_how_many_runs(tmp_path, fmu_dir, capsys):
    """Mixed friction over one period: its first run's doubled estimate misses tol, the next
    run, planned from it, vouches for itself. The line and stats.json say that the reported run
    is the last of several (it said "one run" before)."""
    captured, stats = _simulated_ok("mixed_stribeck", tmp_path, fmu_dir, capsys)
    runs = len(stats["check"]["runs"])
    assert runs >= 2 and stats["estimated_error"]["vouches"] and stats["ok"]
    assert f"{runs} runs: the last one's own estimate vouches" in captured.stdout
    assert "one run" not in captured.stdout
    assert stats["estimated_error"]["method"].endswith(
        f"it is run {runs} of {runs}, each after the first planned from the estimate of the one before, "
        "which had missed tol or, meeting it, was to be verified by the next")
