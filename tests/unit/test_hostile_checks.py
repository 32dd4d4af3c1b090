"""Issue 30, the checks behind the CLI's refusals, at their limits (the integration tier,
tests/integration/test_hostile.py, runs the command itself): a run must resolve its drive,
--max-wall must mean what it says, --out must be a folder a result set can replace."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from tribofmu import api
from tribofmu.cli_checks import (UsageError, check_algorithm_options, check_swappable, lock_out,
                                 lock_path, release_out_locks)

from scenes import scene


@pytest.fixture(scope="module")
def fig2():
    return api.load(scene("fig2_dry"))


def test_fixed_step_needs_ten_points_per_drive_period(fig2):
    period = 2 * math.pi / fig2.drive.omega
    for algorithm in ("jacobi", "gauss-seidel", "implicit"):
        assert check_algorithm_options(fig2, algorithm, period / 10.01, None) == algorithm
        with pytest.raises(UsageError, match=r"communication points per drive period .* at least 10"):
            check_algorithm_options(fig2, algorithm, period / 9.99, None)


def test_scene_step_and_default_step_are_checked_too(fig2):
    coarse = api.load(scene("fig2_dry"), {"simulation.step": 0.05, "simulation.algorithm": "jacobi"})
    with pytest.raises(UsageError, match=r"^simulation.step 0.05 s"):
        check_algorithm_options(coarse, None, None, None)
    fast = api.load(scene("fig2_dry"), {"drive.omega": 7e4})  # period 9e-5 s < 10 default steps
    with pytest.raises(UsageError, match=r"^the jacobi default step 0.0001 s"):
        check_algorithm_options(fast, "jacobi", None, None)
    assert check_algorithm_options(fast, "adaptive", None, None) == "adaptive"


def test_adaptive_needs_twenty_two_nanosecond_steps_per_period():
    limit = 2 * math.pi / (20 * 2e-9)
    ok = api.load(scene("fig2_dry"), {"drive.omega": limit * 0.999})
    assert check_algorithm_options(ok, "adaptive", None, None) == "adaptive"
    fast = api.load(scene("fig2_dry"), {"drive.omega": limit * 1.001})
    with pytest.raises(UsageError, match=r"drive.omega must be <= 1.57e\+08 rad/s"):
        check_algorithm_options(fast, "adaptive", None, None)


def test_a_run_longer_than_the_time_grid_is_refused():
    slow = api.load(scene("fig2_dry"), {"drive.omega": 1e-100})
    with pytest.raises(UsageError, match="longer than the time grid holds"):
        check_algorithm_options(slow, None, None, None)
    # a century of drive: still on the grid (int64 nanoseconds hold 146 years)
    century = api.load(scene("fig2_dry"), {"drive.omega": 2 * math.pi * 6.5 / (100 * 365.25 * 86400)})
    assert check_algorithm_options(century, None, None, None) == "adaptive"


@pytest.mark.parametrize("max_wall, ok", [(0.0, True), (1.0, True), (3.0, True), (1800.0, True), (0.99, False),
                                          (1e-100, False), (-1.0, False), (math.inf, False)])
def test_max_wall_is_zero_or_at_least_a_second(fig2, max_wall, ok):
    if ok:
        check_algorithm_options(fig2, None, None, None, max_wall)
    else:
        with pytest.raises(UsageError, match="--max-wall"):
            check_algorithm_options(fig2, None, None, None, max_wall)


def test_sampling_points_far_beyond_int64_nanoseconds_does_not_overflow():
    from tribofmu.coupling.interpolation import sample
    from tribofmu.coupling.system import Contact, Point
    point = dict(X=0.0, V=0.0, aX=0.0, x=0.0, v=0.0, a=0.0, F=0.0, f=0.0, mode=Contact.FORWARD, T=290.0, n=-20.0, Q=0.0)
    points = [Point(t_ns=0, **point), Point(t_ns=10**30, **point)]
    out = sample(points, np.array([0.0, 1e20]))
    assert np.all(out["x"] == 0.0)


@pytest.mark.parametrize("name", [".", "..", "./", ""])
def test_out_naming_the_current_folder_or_a_parent_is_refused(tmp_path, monkeypatch, name):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    with pytest.raises(UsageError, match="--out"):
        check_swappable(Path(name))


def test_out_holding_the_current_folder_is_refused_and_a_new_folder_is_not(tmp_path, monkeypatch):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    with pytest.raises(UsageError, match="current folder or holds it"):
        check_swappable(tmp_path / "a")
    check_swappable(Path("new"))
    check_swappable(tmp_path / "elsewhere")


def test_root_is_refused():
    with pytest.raises(UsageError, match="cannot be replaced"):
        check_swappable(Path("/"))


def test_the_lock_lives_in_the_temp_dir_and_is_gone_after_release(tmp_path, monkeypatch):
    import tempfile
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", None)
    out = tmp_path / "out"
    path = lock_path(out)
    assert path.parent.parent == tmp_path / "tmp"
    try:
        lock_out(out)
        assert path.is_file() and path.read_text().strip() == str(os.getpid())
        assert not out.exists()  # the preflight makes no folder
    finally:
        release_out_locks()
    assert not path.parent.exists()


def test_the_api_refuses_an_unresolvable_drive_as_the_cli_does(tmp_path):
    """api.simulate: the same one-line refusal, before any FMU is found or built."""
    from tribofmu import api
    from tribofmu.errors import TriboFMUError, UsageError
    with pytest.raises(UsageError, match="drive.omega") as caught:
        api.simulate("fig2_dry", {"drive.omega": 1e12}, fmu_dir=tmp_path / "none", build=False)
    assert isinstance(caught.value, TriboFMUError)
