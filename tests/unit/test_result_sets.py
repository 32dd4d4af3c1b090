"""A result set is one unit: killed at any rename of the swap, the output folder holds the
old set or the new one, whole: a reader never finds a result.csv beside another run's stats.

Each case runs a child process that writes a set and SIGKILLs itself at the n-th rename
(or exchange, or removal); then the folder must hold one set, all its files from one run,
and the next run must leave no leftovers beside it.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tribofmu import atomic

FILES = ("stats.json", "result.csv", "time.png")
CHILD = r"""
import os, shutil, signal, sys
from pathlib import Path
import tribofmu.atomic as A
out, token, kill_at, exchange = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]), sys.argv[4] == "1"
count = [0]
def killing(fn):
    def step(*args, **kwargs):
        count[0] += 1
        if count[0] == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)
        return fn(*args, **kwargs)
    return step
os.rename = killing(os.rename)
shutil.rmtree = killing(shutil.rmtree)
A._exchange = killing(A._exchange) if exchange else (lambda a, b: False)
with A.result_set(out) as tmp:
    for name in ("stats.json", "result.csv", "time.png"):  # a stats.json with provenance: a set of ours
        (tmp / name).write_text('{"provenance": "%s"}' % token if name == "stats.json" else token)
print("steps", count[0])
"""


def write_set(out: Path, token: str, kill_at: int = 0, exchange: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", CHILD, str(out), token, str(kill_at), "1" if exchange else "0"],
                          capture_output=True, text=True, timeout=60)


def tokens(out: Path) -> set[str]:
    import json
    assert sorted(p.name for p in out.iterdir()) == sorted(FILES)
    return {json.loads((out / name).read_text())["provenance"] if name == "stats.json" else (out / name).read_text()
            for name in FILES}


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2-exchange", "two-renames"])
def test_a_kill_at_each_step_of_the_swap_leaves_one_whole_set(tmp_path, exchange):
    out = tmp_path / "run"
    assert write_set(out, "old", exchange=exchange).returncode == 0
    steps = int(write_set(tmp_path / "count", "x", exchange=exchange).stdout.split()[-1])
    steps = max(steps, int(write_set(out, "old", exchange=exchange).stdout.split()[-1]))
    assert steps >= 2
    for kill_at in range(1, steps + 1):
        proc = write_set(out, f"new{kill_at}", kill_at, exchange)
        assert proc.returncode == -9, (kill_at, proc.stderr)
        if not out.exists():  # two renames cut between them: the next run puts the old set back
            assert not exchange, kill_at
            atomic.clean_leftovers(out)
        assert tokens(out) in ({"old"}, {f"new{kill_at}"}), kill_at
        assert write_set(out, "old", exchange=exchange).returncode == 0
        assert tokens(out) == {"old"}
        assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".run.")] == [], kill_at


def test_a_folder_holding_other_files_is_never_replaced(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(FileExistsError, match="thesis.tex"):
        with atomic.result_set(out):
            pass
    assert (out / "thesis.tex").read_text() == "precious"


def test_leftovers_of_dead_processes_are_removed_and_live_ones_kept(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    dead = tmp_path / ".run.partial-999999999-x"
    alive = tmp_path / f".run.partial-{os.getppid()}-x"
    digits = tmp_path / ".run.partial-12345678901234567890-x"  # not a pid: no OverflowError, kept
    inside = out / ".partial-abc123"  # where earlier versions staged a run
    for path in (dead, alive, digits, inside):
        path.mkdir()
    atomic.clean_leftovers(out)
    assert not dead.exists() and alive.exists() and digits.exists() and not inside.exists()


def test_results_are_as_readable_as_any_new_file(tmp_path):
    mask = os.umask(0o022)
    try:
        with atomic.result_set(tmp_path / "run") as tmp:
            (tmp / "stats.json").write_text("{}")
        atomic.atomic_write_bytes(tmp_path / "sweep.csv", b"a\n")
    finally:
        os.umask(mask)
    assert (tmp_path / "run").stat().st_mode & 0o777 == 0o755
    assert (tmp_path / "sweep.csv").stat().st_mode & 0o777 == 0o644


@pytest.mark.parametrize("files", [{"time.png": b"mine"}, {"stats.json": b"[1, 2]", "time.png": b"mine"},
                                   {"stats.json": b"{}", "result.csv": b"1,2\n"}],
                         ids=["result-names-only", "stats-not-ours", "stats-without-provenance"])
def test_a_folder_of_result_names_without_our_marker_is_never_replaced(tmp_path, files):
    """Issue 39: a file's name proves nothing (a user's time.png): a result set is known by
    its stats.json with provenance (a folder kept across runs, by its command's marker)."""
    out = tmp_path / "mine"
    out.mkdir()
    for name, data in files.items():
        (out / name).write_bytes(data)
    with pytest.raises(FileExistsError, match="did not write"):
        with atomic.result_set(out):
            pass
    assert {p.name: p.read_bytes() for p in out.iterdir()} == files


def test_a_result_set_is_known_by_its_stats_and_replaced(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "stats.json").write_text('{"provenance": {"tribofmu": "0.0.9"}}')
    (out / "time.png").write_bytes(b"old plot")
    with atomic.result_set(out) as tmp:
        (tmp / "stats.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["stats.json"]


@pytest.mark.parametrize("kind", ["fifo", "link", "huge", "not-json", "folder"])
def test_a_marker_that_is_not_a_small_regular_file_is_not_trusted(tmp_path, kind):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "time.png").write_bytes(b"mine")
    marker = out / atomic.MARKER
    good = b'{"command": "plot"}'
    if kind == "fifo":
        os.mkfifo(marker)  # never opened: it would block
    elif kind == "link":
        (tmp_path / "elsewhere").write_bytes(good)
        marker.symlink_to(tmp_path / "elsewhere")
    elif kind == "huge":
        marker.write_bytes(good + b" " * atomic.MARKER_BYTES)
    elif kind == "not-json":
        marker.write_bytes(b"simulate")
    else:
        marker.mkdir()
    assert atomic.made_by(out) is None
    with pytest.raises(FileExistsError):
        atomic.check_output_folder(out, ("plot",))
