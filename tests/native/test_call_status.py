"""The loader's logging rules and the ``tribofmuCallStatus`` category, on a small FMU built here
with pythonfmu (the same build path as ours: :func:`tribofmu.build.install_native_loader`),
run in the C host with debug logging off:

- a message logged with category ``tribofmuCallStatus`` raises the status of the call it was
  logged in (fmi2Error here: pythonfmu alone returns fmi2OK), and reaches the host under
  ``logStatusError``;
- warnings reach the host's logger with debug logging off; OK-level debug messages do not.
"""
from __future__ import annotations

import pytest

from native_support import run_clean, vr

pytestmark = [pytest.mark.integration, pytest.mark.native]

def run_gate(programs, gate, tmp_path, inputs):
    folder, description = gate
    values = tmp_path / "u.txt"
    values.write_text("\n".join(map(str, inputs)) + "\n")
    return run_clean([programs["fmi2_host"], "-h", "0.1", "-n", len(inputs), "-f", folder, "Gate",
                      description.get("guid"), "-u", 0, vr(description, "u"), values])


def test_logged_error_status_fails_the_call(programs, gate, tmp_path):
    done = run_gate(programs, gate, tmp_path, [1.0, -2.0, 1.0])
    assert done.returncode == 4, done.stderr
    assert "fmi2DoStep of FMU 0 returned fmi2Error" in done.stderr
    assert "[Error] fmu0 logStatusError: u must be >= 0, got -2.0" in done.stderr
    assert len(done.stdout.splitlines()) == 2  # t0 and after the first step; the second failed


def test_warnings_reach_the_host_and_debug_messages_do_not(programs, gate, tmp_path):
    done = run_gate(programs, gate, tmp_path, [1.0, 200.0, 1.0])
    assert done.returncode == 0, done.stderr
    assert "[Warning] fmu0 logStatusWarning: u=200.0 is large" in done.stderr
    assert "debug: stepping" not in done.stderr  # the host instantiated with loggingOn = false
    assert len(done.stdout.splitlines()) == 4
