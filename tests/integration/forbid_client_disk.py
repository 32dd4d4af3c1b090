"""Dask worker preload for the tests: this worker may not open anything under the directory
named by TRIBOFMU_TEST_FORBIDDEN (the client's disk, as on a cluster without a shared one)."""
import os
import sys

_FORBIDDEN = os.path.realpath(os.environ["TRIBOFMU_TEST_FORBIDDEN"]) + os.sep


def _audit(event, args):
    if event == "open" and args and isinstance(args[0], (str, bytes, os.PathLike)):
        path = os.path.realpath(os.fsdecode(args[0]))
        if path.startswith(_FORBIDDEN):
            raise PermissionError(f"this worker cannot see the client's disk: {path}")


sys.addaudithook(_audit)
