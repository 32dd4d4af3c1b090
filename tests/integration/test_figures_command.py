"""``tribofmu figures`` on the built FMUs: a cheap subset (Figs. 2 and 3 share one run), its
saved runs reused by the next call, an unknown figure refused in one line. What the figures
draw is checked on fake runs in tests/unit/test_figures.py."""
import pytest

from cli_run import main

pytestmark = pytest.mark.integration


def test_figures_command_subset_reuses_its_runs(tmp_path, fmu_dir, capsys):
    out = tmp_path / "figs"
    args = ["figures", "--only", "fig2,fig3", "--out", out, "--fmu-dir", fmu_dir]
    first = main(*args, capsys=capsys)
    assert first.returncode == 0, first.stderr
    assert sorted(p.name for p in out.glob("*.png")) == ["fig2.png", "fig3.png"]
    assert "fig2_dry:" in first.stderr  # one simulation, shared by both figures
    assert first.stderr.count("steps,") == 1
    saved = out / "data" / "fig2_dry.npz"
    stamp = saved.stat().st_mtime_ns
    second = main(*args, capsys=capsys)
    assert second.returncode == 0 and "steps," not in second.stderr
    assert saved.stat().st_mtime_ns == stamp
    bad = main("figures", "--only", "fig9", "--out", out, capsys=capsys)
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines() == [
        "tribofmu: --only fig9: unknown figure 'fig9' (known: fig2, fig3, fig4, fig5, fig6, friction, tn_map)"]


def test_an_interrupted_figures_call_names_what_it_wrote(tmp_path, fmu_dir, capsys, monkeypatch):
    from tribofmu import figures

    def interrupted(runs, path):
        raise KeyboardInterrupt
    monkeypatch.setitem(figures.DRAW, "fig3", interrupted)
    out = tmp_path / "figs"
    run = main("figures", "--only", "fig2,fig3", "--out", out, "--fmu-dir", fmu_dir, "--quiet", capsys=capsys)
    assert run.returncode == 130
    assert (out / "fig2.png").is_file() and not (out / "fig3.png").exists()
    assert "no result was written" not in run.stderr
    assert "fig2_dry.npz" in run.stderr and "fig2.png" in run.stderr, run.stderr
