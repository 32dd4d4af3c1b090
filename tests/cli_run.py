"""The one way the tests run the ``tribofmu`` command, in this process or in a fresh one.

- :func:`main`: in this test's process (no interpreter start-up, the imports already done):
  the default, for what the command answers and writes;
- :func:`tribofmu`: in a fresh process, as a user would, with its own environment (the
  ``env`` fixture of conftest.py: its own FMU cache and temp folder), for what needs one:
  a fresh HOME or cache, the process's exit, its own Dask cluster, a package blocked at import;
- :func:`command`: that process's command line, for a test that signals it while it runs.

Both runners answer a :class:`subprocess.CompletedProcess` (returncode, stdout, stderr).
"""
from __future__ import annotations

import subprocess
import sys


def command(*args) -> list[str]:
    """The command line that runs ``tribofmu args...`` in a fresh process."""
    return [sys.executable, "-m", "tribofmu", *map(str, args)]


def tribofmu(*args, cwd, env, timeout=600) -> subprocess.CompletedProcess:
    """Run ``tribofmu args...`` in a fresh process in cwd with env."""
    return subprocess.run(command(*args), cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def main(*args, capsys) -> subprocess.CompletedProcess:
    """Run ``tribofmu args...`` in this process (:func:`tribofmu.cli.main`), its output read
    through pytest's capsys fixture (what was printed before is dropped)."""
    from tribofmu import cli
    argv = [str(a) for a in args]
    capsys.readouterr()
    code = cli.main(argv)
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["tribofmu", *argv], code, out, err)
