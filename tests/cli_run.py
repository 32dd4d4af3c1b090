"""Running the ``tribofmu`` command as a user would: a fresh process, its own FMU cache and
temp folder (the ``env`` fixture of conftest.py)."""
from __future__ import annotations

import subprocess
import sys


def tribofmu(*args, cwd, env, timeout=600):
    return subprocess.run([sys.executable, "-m", "tribofmu", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)
