"""The one place that calls an FMU: fmpy's ``FMU2Slave`` or ``FMU3Slave`` (picked by the
model description's fmiVersion) wrapped with typed errors.

Every call goes through :meth:`FMUInstance.call`, which counts it and turns a bad status into an
:class:`FMUCallError` naming the instance, the FMI function, the status, and the messages
the FMU logged. Anything with the same methods (``set``, ``get``, ``do_step``, ``save``,
``restore``, ``free_state``) can stand in for an instance: the tests use fakes.
"""
from __future__ import annotations

import atexit
import ctypes
import sys
import threading
from pathlib import Path
from typing import Any, Sequence

from ..coupling.system import CALL_KINDS
from ..errors import STATUS_NAMES, FMUCallError, FMUError, FMUFileError, FMUSetupError  # noqa: F401 (re-exported)
from .fmu_files import content_digest, extract, model_description

# fmpy is imported in the functions that call it: 137 ms at start-up (-X importtime, min of 5,
# 2026-11-26 23:59 UTC, load 5.5), and every command but --help loads this module (the CLI
# clears unzipped FMUs at exit: 'scenes' too), while only a run opens an FMU

# What this process keeps of the FMUs' libraries and of the instances it freed (of the FMU
# files, their unzipped copies and model descriptions: master.fmu_files)
_instances_lock = threading.Lock()
_guards_released_at_exit: set[int] = set()  # library handles (under _instances_lock)


def release_pythonfmu_guard_at_exit(dll) -> None:
    """For an FMU whose binary is pythonfmu's own (built without the native loader): call its
    ``finalizePythonInterpreter`` at interpreter exit, before C's exit handlers run.

    Such a binary, while still loaded at exit (instances are freed without unloading it, see
    :meth:`FMUInstance.close`), destroys its static ``shared_ptr<PyState>`` in a C++ static
    destructor and then resets the destroyed pointer again from its destructor function: a
    write into freed heap memory that can abort the process after its work is done
    ("corrupted double-linked list"). Released here first, both find an empty pointer. The
    native loader does the same for the binary it wraps (and exports no such function)."""
    release = getattr(dll, "finalizePythonInterpreter", None) if hasattr(dll, "_handle") else None
    if release is None:
        return
    with _instances_lock:
        if dll._handle in _guards_released_at_exit:
            return
        _guards_released_at_exit.add(dll._handle)
    release.restype, release.argtypes = None, []
    atexit.register(release)


# fmpy's objects of the instances this process freed, by what they were made for (FMI version,
# unzipped folder, guid, model identifier, instance name), with the hot path's functions made
# for them: the next instance of the same FMU takes one (fmpy loads the library's functions
# with their signatures when it makes one: 1 ms, every run's instances; 2026-11-27).
_idle_slaves: dict[tuple, list] = {}  # under _instances_lock


# A call's status above this one (fmi2Warning, fmi3Warning) is a failure.
WARNING = 1


def hot_path_functions(dll, fmi_version: int) -> tuple[dict[str, str], dict[str, Any], list]:
    """The FMI functions a coupling step calls, under version-neutral names (set and get
    reals, doStep, get, set and free the FMU state): their FMI names, and each as a ctypes
    function of ``dll`` (a new function object, so nothing else's ``argtypes`` are changed)
    with its C signature from the FMI headers (the types are fmpy's).

    From a ``PyDLL`` view of the loaded library: called without releasing the GIL, which the
    binary (the native loader over pythonfmu's) takes at once to run the model in Python
    (released and taken back around every call: 0.1 us of a 2 us fmi2GetReal, 2026-11-27).
    Get and set reals come without ``argtypes``, their signature returned beside: called only
    with arguments made once per set of references, each an object of its C type, checked
    then (:func:`check_arguments`), ctypes passes them as they are (converting each on every
    call: 0.36 us of the 2)."""
    from ctypes import POINTER, PyDLL, c_int, c_size_t

    if fmi_version == 3:
        from fmpy.fmi3 import fmi3Boolean as boolean, fmi3Float64 as real, fmi3FMUState as state
        from fmpy.fmi3 import fmi3Instance as instance, fmi3ValueReference as vr
        names = ("fmi3SetFloat64", "fmi3GetFloat64", "fmi3DoStep", "fmi3GetFMUState", "fmi3SetFMUState",
                 "fmi3FreeFMUState")
        values = [instance, POINTER(vr), c_size_t, POINTER(real), c_size_t]  # + nValues
        step = [instance, real, real, boolean, POINTER(boolean), POINTER(boolean), POINTER(boolean),
                POINTER(real)]
    else:
        from fmpy.fmi2 import fmi2Boolean as boolean, fmi2Component as instance, fmi2FMUstate as state
        from fmpy.fmi2 import fmi2Real as real, fmi2ValueReference as vr
        names = ("fmi2SetReal", "fmi2GetReal", "fmi2DoStep", "fmi2GetFMUstate", "fmi2SetFMUstate",
                 "fmi2FreeFMUstate")
        values = [instance, POINTER(vr), c_size_t, POINTER(real)]
        step = [instance, real, real, boolean]
    argtypes = (values, values, step, [instance, POINTER(state)], [instance, state], [instance, POINTER(state)])
    keys = ("set", "get", "step", "save", "restore", "free")
    functions = {}
    library = PyDLL(dll._name, handle=dll._handle)  # the same loaded library, not loaded again
    for key, name, types in zip(keys, names, argtypes):
        function = library[name]
        function.argtypes, function.restype = (None if key in ("set", "get") else types), c_int
        functions[key] = function
    return dict(zip(keys, names)), functions, values


