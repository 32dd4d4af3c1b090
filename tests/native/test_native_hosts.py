"""Issue 19: the FMUs in native hosts, i.e. C programs with no Python in the process.

Three C programs, compiled here with the system compiler, run in a clean environment (only
``PATH=/usr/bin:/bin``: no virtual environment, no PYTHONPATH, no LD_PRELOAD), so each FMU
must find a Python by itself (tribofmu/native/loader_common.h):

- ``fmi2_host.c``: a minimal FMI 2.0 co-simulation host (dlopen + the FMI C functions, fixed
  steps, Jacobi exchange) runs Drive + TriboPair against the monolithic reference, and
  Friction alone under a prescribed dv against the physics module;
- ``cosim_host.c``: libcosim's C API (libcosimc, from the libcosimpy wheel) runs exported
  SSP archives: the three-FMU Fig. 2 scene, its pair archive, the heating scene;
- ``fmi2_misuse.c``: calls that crashed the host inside pythonfmu's binary now answer
  fmi2Error (or are ignored, for a second fmi2FreeInstance) and the process ends normally.
"""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from native_support import STEP, run_clean, table, vr
from scenes import MIXED_POINTS, MIXED_SHORT

pytestmark = [pytest.mark.integration, pytest.mark.native]

FMI_ERROR = 3


# -- the FMU binary -----------------------------------------------------------------------
def test_fmu_binary_is_the_loader_and_carries_pythonfmus_beside_it(unzipped):
    folder, _ = unzipped("Drive")
    binaries = folder / "binaries" / "linux64"
    assert sorted(p.name for p in binaries.iterdir()) == ["Drive.so", "libpythonfmu-export.so"]
    needed = subprocess.run(["readelf", "-d", str(binaries / "Drive.so")], capture_output=True, text=True).stdout
    assert "libpython" not in needed  # found at run time, not a load-time dependency


# -- (b) our own C host -------------------------------------------------------------------
def pair_run(programs, unzipped, scenario) -> tuple[np.ndarray, np.ndarray]:
    """Drive + TriboPair in the C host for the scenario's span at STEP; (t, v)."""
    from tribofmu.scene.wiring import PAIR

    drive_dir, drive = unzipped("Drive")
    pair_dir, pair = unzipped("TriboPair")
    n = int(math.ceil(scenario.stop_time / STEP - 1e-9))
    command = [programs["fmi2_host"], "-h", repr(STEP), "-n", n,
               "-f", drive_dir, "Drive", drive.get("guid"), "-f", pair_dir, "TriboPair", pair.get("guid")]
    for name, value in (("A", scenario.drive.A), ("omega", scenario.drive.omega)):
        command += ["-s", 0, vr(drive, name), repr(float(value))]
    law = scenario.friction.law()
    command += ["-i", 1, vr(pair, "regime"), law.code]
    values = {**PAIR.start_values(scenario), **PAIR.constant_inputs(scenario)}
    for name in ("M", "K", "n", *sorted(law.keys)):
        command += ["-s", 1, vr(pair, name), repr(float(values[name]))]
    command += ["-c", 0, vr(drive, "V"), 1, vr(pair, "V"), "-c", 0, vr(drive, "a"), 1, vr(pair, "a_drive"),
                "-o", 1, vr(pair, "v")]
    done = run_clean(command)
    assert done.returncode == 0, done.stderr[-2000:]
    out = table(done.stdout)
    assert len(out) == n + 1
    return out[:, 0], out[:, 1]


