"""Hostile and broken input: one line naming the culprit, exit 2, within a second, nothing
written, so that a mistake costs neither a traceback nor a half-written folder.

The corpus below is the fuzz corpus: each case a scenario file (bytes), or a special file,
and the words its one-line message must contain.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from cli_run import main
from scenes import FIG2

BASE = FIG2.read_text(encoding="utf-8")
DEEP_TABLES = "".join("[" + ".".join(["a"] * 200) + f".b{i}]\n" for i in range(1900))  # 774 KB


def with_line(table: str, line: str) -> str:
    return BASE.replace(f"[{table}]\n", f"[{table}]\n{line}\n", 1)


def without(key_line: str) -> str:
    return "\n".join(l for l in BASE.splitlines() if not l.startswith(key_line)) + "\n"


# (id, file content, words of the message)
CORPUS = [
    ("utf16", BASE.encode("utf-16"), ["UTF-16", "UTF-8"]),
    ("utf16-no-bom", BASE.encode("utf-16-le"), ["NUL byte on line 1", "UTF-8"]),
    ("latin1", (BASE + "# café\n").encode("latin-1"), ["not UTF-8", "0xe9", "line"]),
    ("int-400-digits", without("omega").replace("[drive]\n", "[drive]\nomega = " + "9" * 400 + "\n").encode(),
     ["drive.omega", "finite number", "99999"]),
    ("int-5000-digits", ("[drive]\nomega = " + "9" * 5000 + "\n").encode(), ["4300 digits"]),
    ("omega-1e-300", without("omega").replace("[drive]\n", "[drive]\nomega = 1e-300\n").encode(),
     ["drive.omega", "1e-300"]),
    ("step-1e300", with_line("time", "").replace("[time]", "[simulation]\nalgorithm = \"jacobi\"\nstep = 1e300\n\n[time]").encode(),
     ["simulation.step", "1e+300"]),
    ("omega-inf", without("omega").replace("[drive]\n", "[drive]\nomega = inf\n").encode(), ["drive.omega", "inf"]),
    ("mass-nan", without("M =").replace("[block]\n", "[block]\nM = nan\n").encode(), ["block.M", "nan"]),
    ("nesting-100000", ("x = " + "[" * 100_000 + "]" * 100_000 + "\n").encode(), ["nested more than 16"]),
    ("deep-dotted-tables", DEEP_TABLES.encode(), ["nested more than 8 levels"]),
    ("deep-dotted-key", ("a" + ".a" * 50 + " = 1\n").encode(), ["nested more than 8 levels"]),
    ("too-large", (BASE + "#" * 1_100_000 + "\n").encode(), ["at most 1000000 bytes"]),
    ("nul-byte", (BASE + "\0\n").encode(), ["NUL byte on line"]),
    ("not-toml", b"[drive\nomega = 3\n", ["not valid TOML"]),
    ("top-level-value", b"omega = 3\n", ["top-level key 'omega' must be a table"]),
]
# (id, scenario.name, words): names a scenario may have but that must not choose a folder
NAMES = [
    ("dotdot", "../../x", ["scenario.name", "../../x"]),
    ("absolute", "/tmp/x", ["scenario.name", "/tmp/x"]),
    ("separator", "a/b", ["scenario.name"]),
    ("long", "a" * 5000, ["scenario.name", "5000 characters"]),
    ("nul", "a\\u0000b", ["scenario.name", "\\x00"]),
    ("dotdot-alone", "..", ["scenario.name"]),
]


def run(argv, capsys) -> tuple[int, str, float]:
    began = time.perf_counter()
    done = main(*argv, capsys=capsys)
    return done.returncode, done.stderr.strip(), time.perf_counter() - began


@pytest.mark.alone
@pytest.mark.parametrize("content, words", [c[1:] for c in CORPUS], ids=[c[0] for c in CORPUS])
def test_fuzz_corpus_is_one_line_exit_2_within_a_second(tmp_path, capsys, monkeypatch, content, words):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "scene.toml"
    scene.write_bytes(content)
    code, err, elapsed = run(["simulate", str(scene), "-q", "--no-plots"], capsys)
    assert code == 2 and len(err.splitlines()) == 1, err[:500]
    assert all(w in err for w in words), err
    assert elapsed < 1.0, elapsed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]  # nothing written


@pytest.mark.alone
@pytest.mark.parametrize("kind", ["fifo", "dev-zero", "folder"])
def test_only_regular_files_are_read(tmp_path, capsys, kind):
    if kind == "fifo":
        path = tmp_path / "pipe.toml"
        os.mkfifo(path)  # no writer: reading it would wait forever
    else:
        path = Path("/dev/zero") if kind == "dev-zero" else tmp_path
    code, err, elapsed = run(["simulate", str(path), "--out", str(tmp_path / "o"), "-q"], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "regular file" in err, err
    assert elapsed < 1.0


@pytest.mark.parametrize("name, words", [n[1:] for n in NAMES], ids=[n[0] for n in NAMES])
def test_a_scene_name_never_chooses_where_files_go(tmp_path, capsys, monkeypatch, name, words):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "scene.toml"
    scene.write_text(BASE.replace("[scenario]\n", f'[scenario]\nname = "{name}"\n', 1))
    code, err, _ = run(["simulate", str(scene), "-q", "--no-plots"], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]
    # the same through --set
    code, err, _ = run(["simulate", str(FIG2), "--set", "scenario.name=\"../evil\"", "-q"], capsys)
    assert code == 2 and "scenario.name" in err and not (tmp_path.parent / "evil").exists(), err


@pytest.mark.parametrize("args, words", [
    (["--tol", "inf"], ["--tol", "inf"]),
    (["--tol", "nan"], ["--tol", "nan"]),
    (["--algorithm", "jacobi", "--step", "inf"], ["--step", "inf"]),
    (["--max-wall", "inf"], ["--max-wall"]),
    (["--set", "drive.omega=1e-300"], ["drive.omega", "1e-300"]),
    (["--set", "time.periods=1e5"], ["time.periods", "output samples"]),
    # issue 39: a tolerance of 100 % or more accepts any answer (1e300 was "ok", 4.6 % off)
    (["--tol", "1e300"], ["--tol", "< 1", "1e+300"]),
    (["--tol", "1"], ["--tol", "< 1"]),
    (["--tol", "1e-300"], ["--tol", "1e-300"]),
    (["--set", "simulation.tol=5"], ["simulation.tol", "< 1"]),
    # one --set is one value: a second line of TOML was dropped silently
    (["--set", "drive.omega=30\nx=1"], ["--set drive.omega", "not one value"]),
    (["--set", "scenario.title=a\nb"], ["--set scenario.title", "not one value"]),
])
def test_options_out_of_range_are_one_line_exit_2(tmp_path, capsys, monkeypatch, args, words):
    monkeypatch.setenv("TRIBOFMU_CACHE", str(tmp_path / "cache"))  # periods = 1e5: refused before any build
    code, err, elapsed = run(["simulate", str(FIG2), "--out", str(tmp_path / "o"), "-q", *args], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (tmp_path / "o").exists() and not (tmp_path / "cache" / "fmus").exists()


@pytest.mark.parametrize("args, words", [
    (["--set", "friction.regime=" + "x" * 990_000], ["friction.regime", "990002 characters"]),
    (["--set", "time.window=[" + ", ".join(map(str, range(200_000))) + "]"], ["time.window"]),
    (["--set", "t" * 5000 + ".x=1"], ["unknown table"]),
    (["--algorithm", "n" * 100_000], ["unknown algorithm"]),
], ids=["regime-990k", "window-200k", "table-5000", "algorithm-100k"])
def test_an_error_line_cuts_a_long_value(tmp_path, capsys, monkeypatch, args, words):
    """Issue 39: the line echoed the whole value (600-990 kB); now at most 300 characters."""
    monkeypatch.setenv("TRIBOFMU_CACHE", str(tmp_path / "cache"))
    code, err, _ = run(["simulate", str(FIG2), "--out", str(tmp_path / "o"), "-q", *args], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and all(w in err for w in words), err[:400]
    assert len(err) <= 300, len(err)


def test_an_out_folder_with_other_files_is_refused(tmp_path, capsys, fmu_dir):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    code, err, _ = run(["simulate", str(FIG2), "--out", str(out), "--fmu-dir", str(fmu_dir), "-q"], capsys)
    assert code == 2 and "notes.txt" in err and len(err.splitlines()) == 1, err
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MB tmpfs (skipped where this process may not mount one); yields a mounter."""
    import subprocess
    mounted = []

    def mount(options: str) -> Path:
        point = tmp_path / f"disk{len(mounted)}"
        point.mkdir()
        proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(point)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()}")
        mounted.append(point)
        return point
    yield mount
    for point in mounted:
        subprocess.run(["umount", str(point)], capture_output=True)


