"""What a user sees: every coupled signal in result.csv with its unit, the saved result redrawn,
scenes by name, options that cannot apply refused with the reason, one folder per run, and
the CLI synopsis of docs/cli.md equal to the parser's."""
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from tribofmu import api, cli, columns
from tribofmu.errors import ScenarioError
from tribofmu.result_csv import write_result_csv
from tribofmu.scene.library import resolve_scene, scene_names, scenes_dir

from cli_run import tribofmu
from scenes import ROOT

pytestmark = pytest.mark.integration
SHORT = {"time.periods": 1.0, "time.window": [0.0, 1.0]}




# -- result.csv: every coupled signal, units in columns.json ----------------------------------------
@pytest.mark.parametrize("name, extra", [("fig2_dry", []), ("free_oscillator", []),
                                         ("boundary_heating", ["T", "Q"]), ("dry_load_oscillation", ["n"])])
def test_result_csv_carries_every_coupled_signal_with_units(fmu_dir, tmp_path, name, extra):
    overrides = dict(SHORT) if name != "boundary_heating" else {"time.periods": 0.5, "time.window": [0, 0.5]}
    result = api.simulate(name, overrides, fmu_dir=fmu_dir, build=False)
    assert result.ok, result.message
    written = write_result_csv(result, tmp_path / "result.csv")
    names = ["time", "X", "V", "x", "v", "F", "f", "stuck", "dv", "a", *extra]
    assert [c.name for c in written] == names
    with open(tmp_path / "result.csv") as fh:
        assert fh.readline().strip() == ",".join(names)
    side = json.loads((tmp_path / "columns.json").read_text())
    assert [c["name"] for c in side["columns"]] == names and all(c["unit"] for c in side["columns"])
    back = columns.read_result_csv(tmp_path / "result.csv")
    assert np.array_equal(back["v"], result.v) and np.array_equal(back["stuck"], result.stuck)
    assert np.allclose(back["dv"], result.V - result.v, rtol=0, atol=1e-15)
    # a: the block's equation of motion, checked against the derivative of the sampled v
    t, v, a = back["time"], back["v"], back["a"]
    slope = np.gradient(v, t)
    scale = max(np.max(np.abs(slope)), 1e-12)
    smooth = np.abs(np.diff(slope, prepend=slope[0])) < 0.02 * scale  # away from kinks (stick-slip)
    assert np.median(np.abs(a - slope)[smooth]) < 2e-2 * scale
    if "T" in extra:
        assert back["T"][0] == pytest.approx(290.0) and back["T"][-1] > 300.0  # the film heats
        assert np.all(np.diff(back["Q"]) >= -1e-18)
    if "n" in extra:  # the Load FMU's program, L = -n S from 15 N up
        sc = result.scenario
        expected = np.array([sc.normal_stress(x) for x in t])
        assert np.allclose(back["n"], expected, rtol=1e-4)  # linear between communication points


def test_column_table_is_the_one_writers_use():
    sc = api.load("dry_load_oscillation")
    assert [c.name for c in columns.columns_for(sc)] == [c.name for c in columns.RESULT_CSV_COLUMNS if c.name not in ("T", "Q")]
    signals = {k: np.arange(3.0) + i for i, k in enumerate(("time", "X", "V", "x", "v", "F", "f", "stuck", "n"))}
    table = columns.rows(signals, sc)
    assert table.shape == (3, len(columns.columns_for(sc)))


# -- simulate -> stats.json metrics, plot DIR, scenes by name ----------------------------------------
def test_simulate_by_name_from_another_folder_then_plot_the_saved_result(tmp_path, env):
    proc = tribofmu("simulate", "dry_load_oscillation", "--set", "time.periods=2", "--set", "time.window=[0,2]",
                    "--no-plots", "-q", cwd=tmp_path, env=env)
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "out" / "dry_load_oscillation--time.periods=2--time.window=0,2"
    assert sorted(p.name for p in out.iterdir()) == ["columns.json", "result.csv", "stats.json"]
    stats = json.loads((out / "stats.json").read_text())
    assert set(stats["metrics"]) >= {"stick_fraction", "creep_fraction", "harmonics"}
    assert stats["metrics"]["creep_fraction"] is None and stats["metrics"]["stick_fraction"] > 0  # dry
    assert stats["provenance"]["scene"]["file"].endswith("dry_load_oscillation.toml")
    proc = tribofmu("plot", out, cwd=tmp_path, env=env)
    assert proc.returncode == 0, proc.stderr
    assert (out / "time.png").is_file() and (out / "phase.png").is_file()
    bad = tribofmu("plot", tmp_path, cwd=tmp_path, env=env)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "no result.csv" in bad.stderr


