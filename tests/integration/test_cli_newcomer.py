"""A newcomer's first hour: the CLI from any folder, provenance, no silent overwrites, options
that do not apply, clean interruption, FMUs and package in one process, no leftovers."""
import dataclasses
import hashlib
import json
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from tribofmu import api, cli
from tribofmu.build import PRIVATE_PREFIX, private_package_name
from tribofmu.master.fmu_files import EXTRACT_PREFIX

from cli_run import command, main, tribofmu
from scenes import SCENARIOS
SCENES = SCENARIOS
FIG2 = SCENES / "fig2_dry.toml"
SHORT = ["--set", "time.periods=1", "--set", "time.window=[0,1]"]  # one period: a quick run
pytestmark = pytest.mark.integration


def one_line(proc) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    return lines[0]


# -- from any folder the command finds (or builds once) the FMUs of the installed source, so a
# newcomer never names an FMU folder; options that cannot apply are refused, not ignored -------
def test_version_and_python_m(tmp_path, env):
    from tribofmu import __version__
    proc = tribofmu("--version", cwd=tmp_path, env=env)
    assert proc.returncode == 0 and proc.stdout.strip() == f"tribofmu {__version__}"


def test_simulate_and_export_ssp_from_another_folder_build_missing_fmus(tmp_path, env):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    proc = tribofmu("simulate", FIG2, *SHORT, "--no-plots", cwd=elsewhere, env=env)
    assert proc.returncode == 0, proc.stderr
    cache = Path(env["TRIBOFMU_CACHE"]) / "fmus"
    (built,) = list(cache.iterdir())
    assert sorted(p.name for p in built.glob("*.fmu")) == ["BlockSpring.fmu", "Drive.fmu", "Friction.fmu"]
    (run_dir,) = list((elsewhere / "out").iterdir())
    assert (run_dir / "result.csv").is_file()
    proc = tribofmu("export-ssp", SCENES / "fig5_newtonian.toml", "--out", "n.ssp", cwd=elsewhere, env=env)
    assert proc.returncode == 0, proc.stderr
    assert "resources/Friction.fmu" in zipfile.ZipFile(elsewhere / "n.ssp").namelist()
    assert list(cache.iterdir()) == [built]  # found, not rebuilt elsewhere


def fresh_account(tmp_path, env, **extra):
    """A new account's environment: an empty HOME (no ~/.cache), no XDG variables, no
    TRIBOFMU_CACHE (unless given in extra)."""
    home = tmp_path / "home"
    home.mkdir(parents=True)
    fresh = {k: v for k, v in env.items() if k != "TRIBOFMU_CACHE" and not k.startswith("XDG_")}
    return home, dict(fresh, HOME=str(home), **extra)


def test_a_fresh_account_without_a_cache_folder_simulates_and_builds(tmp_path, env):
    home, fresh = fresh_account(tmp_path, env)
    proc = tribofmu("simulate", "fig2_dry", *SHORT, "--no-plots", "-q", cwd=tmp_path, env=fresh)
    assert proc.returncode == 0, proc.stderr
    assert len(list((tmp_path / "out").glob("*/result.csv"))) == 1
    for made in (home / ".cache", home / ".cache" / "tribofmu"):  # made private, as XDG asks
        assert made.is_dir() and (made.stat().st_mode & 0o077) == 0, made
    # a TRIBOFMU_CACHE under folders not made yet: build and export-ssp make them too
    _, under = fresh_account(tmp_path / "b", env, TRIBOFMU_CACHE=str(tmp_path / "new" / "deep" / "cache"))
    assert tribofmu("build", cwd=tmp_path, env=under).returncode == 0
    proc = tribofmu("export-ssp", "fig2_dry", "--out", tmp_path / "a.ssp", cwd=tmp_path, env=under)
    assert proc.returncode == 0 and (tmp_path / "a.ssp").is_file(), proc.stderr


def test_a_cache_that_cannot_be_made_is_one_line_exit_1_and_leaves_nothing(tmp_path, env):
    blocker = tmp_path / "afile"
    blocker.write_text("not a folder")
    _, fresh = fresh_account(tmp_path, env, TRIBOFMU_CACHE=str(blocker / "cache"))
    proc = tribofmu("simulate", "fig2_dry", *SHORT, cwd=tmp_path, env=fresh)
    assert proc.returncode == 1 and "cannot write the FMU cache" in one_line(proc)
    assert not (tmp_path / "out").exists()  # no empty output folder left behind


@pytest.mark.parametrize("args, message", [
    (["--algorithm", "jacobi", "--tol", "1e-5"], "--tol applies to the adaptive algorithm only, not jacobi"),
    (["--algorithm", "implicit", "--tol", "1e-3"], "--tol applies to the adaptive algorithm only, not implicit"),
    (["--tol", "0"], "--tol must be > 0"),
])
def test_options_that_do_not_apply_are_one_line_exit_2(tmp_path, fmu_dir, args, message, capsys):
    out = tmp_path / "o"
    proc = main("simulate", FIG2, "--fmu-dir", fmu_dir, "--out", out, *args, capsys=capsys)
    assert proc.returncode == 2 and message in one_line(proc)
    assert not out.exists()