@pytest.mark.parametrize("name, overrides", [
    ("fig2_dry", {}),  # Fig. 2 itself, the target
    # a parameter point no scene uses: other drive, mass, stiffness, friction and load
    ("fig2_dry", {"drive.omega": 26.0, "drive.A": 1.7e-3, "block.M": 0.45, "block.K": 5200.0,
                  "friction.mu_friction": 0.37, "conditions.n": -13.0, "time.periods": 3.5,
                  "time.window": [2.0, 3.5]}),
    # mixed (Stribeck) friction at the points no scene uses of its fmpy and pair tests
    *[("mixed_stribeck", {**point, **MIXED_SHORT}) for point in MIXED_POINTS.values()],
], ids=["fig2", "off-scene", *(f"mixed-{p}" for p in MIXED_POINTS)])
def test_c_host_runs_drive_and_pair_like_the_reference(programs, unzipped, name, overrides):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.reference import nrms, reference_solution

    from scenes import scene
    scenario = load_scenario(scene(name), overrides)
    t, v = pair_run(programs, unzipped, scenario)
    t0, t1 = scenario.window
    inside = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    reference = np.asarray(reference_solution(scenario, t[inside]).v)
    error = nrms(t, v, t[inside], reference, scenario.window)
    print(f"\nC host, Drive + TriboPair, {name} {overrides}: nRMS(v) = {error:.2e}")
    assert error <= 1e-3


@pytest.mark.parametrize("regime", [1, 2, 3], ids=["fluid", "boundary", "mixed"])
def test_c_host_runs_friction_alone_like_the_physics_module(programs, unzipped, tmp_path, regime):
    """Friction under a prescribed dv(t) at parameters no scene uses: F and f after each step
    are what the physics module computes with the same steps (same inputs, same solver)."""
    from tribofmu.physics import make_law

    folder, description = unzipped("Friction")
    h, n = STEP, 1500
    dv = 0.04 * np.sin(37.0 * h * np.arange(n)) + 0.003
    dv_file = tmp_path / "dv.txt"
    dv_file.write_text("\n".join(repr(float(x)) for x in dv) + "\n")
    params = dict(m=31.0, gamma=-0.3, S=0.8, mu_friction=0.41, f0=0.15, kinetics_tol=1e-7,
                  mu_static=0.57, v_stribeck=0.013, stribeck_exponent=1.6)
    normal, temperature = -17.0, 305.0
    command = [programs["fmi2_host"], "-h", repr(h), "-n", n, "-f", folder, "Friction", description.get("guid"),
               "-i", 0, vr(description, "regime"), regime]
    for name, value in {**params, "n": normal, "T": temperature}.items():
        command += ["-s", 0, vr(description, name), repr(value)]
    command += ["-u", 0, vr(description, "dv"), dv_file, "-o", 0, vr(description, "F"), "-o", 0, vr(description, "f")]
    done = run_clean(command)
    assert done.returncode == 0, done.stderr[-2000:]
    out = table(done.stdout)

    law = make_law(regime, **params)
    f = params["f0"]  # the FMU starts every regime at f0 (only boundary friction moves it)
    F_expected, f_expected = [law.force(0.0, normal, f)], [f]
    previous = None
    for k in range(n):
        if law.has_state:
            f = law.advance_f(f, dv[k], normal, temperature, h, rtol=params["kinetics_tol"],
                              atol=params["kinetics_tol"], dv_start=previous)
        previous = dv[k]
        F_expected.append(law.force(dv[k], normal, f))
        f_expected.append(f)
    F_scale = np.max(np.abs(F_expected))
    assert F_scale > 0.0 and np.all(np.isfinite(out[:, 1]))
    np.testing.assert_allclose(out[:, 1], F_expected, rtol=0, atol=1e-12 * F_scale)
    np.testing.assert_allclose(out[:, 2], f_expected, rtol=0, atol=1e-12)
    if law.has_state:  # the lubricant melts and solidifies: f is not stuck at its start
        assert np.ptp(out[:, 2]) > 1e-3


