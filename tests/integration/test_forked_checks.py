"""The check's runs two at a time on real FMUs (tribofmu.forked_runs): the same result, bit for
bit, as one run at a time, through the API and the command; a progress bar that goes on; a
Ctrl-C that stops every run and leaves nothing; a wrong TRIBOFMU_CHECK_WORKERS in one line.

(The rest of the suite runs one run at a time, conftest.py says why.)"""
from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from cli_run import command, tribofmu
from scenes import scene

pytestmark = [pytest.mark.integration,
              pytest.mark.skipif(not hasattr(os, "fork"), reason="forked runs need fork()")]

SHORT = {"time.periods": 2.0, "time.window": [1.0, 2.0]}
# Dry friction under a load program: a Load FMU changes n over the run, so its runs' own
# estimates cannot vouch for them and its calls make several runs (Fig. 2's dry friction, and
# since 2026-11-27 a shear-thinning fluid, are one run, with nothing to run beside it)
CHECKED = scene("dry_load_oscillation")
TIMES = ("wall_time", "cpu_time")


def _same_stats(one: dict, two: dict) -> None:
    """Equal but for the times and the workers (and the check's bookkeeping of them); the
    command's provenance (its --out, its date) apart."""
    a, b = dict(one), dict(two)
    for key in (*TIMES, "provenance"):
        a.pop(key, None), b.pop(key, None)
    ca, cb = a.pop("check"), b.pop("check")
    assert a == b
    assert [{k: v for k, v in r.items() if k != "wall_time"} for r in ca["runs"]] == \
           [{k: v for k, v in r.items() if k != "wall_time"} for r in cb["runs"]]
    assert (ca["workers"], cb["workers"]) == (1, 2)


@pytest.mark.parametrize("name, overrides", [("dry_load_oscillation", SHORT),
                                             ("boundary_heating", {"time.periods": 1.0, "time.window": [0.5, 1.0]})],
                         ids=["dry under a load program", "boundary with Thermal and Load"])
def test_two_workers_give_the_same_result_bit_for_bit(fmu_dir, name, overrides):
    from tribofmu import api

    scenario = api.load(scene(name), overrides)
    one = api.simulate(scenario, fmu_dir=fmu_dir, build=False, check_workers=1)
    two = api.simulate(scenario, fmu_dir=fmu_dir, build=False, check_workers=2)
    for signal_name in ("time", "x", "v", "F", "f", "stuck"):
        assert np.array_equal(getattr(one, signal_name), getattr(two, signal_name)), signal_name
    for key in one.inputs:
        assert np.array_equal(one.inputs[key], two.inputs[key]), key
    assert two.ok == one.ok and two.message == one.message
    _same_stats(one.stats, two.stats)


def test_the_command_writes_the_same_result_csv_with_two_workers_and_leaves_no_temp_files(tmp_path, env, fmu_dir):
    outs = {}
    for workers in ("1", "2"):
        outs[workers] = tmp_path / f"out{workers}"
        done = tribofmu("simulate", CHECKED, "--fmu-dir", fmu_dir, "--out", outs[workers], "-q", "--no-plots",
                        "--set", "time.periods=2", "--set", "time.window=[1,2]", cwd=tmp_path,
                        env=dict(env, TRIBOFMU_CHECK_WORKERS=workers))
        assert done.returncode == 0, done.stderr
    assert (outs["1"] / "result.csv").read_bytes() == (outs["2"] / "result.csv").read_bytes()
    stats = {w: json.loads((outs[w] / "stats.json").read_text()) for w in outs}
    _same_stats(stats["1"], stats["2"])
    assert list(os.scandir(env["TMPDIR"])) == []  # no spool, result pickle or run folder left


def test_the_bar_goes_on_through_forked_runs(fmu_dir):
    from tribofmu import api
    from tribofmu.progress import RunBar

    class TTY(io.StringIO):
        def isatty(self):
            return True

    scenario = api.load(CHECKED, SHORT)
    shown, stream = [], TTY()

    class Watched(RunBar):
        def __call__(self, status):
            super().__call__(status)
            shown.append((self.run, self.fraction, status.steps))

    with Watched(scenario.name, scenario.stop_time, enabled=True, stream=stream, interval=0.0) as bar:
        result = api.simulate(scenario, fmu_dir=fmu_dir, build=False, progress=bar, check_workers=2)
    made = len(result.stats["check"]["runs"])
    assert {run for run, _, _ in shown} == set(range(1, made + 1))  # every run it waited for told
    assert all(b[1] >= a[1] for a, b in zip(shown, shown[1:]))
    assert shown[-1][2] == result.stats["communication_steps"]  # the reported run's last step
    assert f"run {made} of {made}" in stream.getvalue()


@pytest.mark.alone
@pytest.mark.parametrize("delay", [0.6, 1.2])
def test_ctrl_c_stops_every_run_in_one_line_and_leaves_nothing(tmp_path, env, fmu_dir, delay):
    # Fig. 6's scene: seconds of runs, so the terminal's Ctrl-C (the whole process group)
    # arrives while both forked runs work
    proc = subprocess.Popen(command("simulate", "fig6_boundary", "--fmu-dir", fmu_dir, "--out", tmp_path / "out",
                                    "--no-plots"),
                            cwd=tmp_path, env=dict(env, TRIBOFMU_CHECK_WORKERS="2"), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == \
        "tribofmu: interrupted; no result was written (earlier results are as they were)"
    assert "Traceback" not in err
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and _group_alive(proc.pid):
        time.sleep(0.05)
    assert not _group_alive(proc.pid)
    assert not (tmp_path / "out").exists()
    assert list(os.scandir(env["TMPDIR"])) == []


def _group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
        return True
    except ProcessLookupError:
        return False


@pytest.mark.parametrize("value", ["two", "0"])
def test_a_wrong_workers_variable_is_one_line_and_exit_2(tmp_path, env, value):
    done = tribofmu("simulate", "fig2_dry", "--out", tmp_path / "out", cwd=tmp_path,
                    env=dict(env, TRIBOFMU_CHECK_WORKERS=value))
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [
        f"tribofmu: TRIBOFMU_CHECK_WORKERS{'=' + repr(value) if value == 'two' else ''} must be a whole number "
        f">= 1{'' if value == 'two' else ', got 0'}"]
    assert not (tmp_path / "out").exists()
