"""Helpers of the native-host tests: run a C program in a clean environment, read its output."""
from __future__ import annotations

import subprocess

import numpy as np

# what a native tool's process sees: no virtual environment, no PYTHONPATH, no LD_PRELOAD
CLEAN_ENV = {"PATH": "/usr/bin:/bin"}
STEP = 1e-4  # s, the communication step


def vr(description, name: str) -> int:
    """The value reference of a variable (FMI 2.0 ScalarVariable or FMI 3.0 typed element)."""
    for variable in description.find("ModelVariables"):
        if variable.get("name") == name:
            return int(variable.get("valueReference"))
    raise KeyError(name)


def run_clean(command: list, extra_env: dict | None = None, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in command], env={**CLEAN_ENV, **(extra_env or {})},
                          capture_output=True, text=True, timeout=timeout)


def table(stdout: str) -> np.ndarray:
    return np.array([[float(x) for x in line.split(",")] for line in stdout.strip().splitlines()])
