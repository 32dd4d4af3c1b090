"""What a user sees: every coupled signal in result.csv with its unit, the saved result redrawn,
scenes by name, options that cannot apply refused with the reason, one folder per run."""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from tribofmu import api, columns
from tribofmu.errors import ScenarioError
from tribofmu.result_csv import write_result_csv
from tribofmu.scene.library import resolve_scene, scene_names, scenes_dir

from cli_run import main, tribofmu
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


# -- simulate -> stats.json metrics, plot DIR, scenes by name ----------------------------------------
def test_simulate_by_name_from_another_folder_then_plot_the_saved_result(tmp_path, fmu_dir, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    proc = main("simulate", "dry_load_oscillation", "--set", "time.periods=2", "--set", "time.window=[0,2]",
                "--fmu-dir", fmu_dir, "--no-plots", "-q", capsys=capsys)
    assert proc.returncode == 0, proc.stderr
    out = tmp_path / "out" / "dry_load_oscillation--time.periods=2--time.window=0,2"
    assert sorted(p.name for p in out.iterdir()) == ["columns.json", "result.csv", "stats.json"]
    stats = json.loads((out / "stats.json").read_text())
    assert set(stats["metrics"]) >= {"stick_fraction", "creep_fraction", "harmonics"}
    assert stats["metrics"]["creep_fraction"] is None and stats["metrics"]["stick_fraction"] > 0  # dry
    assert stats["provenance"]["scene"]["file"].endswith("dry_load_oscillation.toml")
    proc = main("plot", out, capsys=capsys)
    assert proc.returncode == 0, proc.stderr
    assert (out / "time.png").is_file() and (out / "phase.png").is_file()
    bad = main("plot", tmp_path, capsys=capsys)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "no result.csv" in bad.stderr


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