# -- finding Python -----------------------------------------------------------------------
def test_no_python_found_fails_instantiation_with_a_message(programs, unzipped, tmp_path):
    folder, description = unzipped("Drive")
    command = [programs["fmi2_host"], "-h", "1e-4", "-n", 1, "-f", folder, "Drive", description.get("guid")]
    missing = tmp_path / "no" / "libpython3.so"
    done = run_clean(command, {"TRIBOFMU_LIBPYTHON": str(missing)})
    assert done.returncode == 3  # fmi2Instantiate returned NULL
    assert "no Python interpreter for this FMU" in done.stderr
    assert str(missing) in done.stderr and "TRIBOFMU_LIBPYTHON" in done.stderr
    # a library that is no Python at all is named as such
    done = run_clean(command, {"TRIBOFMU_LIBPYTHON": "libm.so.6"})
    assert done.returncode == 3 and "libm.so.6 is not a libpython" in done.stderr


def test_named_libpython_is_used(programs, unzipped):
    """TRIBOFMU_LIBPYTHON pointing at the building interpreter's library runs the FMU."""
    from tribofmu.build import recorded_python

    library = recorded_python()["libpython"]
    if not library:
        pytest.skip("the building Python has no shared libpython")
    folder, description = unzipped("Drive")
    done = run_clean([programs["fmi2_host"], "-h", "1e-3", "-n", 3, "-f", folder, "Drive", description.get("guid"),
                      "-s", 0, vr(description, "A"), "0.003", "-s", 0, vr(description, "omega"), "11",
                      "-o", 0, vr(description, "X")], {"TRIBOFMU_LIBPYTHON": library})
    assert done.returncode == 0, done.stderr
    t, X = table(done.stdout).T
    np.testing.assert_allclose(X, 0.003 * np.cos(11.0 * t), rtol=1e-12, atol=1e-15)


# -- misuse that crashed the host ---------------------------------------------------------
def misuse(programs, unzipped, scenario: str, fmu=None) -> list[tuple[str, int]]:
    folder, description = fmu or unzipped("Drive")
    model = description.get("modelName")
    done = run_clean([programs["fmi2_misuse"], folder, model, description.get("guid"), scenario])
    assert done.returncode == 0, f"host ended with {done.returncode}: {done.stderr[-2000:]}"
    calls = [line.split() for line in done.stdout.splitlines() if not line.endswith("done")]
    return [(call, int(status)) for call, status in calls[3:]], done  # after start-up's three OKs


def test_unknown_value_references_are_errors_in_our_fmus(programs, unzipped):
    calls, done = misuse(programs, unzipped, "after-fatal")
    assert calls[:5] == [("fmi2GetReal", FMI_ERROR)] * 5  # refused with a log message, no Fatal
    assert done.stdout.rstrip().endswith("fmi2FreeInstance done")


def test_calls_after_fatal_are_errors_not_crashes(programs, unzipped, gate):
    """A plain pythonfmu FMU behind the loader: its Fatal (an unknown value reference) no
    longer leaves the host calling into a freed Python instance."""
    calls, done = misuse(programs, unzipped, "after-fatal", fmu=gate)
    assert calls[0] == ("fmi2GetReal", 4)  # unknown value reference: pythonfmu's Fatal
    assert calls[1:] == [("fmi2GetReal", FMI_ERROR)] * 5 + [("fmi2DoStep", FMI_ERROR)]
    assert "allows only fmi2FreeInstance" in done.stderr
    assert done.stdout.rstrip().endswith("fmi2FreeInstance done")


def test_second_free_instance_is_ignored(programs, unzipped):
    _, done = misuse(programs, unzipped, "double-free")
    assert done.stdout.count("fmi2FreeInstance done") == 2
    assert "already freed instance" in done.stderr


def test_freed_state_is_refused(programs, unzipped):
    calls, done = misuse(programs, unzipped, "freed-state")
    assert calls == [("fmi2GetFMUstate", 0), ("fmi2DoStep", 0), ("fmi2SetFMUstate", 0), ("fmi2FreeFMUstate", 0),
                     ("fmi2SetFMUstate", FMI_ERROR), ("fmi2FreeFMUstate", FMI_ERROR),
                     ("fmi2SerializedFMUstateSize", FMI_ERROR), ("fmi2DoStep", 0)]
    assert "is not an FMU state of this FMU" in done.stderr


