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