def test_time_png_draws_the_coupled_inputs(tmp_path):
    import matplotlib.pyplot as plt
    from tribofmu import plots
    drawn = {}
    original = plots.save_png

    def keep(fig, path, dpi=110):
        drawn[Path(path).name] = [ax.get_ylabel() for ax in fig.axes] + [fig._suptitle.get_text() if fig._suptitle else ""]
        plt.close(fig)
        return Path(path)
    plots.save_png = keep
    try:
        for name in ("boundary_heating", "dry_load_oscillation", "fig2_dry"):
            sc = api.load(name)
            t = np.linspace(0, sc.stop_time, 200)
            s = {k: np.sin(t) for k in ("X", "V", "x", "v", "F", "f", "stuck")}
            s.update(time=t, T=290 + 1000 * t / t[-1], n=np.array([sc.normal_stress(x) for x in t]), Q=t)
            plots.plot_signals(s, sc, tmp_path)
            labels = drawn["time.png"]
            assert ("T [K]" in labels) == (name == "boundary_heating"), labels
            assert ("load L [N]" in labels) == (name == "dry_load_oscillation"), labels
            if name == "boundary_heating":
                assert "T: 290 K → 1290 K" in labels[-1]
    finally:
        plots.save_png = original


def test_scenes_ship_in_the_package_and_are_listed(tmp_path, env):
    assert scenes_dir().is_dir() and scenes_dir().parent.name == "tribofmu"
    assert (ROOT / "scenarios").resolve() == scenes_dir().resolve()  # the repository's folder is the same
    names = scene_names()
    assert {"fig2_dry", "fig6_boundary", "boundary_heating", "dry_load_oscillation"} <= set(names)
    proc = tribofmu("scenes", cwd=tmp_path, env=env)
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 0 and [line.split()[0] for line in lines] == names
    assert all(len(line.split(None, 1)) == 2 for line in lines)  # a name and a description
    assert resolve_scene("fig2_dry") == resolve_scene("fig2_dry.toml") == scenes_dir() / "fig2_dry.toml"
    mine = tmp_path / "fig2_dry.toml"  # a file here wins over the shipped scene
    mine.write_text("[drive]\nomega = 7.0\n")
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        assert api.load("fig2_dry.toml").drive.omega == 7.0
    finally:
        os.chdir(here)
    with pytest.raises(ScenarioError, match="no scene named 'fig9'.*fig2_dry"):
        resolve_scene("fig9")
    proc = tribofmu("simulate", "fig9", cwd=tmp_path, env=env)
    assert proc.returncode == 2 and proc.stderr.startswith("tribofmu: no scene named 'fig9'")


# -- docs/cli.md synopsis == parser; --help plain with examples ----------------------------------------
CLI_PAGE = ROOT / "docs" / "cli.md"  # the CLI reference the README links to


def readme_cli_block() -> list[str]:
    text = CLI_PAGE.read_text()
    section = text.split("\n## Synopsis\n", 1)[1]
    block = re.search(r"```\n(.*?)```", section, re.S).group(1)
    return [line.split("  #")[0].rstrip() for line in block.strip().splitlines()]


def test_the_readme_synopsis_is_the_parser():
    lines = readme_cli_block()
    assert [line for line in lines if not line.startswith("tribofmu --version")] == cli.synopsis(), (
        "docs/cli.md 'Synopsis' block drifted from the parser; it should read:\n" + "\n".join(cli.synopsis()))


def test_every_option_help_lists_is_named_in_the_readme():
    readme = CLI_PAGE.read_text()
    parser = cli._parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        assert f"tribofmu {name}" in readme, name
        for action in p._actions:
            flags = [f for f in action.option_strings if f not in ("-h", "--help")]
            if flags:  # one of its spellings (-q for -q/--quiet)
                assert any(re.search(rf"tribofmu {name} .*{re.escape(f)}(?![\w-])", readme) for f in flags), (name, flags)


@pytest.mark.parametrize("command", [None, "build", "simulate", "plot", "scenes", "export-ssp", "sweep",
                                     "accuracy", "figures"])
def test_help_is_plain_text_with_an_example(command, capsys):
    with pytest.raises(SystemExit):
        cli._parser().parse_args([command, "--help"] if command else ["--help"])
    text = capsys.readouterr().out
    assert "``" not in text and ":mod:" not in text and ":func:" not in text
    assert re.search(r"examples?:\n  tribofmu ", text), text
    if command in ("simulate", "sweep", "accuracy", "export-ssp"):
        assert re.search(r"SCENARIO\s+a shipped scene's name", text), text
