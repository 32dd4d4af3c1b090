"""Issue 39: the Python API checks its arguments at the door. Each wrong argument below raised
a raw TypeError or AttributeError from deep inside (pathlib, checked.py, algorithms.py,
scenario.py), some only after the FMUs were built, or ran (tol=inf: ok, a silent wrong
answer). Now: an ArgumentError (a TriboFMUError) naming the call and the argument, in one
line of at most 300 characters, before any FMU is found or built."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tribofmu import api, api_arguments
from tribofmu.errors import MAX_MESSAGE, ArgumentError, TriboFMUError, UsageError

SCENE = "fig2_dry"

# (id, keyword arguments of api.simulate, the argument's name in the message)
SIMULATE = [
    ("scenario-None", dict(scenario=None), "scenario"),
    ("scenario-dict", dict(scenario={"drive": {"omega": 30}}), "scenario"),
    ("scenario-int", dict(scenario=42), "scenario"),
    ("scenario-empty", dict(scenario=""), "scenario"),
    ("overrides-str", dict(overrides="drive.omega=80"), "overrides"),
    ("overrides-int-key", dict(overrides={1: 80}), "key"),
    ("overrides-list-of-int", dict(overrides=[1, 2]), "overrides"),
    ("overrides-item-no-equals", dict(overrides=["drive.omega"]), "overrides"),
    ("algorithm-int", dict(algorithm=5), "algorithm"),
    ("algorithm-unknown", dict(algorithm="newton"), "newton"),
    ("step-negative", dict(algorithm="jacobi", step=-1e-3), "step"),
    ("step-zero", dict(algorithm="jacobi", step=0.0), "step"),
    ("step-str", dict(algorithm="jacobi", step="1e-3"), "step"),
    ("step-nan", dict(algorithm="jacobi", step=math.nan), "step"),
    ("tol-zero", dict(tol=0.0), "tol"),
    ("tol-negative", dict(tol=-1e-3), "tol"),
    ("tol-1e-300", dict(tol=1e-300), "tol"),
    ("tol-True", dict(tol=True), "tol"),
    ("tol-str", dict(tol="1e-3"), "tol"),
    ("tol-inf", dict(tol=math.inf), "tol"),
    ("tol-1e300", dict(tol=1e300), "tol"),
    ("tol-one", dict(tol=1.0), "tol"),
    ("tol-for-jacobi", dict(algorithm="jacobi", tol=1e-3), "tol"),
    ("max_wall-nan", dict(max_wall=math.nan), "max_wall"),
    ("max_wall-negative", dict(max_wall=-5.0), "max_wall"),
    ("max_wall-inf", dict(max_wall=math.inf), "max_wall"),
    ("max_wall-str", dict(max_wall="10"), "max_wall"),
    ("progress-int", dict(progress=5), "progress"),
    ("notice-str", dict(notice="say"), "notice"),
    ("sink-int", dict(sink=3), "sink"),
    ("fmu_dir-int", dict(fmu_dir=5), "fmu_dir"),
    ("build-str", dict(build="yes"), "build"),
    ("keep_points-str", dict(keep_points="no"), "keep_points"),
]


@pytest.fixture
def no_fmus(tmp_path, monkeypatch):
    """An empty FMU cache: a call that got past its checks would build into it."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("TRIBOFMU_CACHE", str(cache))
    return cache


def _refused(call, name: str, kind: type = UsageError) -> TriboFMUError:
    with pytest.raises(TriboFMUError) as caught:
        call()
    error = caught.value
    assert isinstance(error, kind), type(error)
    message = str(error)
    assert name in message and "\n" not in message and len(message) <= MAX_MESSAGE, message
    return error


@pytest.mark.parametrize("kwargs, name", [c[1:] for c in SIMULATE], ids=[c[0] for c in SIMULATE])
def test_simulate_refuses_a_wrong_argument_before_any_fmu_is_built(no_fmus, kwargs, name):
    kwargs = {"scenario": SCENE, **kwargs}
    error = _refused(lambda: api.simulate(**kwargs), name)
    assert str(error).startswith("api.simulate: ")
    assert not no_fmus.exists()  # nothing found, built or cached