def test_sweep_without_dask_names_the_package(tmp_path, env):
    block = ("import sys, importlib.abc\n"
             "class Block(importlib.abc.MetaPathFinder):\n"
             "    def find_spec(self, name, path=None, target=None):\n"
             "        if name.split('.')[0] == 'distributed': raise ModuleNotFoundError(name)\n"
             "sys.meta_path.insert(0, Block())\n"
             "from tribofmu.cli import main\n"
             f"sys.exit(main(['sweep', {str(FIG2)!r}, '--grid', 'drive.omega=20,30', '--out', 'sw']))\n")
    proc = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2
    assert "python -m pip install 'dask[distributed]'" in one_line(proc)
    assert not (tmp_path / "sw").exists()


# -- a run says what ran (scene, overrides, versions, FMUs) and never overwrites another run's folder
def test_default_out_dirs_differ_by_overrides_and_stats_say_what_ran(tmp_path, fmu_dir, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    first = main("simulate", FIG2, "--fmu-dir", fmu_dir, *SHORT, "--no-plots", capsys=capsys)
    second = main("simulate", FIG2, "--fmu-dir", fmu_dir, *SHORT, "--set", "drive.omega=80",
                  "--algorithm", "implicit", "--step", "2e-4", "--no-plots", capsys=capsys)
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    runs = sorted((tmp_path / "out").iterdir())
    assert len(runs) == 2 and all(p.name.startswith("fig2_dry--") for p in runs)
    by_omega = {}
    for run in runs:
        stats = json.loads((run / "stats.json").read_text())
        by_omega[stats["provenance"]["overrides"].get("drive.omega")] = stats
    stats = by_omega["80"]
    prov = stats["provenance"]
    assert prov["scene"] == {"file": str(FIG2), "sha256": hashlib.sha256(FIG2.read_bytes()).hexdigest()}
    assert prov["overrides"] == {"time.periods": "1", "time.window": "[0,1]", "drive.omega": "80"}
    assert prov["settings"]["algorithm"] == "implicit" and prov["settings"]["step"] == pytest.approx(2e-4)
    assert set(prov["versions"]) >= {"tribofmu", "fmpy", "pythonfmu", "python"}
    import fmpy
    for name in ("Drive", "BlockSpring", "Friction"):
        guid = fmpy.read_model_description(str(fmu_dir / f"{name}.fmu")).guid
        assert prov["fmus"][name]["guid"] == guid
    assert by_omega[None]["provenance"]["settings"]["algorithm"] == "adaptive"


def test_out_naming_a_file_is_refused_before_simulating(tmp_path, capsys):
    target = tmp_path / "existing.txt"
    target.write_text("keep me")
    # a missing --fmu-dir would fail too: the --out check comes first, before any FMU or run
    proc = main("simulate", FIG2, "--out", target, "--fmu-dir", tmp_path / "none", capsys=capsys)
    assert proc.returncode == 2 and f"--out {target}: {target} is a file" in one_line(proc)
    assert target.read_text() == "keep me"
    proc = main("export-ssp", FIG2, "--out", tmp_path, capsys=capsys)
    assert proc.returncode == 2 and "is a folder, not a file" in one_line(proc)


def _short_result(fmu_dir):
    return api.simulate(FIG2, {"time.periods": 1, "time.window": [0, 1]}, fmu_dir=fmu_dir, build=False)


def test_a_failed_run_does_not_leave_older_results_beside_its_stats(tmp_path, fmu_dir, monkeypatch, capsys):
    out = tmp_path / "run"
    argv = ["simulate", FIG2, "--out", out, "--fmu-dir", fmu_dir, "-q", *SHORT]
    assert main(*argv, capsys=capsys).returncode == 0
    assert {p.name for p in out.iterdir()} == {"stats.json", "result.csv", "columns.json", "time.png", "phase.png",
                                               "friction.png"}
    good = _short_result(fmu_dir)
    failed = dataclasses.replace(good, ok=False, message="stopped at t = 0.1 s: friction: fmi2DoStep")
    failed.stats = dict(good.stats, ok=False, completed=False, message=failed.message)
    monkeypatch.setattr(api, "simulate", lambda *a, **k: failed)
    assert main(*argv, capsys=capsys).returncode == cli.EXIT_FAILED
    assert {p.name for p in out.iterdir()} == {"stats.json"}
    assert json.loads((out / "stats.json").read_text())["message"] == failed.message


def test_ctrl_c_leaves_the_previous_results_untouched(tmp_path, fmu_dir, monkeypatch, capsys):
    out = tmp_path / "run"
    argv = ["simulate", FIG2, "--out", out, "--fmu-dir", fmu_dir, "-q", "--no-plots", *SHORT]
    assert main(*argv, capsys=capsys).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(api, "simulate", interrupted)
    stopped = main(*argv, capsys=capsys)
    assert stopped.returncode == 130 and "interrupted; no result was written" in stopped.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


# -- a killed run leaves no half result and nothing in the temp folder ----------------------------
def test_killed_run_writes_nothing_and_removes_its_extracted_fmus(tmp_path, env, fmu_dir):
    tmp = Path(env["TMPDIR"])
    orphan = tmp / f"{EXTRACT_PREFIX}999999999-dead"  # left by a process that no longer exists
    orphan.mkdir()
    out = tmp_path / "long"
    proc = subprocess.Popen(command("simulate", SCENES / "fig5_pseudoplastic.toml", "--fmu-dir", fmu_dir,
                                    "--out", out, "--set", "time.periods=400"),
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    def extracted() -> list:
        # (the run unzips into folders it renames as it goes: a walk that meets one mid-rename
        # is taken again, not failed)
        try:
            return list(tmp.rglob(f"{EXTRACT_PREFIX}{proc.pid}-*"))
        except FileNotFoundError:
            return []

    deadline, found = time.monotonic() + 120, []
    while not found and time.monotonic() < deadline:
        found = extracted()
        time.sleep(0.05)
    assert found, "the run never unzipped its FMUs"
    assert not orphan.exists()  # reaped by the new process
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "tribofmu: interrupted; no result was written (earlier results are as they were)"
    assert not out.exists() or not any(out.iterdir())
    assert list(tmp.iterdir()) == []


def test_instances_of_one_fmu_share_one_extraction_removed_at_exit(tmp_path, env, fmu_dir):
    code = ("import sys, tempfile\nfrom pathlib import Path\nfrom tribofmu.master.instance import FMUInstance\n"
            f"fmu = Path({str(fmu_dir)!r}) / 'Drive.fmu'\n"
            "a, b = FMUInstance(fmu, 'a'), FMUInstance(fmu, 'b')\n"
            "assert a._unzipped == b._unzipped\n"
            "a.close(); b.close()\n"
            "print(len(list(Path(tempfile.gettempdir()).iterdir())))\n")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "1"  # one folder while running
    assert list(Path(env["TMPDIR"]).iterdir()) == []  # none after exit


# -- the FMUs' private copy of the physics never shadows the installed package in one process ----
def test_fmu_loaded_in_process_does_not_shadow_the_package(tmp_path, env, fmu_dir):
    code = ("import sys, fmpy\n"
            f"r = fmpy.simulate_fmu({str(fmu_dir / 'Drive.fmu')!r}, stop_time=0.01, step_size=1e-3,\n"
            "                      start_values={'A': 1e-3, 'omega': 20.0})\n"
            "assert abs(r['X'][-1] - 1e-3 * __import__('math').cos(0.2)) < 1e-12\n"
            "import tribofmu.api as api\n"
            "assert 'resources' not in api.__file__\n"
            f"res = api.simulate({str(FIG2)!r}, {{'time.periods': 1, 'time.window': [0, 1]}},\n"
            f"                   fmu_dir={str(fmu_dir)!r}, build=False)\n"
            "assert res.ok, res.message\n"
            "print(sorted({m.split('.')[0] for m in sys.modules if 'tribofmu' in m}))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    private = private_package_name()
    assert proc.stdout.strip() == str(sorted([private, f"{private}_Drive", f"{private}_BlockSpring",
                                              f"{private}_Friction", "tribofmu"]))


def test_built_fmus_never_import_the_name_tribofmu(fmu_dir):
    for name in ("Drive", "BlockSpring", "Friction"):
        with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as zf:
            names = zf.namelist()
            assert not [n for n in names if n.startswith("resources/tribofmu/")]
            module = zf.read("resources/slavemodule.txt").decode().strip()
            assert module.startswith(PRIVATE_PREFIX) and module.endswith(f"_{name}")
            for source in [n for n in names if n.endswith(".py") and "/pythonfmu/" not in n]:
                for line in zf.read(source).decode().splitlines():
                    words = line.split()
                    if words[:1] in (["import"], ["from"]):
                        assert words[1].split(".")[0] != "tribofmu", (source, line)


# -- stick is what the coupling held, not a threshold on |V - v| (creeping slip is no stick) ------
def test_stick_fraction_comes_from_the_coupling_state(fmu_dir):
    from tribofmu import metrics
    result = api.simulate(SCENES / "fig4_dry_w130.toml", fmu_dir=fmu_dir, build=False)
    m = result.window_mask()
    got = metrics.result_metrics(result)
    threshold = metrics.stick_fraction(result.time[m], result.V[m], result.v[m])
    assert got["stick_fraction"] == pytest.approx(0.91, abs=0.02)
    assert threshold == pytest.approx(0.958, abs=0.01)  # creeping slip counted as stick
    assert got["stick_episodes_per_period"] == 1


def test_boundary_friction_is_never_stuck_and_says_so_through_melting(fmu_dir):
    from tribofmu import metrics
    result = api.simulate(SCENES / "fig6_boundary.toml", {"time.periods": 1.5, "time.window": [0.5, 1.5],
                                                          "drive.omega": 35.0},
                          algorithm="implicit", step=2e-4, fmu_dir=fmu_dir, build=False)
    assert result.ok, result.message
    got = metrics.result_metrics(result)
    assert got["stick_fraction"] == 0 and got["stick_episodes_per_period"] == 0
    assert 0 < got["melt_fraction"] < 1


