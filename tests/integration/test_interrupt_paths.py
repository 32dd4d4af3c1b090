"""A Ctrl-C is an interruption wherever it lands: also one that Python wraps in another error
(a class made during an import turns it into RuntimeError "Error calling __set_name__"), and
``python -m tribofmu`` ends with 130 after its one line, not by SIGINT."""
from __future__ import annotations

import subprocess
import sys
import textwrap

from cli_run import main


def test_a_ctrl_c_wrapped_in_another_error_is_an_interruption(tmp_path, capsys, monkeypatch):
    from tribofmu import cli_commands

    def wrapped(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:  # what type.__new__ does with it inside __set_name__
            raise RuntimeError("Error calling __set_name__ on 'Field' instance 'phi0_star'") from exc

    monkeypatch.setattr(cli_commands, "cmd_scenes", wrapped)  # (the parser reads it when made)
    run = main("scenes", capsys=capsys)
    assert run.returncode == 130
    assert run.stderr.strip().splitlines() == [
        "tribofmu: interrupted; no result was written (earlier results are as they were)"]


def test_an_error_that_is_no_interruption_is_not_taken_for_one():
    from tribofmu import cli

    assert not cli._interrupted(RuntimeError("plain"))
    chained = ValueError("after")
    chained.__context__ = OSError("before")
    assert not cli._interrupted(chained)
    loop = RuntimeError("a")
    loop.__context__ = loop  # a cycle ends the walk
    assert not cli._interrupted(loop)


def test_the_interrupted_exit_runs_the_exit_handlers_and_is_130(tmp_path):
    marker = tmp_path / "cleaned"
    script = textwrap.dedent(f"""
        import atexit, pathlib, sys
        from tribofmu.__main__ import exit_now_if_interrupted
        atexit.register(lambda: pathlib.Path({str(marker)!r}).write_text("yes"))
        print("line", file=sys.stderr)
        exit_now_if_interrupted(130)
        print("never", file=sys.stderr)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert done.returncode == 130
    assert done.stderr.splitlines() == ["line"]
    assert marker.read_text() == "yes"
