"""The Python API saves what the CLI saves: ``api.simulate_and_save`` (what ``tribofmu simulate``
calls) and ``api.save`` (a result already in memory) write the same result set, whole or not at
all."""
from __future__ import annotations

import json

import pytest

from tribofmu import api

from cli_run import main
from scenes import FIG2

pytestmark = pytest.mark.integration

SET = ["columns.json", "friction.png", "phase.png", "result.csv", "stats.json", "time.png"]


def names(folder):
    return sorted(p.name for p in folder.iterdir())


def test_a_notebook_user_gets_the_folder_a_cli_user_gets(tmp_path, fmu_dir, capsys):
    by_cli, by_api, saved = tmp_path / "cli", tmp_path / "api", tmp_path / "saved"
    assert main("simulate", FIG2, "--out", by_cli, "--fmu-dir", fmu_dir, "-q", capsys=capsys).returncode == 0
    result = api.simulate_and_save(FIG2, by_api, fmu_dir=fmu_dir, build=False)
    assert result.ok and result.time[0] > 0  # the window alone is kept; the rest is on disk
    whole = api.simulate(FIG2, fmu_dir=fmu_dir, build=False)
    assert api.save(whole, saved, scene_file=FIG2) == saved
    for folder in (by_cli, by_api, saved):
        assert names(folder) == SET, folder
        assert (folder / "result.csv").read_bytes() == (by_cli / "result.csv").read_bytes(), folder
        assert (folder / "columns.json").read_bytes() == (by_cli / "columns.json").read_bytes(), folder
    stats = {f: json.loads((f / "stats.json").read_text()) for f in (by_cli, by_api, saved)}
    assert stats[by_cli].keys() == stats[by_api].keys() == stats[saved].keys()
    for s in stats.values():
        assert s["metrics"] == stats[by_cli]["metrics"] and s["scenario"] == stats[by_cli]["scenario"]
        assert s["provenance"]["scene"] == stats[by_cli]["provenance"]["scene"]
        assert s["provenance"]["settings"]["algorithm"] == "adaptive"
    assert stats[by_cli]["provenance"]["command"][0] == "tribofmu"
    assert stats[by_api]["provenance"]["command"] is None
    # the same with overrides and without plots; a Scenario object records no file
    quick = api.simulate_and_save(api.load("fig2_dry"), tmp_path / "w80", {"drive.omega": 80},
                                  fmu_dir=fmu_dir, build=False, plots=False)
    assert quick.scenario.drive.omega == 80 and names(tmp_path / "w80") == ["columns.json", "result.csv", "stats.json"]
    assert json.loads((tmp_path / "w80" / "stats.json").read_text())["provenance"]["scene"]["file"] is None


def test_save_is_whole_or_nothing_and_never_takes_a_users_files(tmp_path, fmu_dir, monkeypatch):
    whole = api.simulate(FIG2, fmu_dir=fmu_dir, build=False)
    out = tmp_path / "run"
    api.save(whole, out, plots=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    import tribofmu.plots

    def broken(*args, **kwargs):
        raise RuntimeError("the plot failed")
    monkeypatch.setattr(tribofmu.plots, "plot_result", broken)
    with pytest.raises(RuntimeError, match="the plot failed"):
        api.save(whole, out)
    with pytest.raises(RuntimeError, match="the plot failed"):
        api.simulate_and_save(FIG2, out, fmu_dir=fmu_dir, build=False)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # the earlier set, as it was
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no partial folder left beside it

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="notes.txt"):
        api.save(whole, mine, plots=False)
    assert names(mine) == ["notes.txt"]

    window_only = api.simulate(FIG2, fmu_dir=fmu_dir, build=False, keep_window=True)
    with pytest.raises(ValueError, match="window"):
        api.save(window_only, tmp_path / "w", plots=False)


def test_a_run_that_did_not_complete_is_saved_as_its_stats_alone(tmp_path, fmu_dir):
    import dataclasses

    whole = api.simulate(FIG2, fmu_dir=fmu_dir, build=False)
    failed = dataclasses.replace(whole, ok=False, message="diverged",
                                 stats={**whole.stats, "ok": False, "completed": False})
    api.save(failed, tmp_path / "failed")
    assert names(tmp_path / "failed") == ["stats.json"]
    assert json.loads((tmp_path / "failed" / "stats.json").read_text())["message"] == whole.stats["message"]
    # a run that completed but missed a target (stats "completed": true, ok false) keeps its whole set
    short = dataclasses.replace(whole, ok=False, stats={**whole.stats, "ok": False, "completed": True})
    api.save(short, tmp_path / "short", plots=False)
    assert names(tmp_path / "short") == ["columns.json", "result.csv", "stats.json"]