def test_pointer_that_is_no_state_is_refused(programs, unzipped):
    calls, _ = misuse(programs, unzipped, "foreign-state")
    assert calls == [("fmi2SetFMUstate", FMI_ERROR), ("fmi2DoStep", 0)]


def test_pointer_that_is_no_instance_is_refused(programs, unzipped):
    calls, done = misuse(programs, unzipped, "unknown-instance")
    assert calls == [("fmi2GetReal", FMI_ERROR), ("fmi2DoStep", FMI_ERROR), ("fmi2GetReal", FMI_ERROR)]
    assert "unknown or already freed instance" in done.stderr


# -- (a) libcosim's C API -----------------------------------------------------------------
def cosim_run(cosim_host, archive: Path, n: int, variables: list[str]) -> np.ndarray:
    done = run_clean([cosim_host, archive, round(STEP * 1e9), n, *variables])
    assert done.returncode == 0, done.stderr[-2000:]
    out = table(done.stdout)
    assert out.shape == (n, 1 + len(variables)) and np.all(np.isfinite(out))
    np.testing.assert_allclose(out[:, 0], STEP * np.arange(1, n + 1), rtol=1e-12)
    return out


@pytest.mark.parametrize("pair", [False, True], ids=["three-fmus", "pair"])
def test_libcosim_c_api_runs_the_fig2_archives(cosim_host, fmu_dir, tmp_path, pair):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.scene.ssp import export_ssp
    from tribofmu.studies.reference import nrms, reference_solution

    from scenes import scene
    scenario = load_scenario(scene("fig2_dry"))
    archive = export_ssp(scenario, tmp_path / "fig2.ssp", fmu_dir, pair=pair)
    n = int(math.ceil(scenario.stop_time / STEP - 1e-9))
    variable = "TriboPair.v" if pair else "BlockSpring.v"
    out = cosim_run(cosim_host, archive, n, [variable])
    t, v = out[:, 0], out[:, 1]
    t0, t1 = scenario.window
    inside = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    error = nrms(t, v, t[inside], np.asarray(reference_solution(scenario, t[inside]).v), scenario.window)
    print(f"\nlibcosim C API, fig2_dry {'pair' if pair else 'three FMUs'}: nRMS(v) = {error:.2e}")
    # the pair closes the stick inside itself; three FMUs exchanged explicitly chatter at
    # stick (tests/external/test_ssp.py measures the same in libcosimpy, fmpy and Ecos)
    assert error <= (1e-3 if pair else 0.25)


OLD_HEATING = {"thermal.C": 8e-12, "thermal.G": 1e-11, "friction.phi0_star": 5.0, "friction.alpha": 0.45}


def test_libcosim_c_api_runs_the_heating_archive(cosim_host, fmu_dir, tmp_path):
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.scene.ssp import export_ssp
    from tribofmu.studies.reference import reference_solution

    from scenes import scene
    # the scene as its bound below was measured on (the paper's lubricant, whose T term is
    # 5x weaker, and the film's own heat capacity alone): the explicit exchange's error grows
    # with the friction's pull on T (16.6 % of the rise with the shipped lubricant, C = 8e-12)
    scenario = load_scenario(scene("boundary_heating"), {"time.periods": 0.5, "time.window": [0.0, 0.5],
                                                        **OLD_HEATING})
    archive = export_ssp(scenario, tmp_path / "heating.ssp", fmu_dir)
    n = int(math.ceil(scenario.stop_time / STEP - 1e-9))
    out = cosim_run(cosim_host, archive, n, ["BlockSpring.v", "Thermal.T"])
    t, T = out[:, 0], out[:, 2]
    ref = reference_solution(scenario, t_eval=t, rtol=1e-8)
    rise = ref.T[-1] - ref.T[0]
    error = float(np.max(np.abs(T - ref.T)) / rise)
    print(f"\nlibcosim C API, boundary_heating 0.5 periods: max |T - T_ref| / rise = {error:.2e}")
    assert rise > 100.0 and error < 0.15  # the bound of tests/external/test_ssp.py