# simulate_and_save takes every argument of simulate but sink and keep_points
SAVED = [c for c in SIMULATE if not {"sink", "keep_points"} & set(c[1])]


@pytest.mark.parametrize("kwargs, name", [c[1:] for c in SAVED], ids=[c[0] for c in SAVED])
def test_simulate_and_save_refuses_it_before_writing_anything(tmp_path, no_fmus, kwargs, name):
    kwargs = {"scenario": SCENE, **kwargs}
    _refused(lambda: api.simulate_and_save(out=tmp_path / "run", **kwargs), name)
    assert list(tmp_path.iterdir()) == []  # no cache, no output folder, no partial set


@pytest.mark.parametrize("out", [None, 5, ""])
def test_simulate_and_save_needs_a_path_for_out(tmp_path, no_fmus, out):
    _refused(lambda: api.simulate_and_save(SCENE, out), "out")
    assert not no_fmus.exists()


def _result() -> api.SimulationResult:
    scenario = api.load(SCENE)
    t = np.linspace(0.0, scenario.stop_time, 11)
    zeros = np.zeros_like(t)
    return api.SimulationResult(scenario, t, *(zeros,) * 7, ok=True, message="ok", stats={"completed": True})


@pytest.mark.parametrize("args, kwargs, name", [
    (("out/x", "run"), {}, "result"),
    ((None, "run"), {}, "result"),
    ((_result, None), {}, "out"),
    ((_result, 5), {}, "out"),
    ((_result, "run"), {"plots": "no"}, "plots"),
    ((_result, "run"), {"scene_file": 3}, "scene_file"),
    ((_result, "run"), {"overrides": "drive.omega=3"}, "overrides"),
], ids=["result-str", "result-None", "out-None", "out-int", "plots-str", "scene_file-int", "overrides-str"])
def test_save_refuses_a_wrong_argument_before_writing(tmp_path, monkeypatch, args, kwargs, name):
    monkeypatch.chdir(tmp_path)
    args = tuple(a() if callable(a) else a for a in args)
    _refused(lambda: api.save(*args, **kwargs), name)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, name", [((None,), "path"), ((5,), "path"), (({"a": 1},), "path"),
                                        ((SCENE, "drive.omega=3"), "overrides"),
                                        ((SCENE, {2: 3}), "key")])
def test_load_refuses_a_wrong_argument(args, name):
    _refused(lambda: api.load(*args), name)


def test_an_argument_error_is_still_a_type_and_value_error():
    """Code written against the built-in errors raised before still catches them."""
    with pytest.raises(TypeError):
        api.simulate(SCENE, progress=5)
    with pytest.raises(ValueError):
        api.simulate(SCENE, tol=-1.0)


def test_a_long_value_is_cut_in_the_message(no_fmus):
    error = _refused(lambda: api.simulate(SCENE, overrides={"friction.regime": "x" * 990_000}),
                     "friction.regime", TriboFMUError)
    assert "990002 characters" in str(error)
    window = _refused(lambda: api.load(SCENE, {"time.window": list(range(200_000))}), "time.window",
                      TriboFMUError)
    assert len(str(window)) <= MAX_MESSAGE


def test_max_wall_defaults_to_the_scenes_and_takes_none_or_zero_for_no_limit():
    import inspect
    assert inspect.signature(api.simulate).parameters["max_wall"].default == api.SCENE_MAX_WALL
    for value in (None, 0.0, 1.0, 1800):
        api_arguments.check_run_arguments("simulate", SCENE, None, None, None, None, None, value)


def test_the_library_checks_a_run_without_the_cli():
    """Issue 37: api.simulate's checks of a scene live in the scene (tribofmu.scene.checks);
    refusing an unresolvable drive imports no CLI module."""
    import subprocess
    import sys
    code = ("import sys\nfrom tribofmu import api\nfrom tribofmu.errors import UsageError\n"
            "try:\n    api.simulate('fig2_dry', {'drive.omega': 1e12}, fmu_dir='none', build=False)\n"
            "except UsageError as exc:\n    print(exc)\n"
            "print(sorted(m for m in sys.modules if m.startswith('tribofmu.cli')))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "drive.omega" in lines[0] and lines[-1] == "[]", done.stdout
