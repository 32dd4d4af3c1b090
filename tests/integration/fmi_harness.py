"""Drive the built FMUs through fmpy's FMU2Slave, the way an external FMI host would.

Shared by ``test_fmi_conformance.py`` and ``test_fmu_fuzz.py``. Nothing here imports the
FMU code itself: every value goes through the FMI C API of the built ``.fmu`` files.

Two facts about pythonfmu 0.7.0 shape this harness:

- its C wrapper forwards the model's log messages to the host's logger callback only
  when debug logging is on (``loggingOn`` at instantiation, or ``fmi2SetDebugLogging``
  with no category or a listed one). The harness instantiates with ``loggingOn=True``,
  otherwise a refused step would arrive without its explanation;
- after an fmi2Fatal the wrapper has already released the Python instance, so the
  harness never calls ``fmi2FreeInstance`` on a lost instance (it leaks it instead of
  risking a double release inside the test process).
"""
from __future__ import annotations

import math
import struct
import zipfile
from pathlib import Path

import pytest
from fmpy import calloc, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

from tribofmu.master.fmu_files import extract as extract_once
from tribofmu.fmu.registry import fmu_names

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
FMU_NAMES = fmu_names()


def has_native_loader(fmu_path: Path) -> bool:
    """The FMU's binary is tribofmu's native loader, with pythonfmu's binary beside it: a
    refused call then answers fmi2Error (the status its log message carries); pythonfmu's
    binary alone answers OK, and fmi2Discard for a refused doStep."""
    with zipfile.ZipFile(fmu_path) as archive:
        return "binaries/linux64/libpythonfmu-export.so" in archive.namelist()


class FmuFatal(AssertionError):
    """An FMI call returned fmi2Fatal (or fmi2Error): the host lost the instance."""


class Instance:
    """One co-simulation instance with a logger that keeps every message.

    ``messages`` holds ``(status, category, text)`` tuples in arrival order.
    """

    def __init__(self, fmu_path: Path, name: str = "inst", unzip_dir: str | None = None,
                 logging_on: bool = True):
        self.md = read_model_description(str(fmu_path))
        # the master's per-process extraction folder: removed when the test process exits
        self.unzip_dir = unzip_dir or str(extract_once(fmu_path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.reals = [v.name for v in self.md.modelVariables if v.type == "Real"]
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self.messages: list[tuple[int, str, str]] = []
        self.raw_messages: list[str] = []  # as received: printf formats
        self.lost = False
        # the status of a refused call (a bad value, a call in the wrong state)
        loader = has_native_loader(fmu_path)
        self.refused = ERROR if loader else OK
        self.step_refused = ERROR if loader else DISCARD

        def logger(env, instance, status, category, message):
            # The message is a printf format (FMI 2.0); the FMUs pass no arguments, so
            # "%%" is the only specifier they write.
            self.raw_messages.append((message or b"").decode(errors="replace"))
            text = self.raw_messages[-1].replace("%%", "%")
            self.messages.append((int(status), (category or b"").decode(errors="replace"), text))

        # Keep the ctypes objects alive as long as the instance: the FMU calls back into them.
        # No fmpy.logging.addLoggerProxy: its proxy keeps ONE process-wide target, so the
        # last instance registered would receive every instance's messages.
        self._logger = fmi2CallbackLoggerTYPE(logger)
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._callbacks = callbacks
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip_dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)

    # -- raw calls, with fmi2Fatal/fmi2Error turned into a test failure ---------------------
    def call(self, function, *args, refusable: bool = False):
        """Call an FMU2Slave method; returns its result. Status >= fmi2Error fails the test,
        but for a refusal (fmi2Error, logged) where ``refusable``: then None."""
        assert not self.lost, "instance was lost by an earlier fmi2Fatal"
        try:
            return function(*args)
        except FMICallException as exc:
            if refusable and exc.status == ERROR == self.refused:
                return None
            if exc.status >= ERROR:
                self.lost = exc.status == FATAL
                raise FmuFatal(f"{function.__name__}{args}: status {exc.status}; log: {self.messages[-3:]}")
            raise

    def set(self, **values) -> None:
        """Set variables; a refused value (logged as an error) is not a test failure here."""
        for name, value in values.items():
            var = self.vars[name]
            vr = [var.valueReference]
            if var.type == "Real":
                self.call(self.fmu.setReal, vr, [float(value)], refusable=True)
            elif var.type == "Integer":
                self.call(self.fmu.setInteger, vr, [int(value)], refusable=True)
            elif var.type == "Boolean":
                self.call(self.fmu.setBoolean, vr, [bool(value)], refusable=True)
            else:  # pragma: no cover
                raise TypeError(f"{name}: {var.type}")

    def get(self, *names: str) -> list[float]:
        """Values of Real variables, in the order asked (NaN where the read is refused)."""
        vrs = [self.vars[n].valueReference for n in names]
        values = self.call(self.fmu.getReal, vrs, refusable=True)
        if values is None:  # refused: fmpy raised before returning the buffer
            return [math.nan] * len(names)
        return values

    def get_outputs(self) -> dict[str, float]:
        names = [n for n in self.outputs if self.vars[n].type == "Real"]
        return dict(zip(names, self.get(*names)))

    def start(self, start_time: float = 0.0, **parameters) -> None:
        """setupExperiment, initialization mode with the given parameters, exit."""
        self.call(self.fmu.setupExperiment, None, start_time)
        self.call(self.fmu.enterInitializationMode)
        self.set(**parameters)
        self.call(self.fmu.exitInitializationMode, refusable=True)  # refused for a bad parameter

    def step(self, t: float, h: float) -> int:
        """fmi2DoStep; returns fmi2OK, fmi2Discard or a refusal's status (fmi2Fatal fails the test)."""
        assert not self.lost, "instance was lost by an earlier fmi2Fatal"
        try:
            self.fmu.doStep(t, h)
        except FMICallException as exc:
            if exc.status == FATAL:
                self.lost = True
                raise FmuFatal(f"doStep({t}, {h}): fmi2Fatal; log: {self.messages[-3:]}")
            return exc.status
        return OK

    def reset(self) -> None:
        self.call(self.fmu.reset)

    def errors_since(self, mark: int) -> list[str]:
        return [text for status, _, text in self.messages[mark:] if status >= ERROR]

    def free(self) -> None:
        if self.lost:
            return  # see the module docstring: never free an instance pythonfmu already released
        self.fmu.terminate()
        self.fmu.freeInstance()


def bits(values) -> list[bytes]:
    """Exact bit patterns of floats, so that -0.0 != 0.0 and NaN payloads count."""
    return [struct.pack("<d", v) for v in values]


def value_text(value) -> str:
    """How the FMU writes a value into its messages (Python's str of the value it received)."""
    if isinstance(value, bool) or isinstance(value, int):
        return str(value)
    return str(float(value))


def all_finite(values) -> bool:
    return all(math.isfinite(v) for v in values)
