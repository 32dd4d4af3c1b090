"""friction.png is part of simulate's result set: written beside time.png and phase.png, and a
second run into the same folder replaces the set (a friction.png there is the run's, not the
user's)."""
import pytest

from cli_run import main

pytestmark = pytest.mark.integration
SHORT = ["--set", "time.periods=1", "--set", "time.window=[0, 1]"]


def test_simulate_writes_friction_png_and_a_rerun_replaces_it(tmp_path, fmu_dir, capsys):
    out = tmp_path / "run"
    for _ in range(2):
        run = main("simulate", "mixed_stribeck", *SHORT, "--out", out, "--fmu-dir", fmu_dir, "--quiet",
                   capsys=capsys)
        assert run.returncode == 0, run.stderr
        assert {"time.png", "phase.png", "friction.png"} <= {p.name for p in out.iterdir()}