def check_arguments(signature: list, args: tuple) -> None:
    """Raise TypeError unless ``args`` are, one for each parameter of ``signature`` (ctypes
    types), objects of exactly that type, or for a pointer an array of what it points to:
    what a function without ``argtypes`` may be called with (ctypes passes them as they are;
    a Python int would go as a C int)."""
    import ctypes

    if len(args) != len(signature):
        raise TypeError(f"{len(args)} arguments for {len(signature)} parameters")
    for ctype, arg in zip(signature, args):
        if type(arg) is not ctype and not (isinstance(arg, ctypes.Array) and ctype is ctypes.POINTER(arg._type_)):
            raise TypeError(f"{arg!r} is not a {ctype.__name__}")


class FMUInstance:
    """One instance of an FMU file (FMI 2.0 or 3.0 co-simulation), driven through fmpy.

    path: the .fmu file; instance: its instance name; parameters: start values by name.
    """

    def __init__(self, path: str | Path, instance: str, parameters: dict[str, Any] | None = None,
                 start_time: float = 0.0):
        path = Path(path)
        if not path.is_file():
            raise FMUFileError(f"{instance}: FMU file not found: {path} (run 'tribofmu build' first)")
        self.instance = instance
        self._setup_calls = 0  # the FMI calls made outside the hot path (``calls`` adds the rest)
        # the hot path's calls by kind (CALL_KINDS: get/set reals, doStep, get/set/free FMU
        # state); the rest of ``calls`` is setup and teardown
        self.calls_by_kind = dict.fromkeys(CALL_KINDS, 0)
        # the FMU state handle the instance holds exactly (saved into or restored from, no set
        # or step since; None: none): restoring it again is no call (see restore)
        self._holds = None
        self.messages: list[str] = []
        try:
            digest = content_digest(path)
            md = model_description(path, digest)
        except Exception as exc:  # a corrupt archive has many failure modes in fmpy
            raise FMUFileError(f"{instance}: cannot read {path}: {exc}") from None
        self.variables = {v.name: v for v in md.modelVariables}
        self.refs = {name: v.valueReference for name, v in self.variables.items()}
        self.guid = md.guid  # FMI 3.0: the instantiationToken
        self.fmi_version = 3 if md.fmiVersion.startswith("3") else 2
        if md.coSimulation is None:
            raise FMUFileError(f"{instance}: {path} is not a co-simulation FMU")
        unknown = sorted(set(parameters or ()) - set(self.variables))
        if unknown:  # before anything is unzipped or instantiated: nothing to undo
            raise FMUSetupError(f"{instance}: {path} has no parameter {', '.join(map(repr, unknown))}: an FMU "
                                f"built by another tribofmu version? rebuild it (tribofmu build --out {path.parent})")
        self._prefix = f"fmi{self.fmi_version}"
        try:
            self._unzipped = extract(path, digest)
        except Exception as exc:
            raise FMUFileError(f"{instance}: cannot unzip {path}: {exc}") from None
        self._take_fmpy_slave(md)
        self._closed = False
        self._instantiate()
        dll = getattr(self._fmu, "dll", None)
        release_pythonfmu_guard_at_exit(dll)
        # Behind the native loader a saved state can be overwritten in place (FMI's get into a
        # non-NULL state): one call where a free and a save were two. pythonfmu's own binary
        # (it exports finalizePythonInterpreter, the loader does not) would leak the old state.
        self.overwrites_states = dll is not None and getattr(dll, "finalizePythonInterpreter", None) is None
        if self.fmi_version == 3:  # FMI 3.0 has no setupExperiment: the start time comes here
            self.call("enterInitializationMode", startTime=start_time)
        else:
            self.call("setupExperiment", startTime=start_time)
            self.call("enterInitializationMode")
        if parameters:
            self.set(parameters)
        self.call("exitInitializationMode")
        self._bind_hot_path()

    def _take_fmpy_slave(self, md) -> None:
        """fmpy's object for this instance (``_fmu``, with its hot-path functions ``_hot`` where
        made): one an instance of the same FMU left when it was closed, else a new one."""
        self._made_for = (self.fmi_version, str(self._unzipped), md.guid, md.coSimulation.modelIdentifier,
                          self.instance)
        with _instances_lock:
            idle = _idle_slaves.get(self._made_for)
            self._fmu, self._hot = idle.pop() if idle else (None, None)
        if self._fmu is None:
            if self.fmi_version == 3:
                from fmpy.fmi3 import FMU3Slave as FMUSlave
            else:
                from fmpy.fmi2 import FMU2Slave as FMUSlave
            self._fmu = FMUSlave(guid=md.guid, unzipDirectory=str(self._unzipped),
                                 modelIdentifier=md.coSimulation.modelIdentifier, instanceName=self.instance)

    def _instantiate(self) -> None:
        """fmi2Instantiate / fmi3Instantiate, with the logger that keeps what explains a failure
        in ``messages``."""
        resources = str(Path(self._unzipped, "resources"))
        try:
            if self.fmi_version == 3:
                self._log_message = self._make_log_message()
                self.call("instantiate", loggingOn=True, logMessage=self._log_message)
            else:
                self._callbacks = self._make_callbacks()
                self.call("instantiate", callbacks=self._callbacks, loggingOn=True)
        finally:
            # pythonfmu put the FMU's resources folder first on sys.path to import the slave;
            # once imported it is not needed, and its bundled pythonfmu copy (without the
            # builder's binaries) would shadow the installed one in this process.
            sys.path[:] = [entry for entry in sys.path if entry != resources]

    def _make_callbacks(self):
        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

        # No fmpy logger proxy: it routes every instance's messages to the last one
        # registered. pythonfmu passes the whole text as the format, with % escaped.
        def log(_env, _name, status, _category, message):
            text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
            if status >= 2:  # keep only what explains a failure
                self.messages.append(text.replace("%%", "%"))

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        return callbacks

    def _make_log_message(self):
        from fmpy.fmi3 import fmi3LogMessageCallback

        # FMI 3.0 passes the message as plain text (no format string, nothing escaped).
        def log(_env, status, _category, message):
            if status >= 2:  # keep only what explains a failure
                self.messages.append(message.decode("utf-8", "replace")
                                     if isinstance(message, bytes) else str(message))

        return fmi3LogMessageCallback(log)

    def _bind_hot_path(self):
        """The calls a coupling step makes thousands of times (set and get reals, doStep, get,
        set and free the FMU state), bound once: each a ctypes function of the FMU's library
        with its C signature (:func:`hot_path_functions`), called with the value-reference and
        value arrays built once per set of references, its status checked here (above
        Warning: :class:`FMUCallError`). What does not change between calls (the instance
        handle, the counts, doStep's flags) is an object of its C type, made once (ctypes
        converts a Python int or bool anew on every call: 0.24 us of 2.3, 2026-11-27).

        fmpy's public per-function methods (``fmi2GetReal(component, vr, n, values)``, which
        this called before) wrap the same C call in two Python calls and a status check of
        their own; fmpy stays what loads the library and makes the instance.
        """
        import ctypes

        from ctypes import c_size_t

        self._size = c_size_t
        # per tuple of value references: its values array and the C call's arguments (see _buffer)
        self._buffers: dict[tuple[int, ...], tuple[Any, tuple]] = {}
        # the operations under version-neutral names (set/get reals, do step, get/set/free state)
        if self._hot is None:
            self._hot = hot_path_functions(self._fmu.dll, self.fmi_version)
        self._names, functions, self._real_signature = self._hot
        self._set_c, self._get_c, self._step_c, self._save_c, self._restore_c, self._free_c = (
            functions[key] for key in ("set", "get", "step", "save", "restore", "free"))
        if self.fmi_version == 3:
            from fmpy.fmi3 import fmi3Boolean, fmi3Float64, fmi3FMUState, fmi3Instance, fmi3ValueReference

            self._component = fmi3Instance(self._fmu.component)
            self._state_type = fmi3FMUState
            self._real, self._vr = fmi3Float64, fmi3ValueReference
            # doStep's outputs; eventHandlingNeeded and earlyReturn stay false (not requested)
            self._step_flags = (fmi3Boolean(), fmi3Boolean(), fmi3Boolean(), fmi3Float64())
            # doStep's arguments after t and h: noSetFMUStatePriorToCurrentPoint, the outputs
            self._step_tail = (fmi3Boolean(False), *(ctypes.byref(flag) for flag in self._step_flags))
        else:
            from fmpy.fmi2 import fmi2Boolean, fmi2Component, fmi2FMUstate, fmi2Real, fmi2ValueReference

            self._component = fmi2Component(self._fmu.component)
            self._state_type = fmi2FMUstate
            self._real, self._vr = fmi2Real, fmi2ValueReference
            self._step_tail = (fmi2Boolean(1),)  # noSetFMUStatePriorToCurrentPoint

    def _buffer(self, refs) -> tuple[Any, tuple]:
        """The values array of ``refs`` (made once per tuple of value references) and the
        arguments of the C get and set reals calls on it, the same for both: (instance,
        value references, their count, values) and, FMI 3.0, nValues."""
        key = refs if type(refs) is tuple else tuple(refs)
        buf = self._buffers.get(key)
        if buf is None:
            n = len(key)
            values, count = (self._real * n)(), self._size(n)
            args = (self._component, (self._vr * n)(*key), count, values) + ((count,) if self.fmi_version == 3 else ())
            check_arguments(self._real_signature, args)  # (the calls on them check none)
            buf = self._buffers[key] = (values, args)
        return buf

    def _failed(self, key: str, status: int, mark: int) -> FMUCallError:
        """The error of a hot-path call whose status is above Warning, with the messages the
        FMU logged during the call (the state it holds is then unknown: a refused call may
        have put it in its error state)."""
        self._holds = None
        return FMUCallError(self.instance, self._names[key], status, self.messages[mark:])

    @property
    def calls(self) -> int:
        """Every FMI call made, setup and hot path alike."""
        return self._setup_calls + sum(self.calls_by_kind.values())

    def call(self, function: str, *args, **kwargs):
        """Call an fmpy FMU2Slave/FMU3Slave method; a bad status raises :class:`FMUCallError`."""
        from fmpy.fmi1 import FMICallException

        self._setup_calls += 1
        self._holds = None
        mark = len(self.messages)
        try:
            return getattr(self._fmu, function)(*args, **kwargs)
        except FMICallException as exc:
            raise FMUCallError(self.instance, self._prefix + function[0].upper() + function[1:],
                               exc.status, self.messages[mark:]) from None
        except Exception as exc:
            if function == "instantiate":
                raise FMUCallError(self.instance, self._prefix + "Instantiate", 3,
                                   self.messages[mark:] or [str(exc)]) from None
            raise

    # -- the operations the coupling algorithms use ------------------------------------
    def set(self, values: dict[str, Any]) -> None:
        """Set variables by name; the type comes from the model description."""
        groups: dict[str, tuple[list[int], list[Any]]] = {}
        for name, value in values.items():
            var = self.variables.get(name)
            if var is None:
                raise FMUSetupError(f"{self.instance}: no variable {name!r} in this FMU")
            refs, vals = groups.setdefault(var.type, ([], []))
            refs.append(var.valueReference)
            vals.append(value)
        for kind, (refs, vals) in groups.items():
            self.call(f"set{kind}", refs, vals)

    def set_reals(self, refs: Sequence[int], values: Sequence[float]) -> None:
        """fmi2SetReal / fmi3SetFloat64."""
        self.calls_by_kind["set"] += 1
        self._holds = None
        try:  # (the hot path passes tuples of references seen before)
            buf, args = self._buffers[refs]
        except (KeyError, TypeError):
            buf, args = self._buffer(refs)
        buf[:] = values
        mark = len(self.messages)  # before the call: its messages explain a bad status
        status = self._set_c(*args)
        if status > WARNING:
            raise self._failed("set", status, mark)

    def get_reals(self, refs: Sequence[int]) -> list[float]:
        """fmi2GetReal / fmi3GetFloat64."""
        self.calls_by_kind["get"] += 1
        try:
            buf, args = self._buffers[refs]
        except (KeyError, TypeError):
            buf, args = self._buffer(refs)
        mark = len(self.messages)
        status = self._get_c(*args)
        if status > WARNING:
            raise self._failed("get", status, mark)
        return buf[:]

    def do_step(self, t: float, h: float) -> None:
        """One communication step from t by h [s]. The master may restore an earlier state
        afterwards: FMI 3.0 gets noSetFMUStatePriorToCurrentPoint = false (the FMI 2.0 call
        keeps passing true, which pythonfmu ignores)."""
        self.calls_by_kind["doStep"] += 1
        self._holds = None
        mark = len(self.messages)
        status = self._step_c(self._component, t, h, *self._step_tail)
        if status > WARNING:
            raise self._failed("step", status, mark)

    def save(self):
        state = self._state_type()
        self._get_state(state)
        return state

    def save_into(self, state) -> bool:
        """Overwrite ``state`` (saved by this instance before) with the current state; False,
        and nothing done, where the binary cannot (see ``overwrites_states``)."""
        if not self.overwrites_states:
            return False
        self._get_state(state)
        return True

    def _get_state(self, state) -> None:
        """FMI's get FMU state into ``state`` (a new one where it holds NULL)."""
        self.calls_by_kind["save"] += 1
        mark = len(self.messages)
        status = self._save_c(self._component, ctypes.byref(state))
        if status > WARNING:
            raise self._failed("save", status, mark)
        self._holds = state

    def restore(self, state) -> None:
        """FMI's set FMU state: no call where the instance holds that state already (saved
        into or restored from it, and neither set nor stepped since: a get reads, it does not
        move the state), as a rejected try's block that its deferred step never moved."""
        if state is self._holds:
            return
        self.calls_by_kind["restore"] += 1
        self._holds = None  # (a failed restore leaves the state unknown)
        mark = len(self.messages)
        status = self._restore_c(self._component, state)
        if status > WARNING:
            raise self._failed("restore", status, mark)
        self._holds = state

    def free_state(self, state) -> None:
        self.calls_by_kind["free"] += 1
        if state is self._holds:
            self._holds = None  # (the handle may be reused for another state)
        mark = len(self.messages)
        status = self._free_c(self._component, ctypes.byref(state))
        if status > WARNING:
            raise self._failed("free", status, mark)

    def close(self) -> None:
        """Terminate and free the instance (errors here lose nothing: ignore them). The
        unzipped copy stays for other instances of the same file until the process exits.

        The FMU's shared library stays loaded until the process exits (fmpy's
        ``freeInstance`` would also unload it), so the next instance of the same file does
        not load it again. pythonfmu's binary is never unloaded anyway (glibc keeps a library
        with STB_GNU_UNIQUE symbols); what it does wrong at exit is handled by the native
        loader and by :func:`release_pythonfmu_guard_at_exit`. fmpy's object, its library
        loaded, is kept for the next instance of the same FMU (``_idle_slaves``). A second
        close does nothing (that object may make another instance by then).
        """
        if self._closed:
            return
        self._closed = True
        try:
            self._fmu.terminate()
        except Exception:
            pass
        try:  # fmi2FreeInstance / fmi3FreeInstance without fmpy's freeLibrary
            getattr(self._fmu, f"{self._prefix}FreeInstance")(self._fmu.component)
        except Exception:
            return  # not freed: not for another instance either
        with _instances_lock:
            _idle_slaves.setdefault(self._made_for, []).append((self._fmu, self._hot))
