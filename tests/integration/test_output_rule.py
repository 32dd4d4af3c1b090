"""Issue 39: one output rule for every command. ``--out`` is new, empty, or a folder this
command made (its marker, ``.tribofmu-output``, or its own files: a result set's stats.json
with provenance, a build's FMUs); anything else, and a symbolic link, is
refused with one line before any work, and nothing of the user's is replaced or written
through. Before: ``plot --out U`` replaced the user's ``U/time.png``, ``sweep --out U``
wrote among the user's files and replaced their ``sweep.json``, and plot, sweep, figures
and build wrote into a linked folder's target. ``export-ssp`` over a zip bomb read 6 GB."""
from __future__ import annotations

import json
import time
import tracemalloc
import zipfile
from pathlib import Path

import pytest

from cli_run import main
from scenes import FIG2

USER = b"the user's own bytes"


@pytest.fixture(scope="module")
def result_dir(tmp_path_factory, fmu_dir):
    """A simulate result set (a short run)."""
    import subprocess
    import sys
    out = tmp_path_factory.mktemp("result") / "fig2"
    done = subprocess.run([sys.executable, "-m", "tribofmu", "simulate", str(FIG2), "--fmu-dir", str(fmu_dir),
                           "--out", str(out), "--no-plots", "-q", "--set", "time.periods=1",
                           "--set", "time.window=[0, 1]"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return out


def commands(kind: str, out: Path, result_dir: Path, fmu_dir: Path) -> list[str]:
    return {"plot": ["plot", result_dir, "--out", out],
            "sweep": ["sweep", FIG2, "--grid", "drive.omega=30", "--workers", "0", "--fmu-dir", fmu_dir,
                      "--no-plots", "-q", "--out", out],
            "figures": ["figures", "--only", "fig2", "--fmu-dir", fmu_dir, "-q", "--out", out],
            "build": ["build", "--out", out],
            "simulate": ["simulate", FIG2, "--fmu-dir", fmu_dir, "--no-plots", "-q", "--out", out]}[kind]


def refused(done, *words) -> None:
    err = done.stderr.strip()
    assert done.returncode == 2 and len(err.splitlines()) == 1, err
    assert all(w in err for w in words), err


# the files a user may keep, each named as a file the command writes
USERS_FILES = {"plot": "time.png", "sweep": "sweep.json", "figures": "fig2.png", "build": "Friction.fmu",
               "simulate": "time.png"}


@pytest.mark.parametrize("kind", list(USERS_FILES))
def test_a_users_folder_is_refused_and_left_alone(tmp_path, capsys, result_dir, fmu_dir, kind):
    out = tmp_path / "mine"
    out.mkdir()
    (out / USERS_FILES[kind]).write_bytes(USER)
    began = time.perf_counter()
    done = main(*commands(kind, out, result_dir, fmu_dir), capsys=capsys)
    refused(done, str(out), USERS_FILES[kind])
    assert time.perf_counter() - began < 5.0  # refused before any work
    assert sorted(p.name for p in out.iterdir()) == [USERS_FILES[kind]]
    assert (out / USERS_FILES[kind]).read_bytes() == USER


@pytest.mark.parametrize("kind", list(USERS_FILES))
def test_a_linked_out_is_refused_and_its_target_left_alone(tmp_path, capsys, result_dir, fmu_dir, kind):
    target = tmp_path / "elsewhere"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target)
    done = main(*commands(kind, link, result_dir, fmu_dir), capsys=capsys)
    refused(done, "symbolic link")
    assert list(target.iterdir()) == [] and link.is_symlink()


def test_plot_into_a_folder_it_made_or_the_result_set_is_allowed(tmp_path, capsys, result_dir):
    out = tmp_path / "plots"
    for _ in range(2):  # new, then its own
        done = main("plot", result_dir, "--out", out, capsys=capsys)
        assert done.returncode == 0, done.stderr
    assert (out / "time.png").is_file() and (out / ".tribofmu-output").is_file()
    done = main("plot", result_dir, capsys=capsys)  # into the result set itself (simulate made it)
    assert done.returncode == 0, done.stderr


def test_a_sweep_resumes_in_its_own_folder_and_in_one_of_an_earlier_version(tmp_path, capsys, fmu_dir):
    out = tmp_path / "sweep"
    args = ["sweep", FIG2, "--grid", "drive.omega=30", "--workers", "0", "--fmu-dir", fmu_dir, "--no-plots",
            "-q", "--set", "time.periods=1", "--set", "time.window=[0, 1]", "--out", out]
    assert main(*args, capsys=capsys).returncode == 0
    marker = json.loads((out / ".tribofmu-output").read_text())
    assert marker["command"] == "sweep"
    (out / ".tribofmu-output").unlink()  # as an earlier version left it: its sweep.json says it is ours
    done = main(*args, capsys=capsys)
    assert done.returncode == 0 and "1 already done" in done.stdout, done.stdout + done.stderr


def test_simulate_keeps_replacing_its_own_result_set(tmp_path, capsys, fmu_dir):
    out = tmp_path / "run"
    args = ["simulate", FIG2, "--fmu-dir", fmu_dir, "--no-plots", "-q", "--set", "time.periods=1",
            "--set", "time.window=[0, 1]", "--out", out]
    for _ in range(2):
        done = main(*args, capsys=capsys)
        assert done.returncode == 0, done.stderr
    assert "provenance" in json.loads((out / "stats.json").read_text())  # what shows the set is ours
    assert not (out / ".tribofmu-output").exists()  # a result set carries no marker


def test_a_folder_of_our_fmus_is_builds_own_and_one_more_file_makes_it_the_users(tmp_path, fmu_dir):
    import shutil

    from tribofmu.atomic import check_output_folder
    out = tmp_path / "fmus"
    shutil.copytree(fmu_dir, out)
    check_output_folder(out, ("build",))
    (out / "Friction.fmu").write_bytes(USER)  # a file of the user's, named as ours
    with pytest.raises(FileExistsError, match="did not write"):
        check_output_folder(out, ("build",))


def zip_bomb(path: Path, inflated_mb: int) -> Path:
    """An archive whose SystemStructure.ssd inflates to ``inflated_mb`` MB of zeros."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("SystemStructure.ssd", "w", force_zip64=True) as ssd:
            block = b"\0" * 1_000_000
            for _ in range(inflated_mb):
                ssd.write(block)
    return path


def test_reading_an_archive_to_replace_is_bounded(tmp_path, capsys):
    """export-ssp --out F.ssp over a zip bomb: one line within a second, reading at most ~1 MB
    of it (the issue's 6.5 MB archive inflated to 6 GB: 66 s, 12 GB and a traceback)."""
    from tribofmu.scene.ssp import check_replaceable_archive
    bomb = zip_bomb(tmp_path / "bomb.ssp", 300)
    size = bomb.stat().st_size
    tracemalloc.start()
    began = time.perf_counter()
    with pytest.raises(FileExistsError, match="not an archive written by tribofmu"):
        check_replaceable_archive(bomb)
    elapsed = time.perf_counter() - began
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert elapsed < 1.0 and peak < 20_000_000, (elapsed, peak)
    done = main("export-ssp", FIG2, "--out", bomb, capsys=capsys)
    refused(done, "not an archive written by tribofmu")
    assert bomb.stat().st_size == size