@pytest.mark.alone
def test_a_read_only_disk_is_one_line_exit_1_before_any_work(capsys, fmu_dir, small_disk):
    disk = small_disk("size=1m,ro")
    code, err, elapsed = run(["simulate", str(FIG2), "--out", str(disk / "run"), "--fmu-dir", str(fmu_dir),
                              "-q"], capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "cannot write" in err and "Read-only" in err, err
    assert elapsed < 1.0


@pytest.mark.alone
def test_a_full_disk_is_one_line_exit_1_before_any_work(capsys, fmu_dir, small_disk):
    disk = small_disk("size=1m")  # fig2's 6.5 periods need about 1.1 MB of CSV and 1 MB of plots
    for command in (["simulate", str(FIG2)], ["sweep", str(FIG2), "--grid", "drive.omega=" + ",".join(
            str(w) for w in range(10, 70))]):
        code, err, elapsed = run([*command, "--out", str(disk / "run"), "--fmu-dir", str(fmu_dir), "-q"], capsys)
        assert code == 1 and len(err.splitlines()) == 1 and "MB free" in err, err
        assert elapsed < 1.0
    code, err, _ = run(["export-ssp", str(FIG2), "--out", str(disk / "scene.ssp"), "--fmu-dir", str(fmu_dir)], capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "MB free" in err, err
    assert not (disk / "scene.ssp").exists()
    assert list(disk.iterdir()) == [] or [p.name for p in disk.iterdir()] == ["run"]


def test_a_cold_cache_on_a_read_only_disk_is_one_line_exit_1(capsys, monkeypatch, small_disk):
    disk = small_disk("size=1m,ro")
    monkeypatch.setenv("TRIBOFMU_CACHE", str(disk / "cache"))
    code, err, _ = run(["build"], capsys)
    code2, err2, _ = run(["simulate", str(FIG2), "--out", str(disk.parent / "o"), "-q"], capsys)
    for c, e in ((code, err), (code2, err2)):
        assert c == 1 and len(e.splitlines()) == 1 and "Read-only" in e, e


@pytest.mark.alone
def test_too_little_free_space_is_one_line_exit_1_before_any_work(tmp_path, capsys, monkeypatch, fmu_dir):
    import shutil
    from collections import namedtuple
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(10**9, 10**9 - 1000, 1000))
    code, err, elapsed = run(["simulate", str(FIG2), "--out", str(tmp_path / "run"), "--fmu-dir", str(fmu_dir),
                              "-q"], capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "MB free" in err, err
    assert not (tmp_path / "run").exists() and elapsed < 1.0


def test_a_write_failing_after_the_run_keeps_the_previous_results(tmp_path, capsys, monkeypatch, fmu_dir):
    """The disk fills during the run: one line, exit 1, the earlier set intact, no leftovers."""
    import tribofmu.plots as plots
    out = tmp_path / "run"
    argv = ["simulate", str(FIG2), "--out", str(out), "--fmu-dir", str(fmu_dir), "-q",
            "--set", "time.periods=1", "--set", "time.window=[0,1]"]
    assert main(*argv, capsys=capsys).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device", str(out / "time.png"))
    monkeypatch.setattr(plots, "plot_result", full)
    code, err, _ = run(argv, capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "No space left on device" in err, err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


@pytest.mark.alone
def test_an_unreachable_scheduler_is_one_line_exit_2_within_15_s(tmp_path, capsys):
    import socket
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code, err, elapsed = run(["sweep", str(FIG2), "--grid", "drive.omega=30", "--scheduler",
                              f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "s"), "-q",
                              "--set", "time.periods=1", "--set", "time.window=[0,1]"], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "--scheduler" in err, err
    assert elapsed < 15.0


KILL_AT_SWAP = r"""
import os, signal, sys
import tribofmu.atomic as A
from tribofmu.cli import main
A._exchange = lambda a, b: os.kill(os.getpid(), signal.SIGKILL)
sys.exit(main(sys.argv[1:]))
"""


def test_simulate_killed_at_the_swap_leaves_the_previous_set_and_the_next_run_cleans_up(tmp_path, fmu_dir, capsys):
    import subprocess
    import sys
    out = tmp_path / "run"
    argv = ["simulate", str(FIG2), "--out", str(out), "--fmu-dir", str(fmu_dir), "-q", "--no-plots",
            "--set", "time.periods=1", "--set", "time.window=[0,1]"]
    assert main(*argv, capsys=capsys).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.run([sys.executable, "-c", KILL_AT_SWAP, *argv[:-4], "--set", "drive.omega=50",
                           "--set", "time.periods=1", "--set", "time.window=[0,1]"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == -9, proc.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".run.partial-")]  # the killed run's
    assert main(*argv, capsys=capsys).returncode == 0
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def test_export_ssp_never_replaces_a_file_it_did_not_write(tmp_path, capsys, fmu_dir):
    """A user's file, a zip that is no archive of ours, a link or a folder at --out: one line
    naming it, exit 2, the file as it was; an archive export-ssp wrote is replaced."""
    import zipfile

    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    foreign = tmp_path / "foreign.ssp"
    with zipfile.ZipFile(foreign, "w") as archive:
        archive.writestr("SystemStructure.ssd", '<ssd:SystemStructureDescription xmlns:ssd='
                         '"http://ssp-standard.org/SSP1/SystemStructureDescription" name="x" version="1.0"/>')
    link = tmp_path / "link.ssp"
    link.symlink_to(notes)
    for target in (notes, foreign, link):
        before = target.read_bytes()
        code, err, _ = run(["export-ssp", str(FIG2), "--out", str(target), "--fmu-dir", str(fmu_dir)], capsys)
        assert code == 2 and len(err.splitlines()) == 1 and str(target) in err, err
        assert ("symbolic link" if target == link else "not replaced") in err, err
        assert target.read_bytes() == before
    assert notes.read_text() == "my notes\n"
    ours = tmp_path / "ours.ssp"
    for _ in range(2):  # written, then replaced by the same command
        code, err, _ = run(["export-ssp", str(FIG2), "--out", str(ours), "--fmu-dir", str(fmu_dir)], capsys)
        assert code == 0, err
    assert zipfile.ZipFile(ours).read("SystemStructure.ssd").count(b'generationTool="tribofmu ') == 1


def test_an_fmu_from_an_older_build_is_one_line_naming_the_parameter(tmp_path, fmu_dir, capsys):
    """--fmu-dir holding a Friction FMU built before a law's parameter existed (here: its
    model description names no mu_static): exit 2, one line naming the parameter and the
    rebuild, nothing written (before: a KeyError traceback from the setter)."""
    import shutil
    import zipfile

    old = tmp_path / "fmus"
    shutil.copytree(fmu_dir, old)
    with zipfile.ZipFile(fmu_dir / "Friction.fmu") as src, \
            zipfile.ZipFile(old / "Friction.fmu", "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'name="mu_static"', b'name="unused_parameter"')
            dst.writestr(item, data)
    out = tmp_path / "out"
    run = main("simulate", "mixed_stribeck", "--fmu-dir", old, "--out", out, "--no-plots", capsys=capsys)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "'mu_static'" in lines[0] and "rebuild" in lines[0], run.stderr
    assert not out.exists()
