"""The shared framework of the tribofmu FMUs: a thin layer over pythonfmu's ``Fmi2Slave``
(FMI 2.0) or pythonfmu3's ``Fmi3Slave`` (FMI 3.0), chosen at build time by
:data:`.fmi_version.FMI_VERSION`; the adapters import everything FMI-specific from here, so
the same adapter files build for both versions.

Each FMU script declares its variables with :meth:`TriboModel.declare` and implements
:meth:`TriboModel.advance`. This module is the one place that

- writes what pythonfmu 0.7 leaves out of ``modelDescription.xml``: units, ``initial``
  attributes, ``InitialUnknowns`` and the output dependencies of ``ModelStructure``;
- takes the start values of parameters and inputs from the FMU's own ``modelDescription.xml``
  (FMI: the start value is the value at instantiation), so an FMU copy whose description
  was rewritten (``tribofmu export-ssp``) starts from the rewritten values;
- enforces the FMI state machine (instantiated, initialization mode, step mode, terminated)
  and turns misuse and bad values into a refusal with a log message of status Error naming
  the call, the variable and the value.

What the host receives as status is decided by pythonfmu's C++ wrapper, not by this code:
pythonfmu 0.7.0 (FMI 2.0) returns fmi2OK whenever the Python method returns, fmi2Discard when
``do_step`` returns False, and fmi2Fatal on any Python exception, after which it has already
released the Python instance (every further call on it is a use after free). pythonfmu3
0.3.4 (FMI 3.0) does the same, except that ``do_step`` may return any status. So nothing here
raises; a refused call leaves no effect, logs an Error-status message in the category
:data:`CALL_STATUS_CATEGORY` (the FMUs' native loader, between host and pythonfmu's binary,
makes that status the call's: fmi2Error) and, where the call
would otherwise have changed what the model computes (a setter, setting an FMU state), puts
the instance into an error state: every following ``doStep`` is refused (fmi2Discard,
fmi3Error) until fmi2Reset or restoring a good FMU state. A host that ignores the logger
therefore still cannot step on with a value it believes set. What a host sees, call by call,
is the README's state table. A step is all or nothing: a refused step (bad value, numerical
failure, non-finite outputs) leaves the state as it was.

- saves and restores the complete state (variables plus the model's internal state), so
  get/set and serialize/deserialize FMU state continue bit-identically; a state names the
  model and build it came from, and one of another model or build is refused.

No physics here: the models live in :mod:`tribofmu.physics`.
"""
from __future__ import annotations

import copy
import json
import math
import os
import uuid
from typing import Any, Callable, Iterable
from xml.etree.ElementTree import Element, SubElement, parse

from .fmi_version import FMI_VERSION

if FMI_VERSION == 3:
    from pythonfmu3 import Boolean, Fmi3Causality as Causality, Fmi3Slave as _PythonFMUSlave
    from pythonfmu3 import Fmi3Variability as Variability, Float64 as Real, Int32 as Integer
    from pythonfmu3.default_experiment import DefaultExperiment
    from pythonfmu3.enums import Fmi3Initial as Initial, Fmi3Status as Status
    from pythonfmu3.fmi3slave import Fmi3StepResult
else:
    from pythonfmu import Boolean, Fmi2Causality as Causality, Fmi2Slave as _PythonFMUSlave
    from pythonfmu import Fmi2Variability as Variability, Integer, Real
    from pythonfmu.default_experiment import DefaultExperiment
    from pythonfmu.enums import Fmi2Initial as Initial, Fmi2Status as Status

PARAMETER, INPUT, OUTPUT = Causality.parameter, Causality.input, Causality.output

AUTHOR = "tribofmu developers"
LICENSE = "MIT"
VERSION = "0.1.0"

_KINDS = {float: Real, int: Integer, bool: Boolean}
_PREFIX = f"fmi{FMI_VERSION}"
# The FMI names of the typed calls, for messages: Python type of the variable -> suffix.
_TYPE_NAMES = {Real: "Float64" if FMI_VERSION == 3 else "Real",
               Integer: "Int32" if FMI_VERSION == 3 else "Integer", Boolean: "Boolean"}
_STATE = "FMUState" if FMI_VERSION == 3 else "FMUstate"

# The log category of a refusal: the FMUs' native loader (tribofmu.native, between the host and
# pythonfmu's binary) returns the status of such a message as the status of the call, so a
# refused setter, getter, initialization or FMU state answers fmi2Error/fmi3Error there. The
# loader hands the message on under the usual logStatusError category.
CALL_STATUS_CATEGORY = "tribofmuCallStatus"

# The FMI states a co-simulation instance passes through (error is a flag beside them).
INSTANTIATED, INITIALIZATION, STEP, TERMINATED = (
    "instantiated", "initialization mode", "step mode", "terminated")


def _start_values(resources: str | None) -> dict[str, str]:
    """name -> start text of every variable with a start value in the modelDescription.xml
    beside ``resources`` (empty when there is none, e.g. while pythonfmu builds the FMU)."""
    if not resources or os.path.basename(os.path.normpath(resources)) != "resources":
        return {}
    path = os.path.join(os.path.dirname(os.path.normpath(resources)), "modelDescription.xml")
    try:
        root = parse(path).getroot()
    except (OSError, SyntaxError):
        return {}
    starts = {}
    for node in root.iterfind("ModelVariables/*"):
        typed = node if FMI_VERSION == 3 else next(iter(node), None)  # FMI 2: <Real start=.../>
        if typed is not None and typed.get("start") is not None:
            starts[node.get("name")] = typed.get("start")
    return starts


def _parse_start(kind: type, text: str) -> Any:
    if kind is bool:
        if text not in ("true", "false", "1", "0"):
            raise ValueError(f"not a Boolean: {text!r}")
        return text in ("true", "1")
    return kind(text)


class TriboModel(_PythonFMUSlave):
    """Base of every tribofmu FMU: declare variables, implement :meth:`advance`."""

    author = AUTHOR
    license = LICENSE
    version = VERSION
    log_categories = {**_PythonFMUSlave.log_categories,
                      CALL_STATUS_CATEGORY: "A refused call; its status (Error) is the call's status."}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        # pythonfmu3's constructor sets these to None on the instance, hiding the adapters'
        # class attributes; pythonfmu's leaves them visible. Either way: the class's value.
        for name in ("description", "author", "license", "version", "default_experiment"):
            if getattr(type(self), name, None) is not None:
                setattr(self, name, getattr(type(self), name))
        self._units: dict[str, str] = {}
        self._depends_on: dict[str, tuple[str, ...]] = {}
        self._checks: dict[str, Callable[[Any], str | None]] = {}
        self._bad: dict[str, str] = {}  # variable name -> why its value was refused
        self._getters: dict[str, Callable[[], Any]] = {}  # outputs computed on demand
        self._initialized = False  # initialize() ran (it is skipped while values are bad)
        self._real_output_names: list[str] | None = None  # caches: variables are declared once
        self._dynamic_state_names: list[str] | None = None
        self._parameter_names: list[str] = []
        self._parameter_set: set[str] = set()
        self._scalar_state_names: list[str] | None = None
        self._model_problems: list[str] | None = None  # parameters are fixed: validate once
        # Names the parameter values; a saved state whose token matches needs none restored.
        self._parameter_token = f"{uuid.uuid4()}:0"
        self.time = 0.0
        self._mode = INSTANTIATED
        self._error: str | None = None  # the refused call that put the instance in error
        self._describing = False  # pythonfmu reads the start values while writing the XML
        self._starts = _start_values(kwargs.get("resources"))
        # FMU states name the model and the build (the module's private name has both)
        self._model_id = f"{type(self).__module__}.{type(self).__qualname__}"
        if FMI_VERSION == 3:  # FMI 3.0 requires the independent variable among the variables
            self.register_variable(Real("time", causality=Causality.independent,
                                        variability=Variability.continuous,
                                        description="simulation time", getter=lambda: self.time))
            self._units["time"] = "s"

    # -- declaring variables ------------------------------------------------------
    def declare(self, name: str, start: Any, causality: Causality, unit: str,
                description: str, depends_on: Iterable[str] = (),
                check: Callable[[Any], str | None] | None = None,
                getter: Callable[[], Any] | None = None) -> None:
        """Register a variable.

        start: initial value (its Python type picks Real, Integer or Boolean);
        unit: SI unit symbol ("1" for dimensionless); depends_on: for outputs, the inputs
        they depend on directly; check: for parameters and inputs, returns why a value is
        out of range (None if fine); getter: for outputs computed on demand.
        """
        kind = _KINDS[type(start)]
        start = self._start_of(name, start, causality)
        kwargs: dict[str, Any] = dict(causality=causality, description=description)
        if causality == Causality.parameter:
            kwargs["variability"] = Variability.fixed
        elif causality == Causality.input:
            kwargs["variability"] = Variability.continuous if kind is Real else Variability.discrete
        elif causality == Causality.output:
            kwargs["variability"] = Variability.continuous if kind is Real else Variability.discrete
            kwargs["initial"] = Initial.calculated
        if causality in (Causality.parameter, Causality.input):
            setattr(self, name, start)
            kwargs["setter"] = self._setter(name, type(start), causality == Causality.parameter)
        if causality == Causality.parameter:
            self._parameter_names.append(name)
            self._parameter_set.add(name)
        if getter is not None:
            self._getters[name] = getter
            kwargs["getter"] = self._safe_getter(name, getter)
        elif causality == Causality.output:
            setattr(self, name, start)
        self.register_variable(kind(name, **kwargs))
        if kind is Real:
            self._units[name] = unit
        self._depends_on[name] = tuple(depends_on)
        if check is not None:
            self._checks[name] = check
        if causality in (Causality.parameter, Causality.input):
            why = self._value_problem(name, type(start), start)
            if why:  # a start value from a rewritten modelDescription.xml
                self._bad[name] = f"{name} {why}"

    def _start_of(self, name: str, start: Any, causality: Causality) -> Any:
        text = self._starts.get(name)
        if text is None or causality not in (Causality.parameter, Causality.input):
            return start
        # pythonfmu writes Reals with 16 significant digits, one short of a round trip: the
        # text it wrote for the declared start means the declared start, bit for bit
        if type(start) is float and text == f"{start:.16g}":
            return start
        try:
            return _parse_start(type(start), text)
        except ValueError:
            self._log(f"{name}: start value {text!r} in modelDescription.xml is not a "
                      f"{type(start).__name__}; using {start}", Status.error)
            return start

    def _value_problem(self, name: str, kind: type, value: Any) -> str | None:
        if kind is float and not math.isfinite(value):
            return f"must be finite, got {value}"
        check = self._checks.get(name)
        return check(value) if check else None

    def _setter(self, name: str, kind: type, is_parameter: bool) -> Callable[[Any], None]:
        def setter(value: Any) -> None:
            value = kind(value)
            why = self._value_problem(name, kind, value)
            if why:
                self._bad[name] = f"{name} {why}"
                if kind is float and not math.isfinite(value):
                    # refused: never stored, so nothing computes with it; every step and
                    # every output that depends on the values is refused until it is replaced
                    self._log(f"{_PREFIX}Set{_TYPE_NAMES[_KINDS[kind]]}: {name} {why}: refused",
                              Status.error, CALL_STATUS_CATEGORY)
                    return
                # in range is checked when initialization ends (parameters) or at the step
            else:
                self._bad.pop(name, None)
            setattr(self, name, value)
            if is_parameter:
                self._parameters_changed(name)
            else:
                self.changed(name)
        return setter

    def _parameters_changed(self, name: str) -> None:
        uid, count = self._parameter_token.rsplit(":", 1)
        self._new_parameters(f"{uid}:{int(count) + 1}")
        self.changed(name)

    def _new_parameters(self, token: str) -> None:
        """Parameter values changed: drop what was derived from them."""
        self._model_problems = None
        self._parameter_token = token

    def _safe_getter(self, name: str, getter: Callable[[], Any]) -> Callable[[], Any]:
        # An exception escaping a getter would make fmi2GetReal return fmi2Fatal.
        def get() -> Any:
            if self._describing:
                return getter()
            # the model's own validation runs once per parameter set: usually nothing to join
            problems = self.problems() if self._bad or self._model_problems != [] else None
            if problems:
                why = "; ".join(problems)
                self._log(f"{_PREFIX}Get{_TYPE_NAMES[Real]}: {name} cannot be evaluated while {why}; "
                          f"reads as NaN", Status.error, CALL_STATUS_CATEGORY)
                return math.nan
            try:
                value = getter()
            except Exception as exc:
                self._log(f"{_PREFIX}Get{_TYPE_NAMES[Real]}: {name} cannot be evaluated "
                          f"({type(exc).__name__}: {exc}) at {self._inputs_text()}; reads as NaN",
                          Status.error, CALL_STATUS_CATEGORY)
                return math.nan
            if isinstance(value, float) and not math.isfinite(value):
                self._log(f"{_PREFIX}Get{_TYPE_NAMES[Real]}: {name} is not finite ({value}) at "
                          f"{self._inputs_text()}", Status.error, CALL_STATUS_CATEGORY)
            return value
        return get

    def _log(self, msg: str, status: Status, category: str | None = None) -> None:
        text = f"{self.instance_name}: {msg}"
        if FMI_VERSION == 2:
            # pythonfmu hands the text to the host's logger as its printf format string
            # (FMI 2.0 says the message is one): an unescaped "%s", e.g. from a host-chosen
            # instance name, makes a formatting host read arguments that are not there.
            # FMI 3.0's logMessage takes plain text: nothing to escape.
            text = text.replace("%", "%%")
        self.log(text, status, category)

    def _inputs_text(self) -> str:
        names = [v.name for v in self.vars.values() if v.causality == Causality.input]
        return ", ".join(f"{n}={getattr(self, n)}" for n in names) or "no inputs"

    # -- the FMI state machine ------------------------------------------------------------
    def _refuse(self, call: str, why: str, enter_error: bool = False) -> None:
        """Log a refused call (status Error); enter_error: the host may believe something
        happened that did not, so every doStep is refused until reset or a state is restored."""
        self._log(f"{_PREFIX}{call}: {why}", Status.error, CALL_STATUS_CATEGORY)
        if enter_error and self._error is None:
            self._error = f"{_PREFIX}{call} was refused ({why})"

    def _in_mode(self, call: str, *modes: str) -> bool:
        if self._mode in modes:
            return True
        self._refuse(call, f"not allowed in {self._mode} (only in {' or '.join(modes)})")
        return False

    def setup_experiment(self, start_time: float, stop_time=None, tolerance=None) -> None:
        if self._in_mode("SetupExperiment" if FMI_VERSION == 2 else "EnterInitializationMode",
                         INSTANTIATED):
            self.time = start_time

    def enter_initialization_mode(self) -> None:
        if self._in_mode("EnterInitializationMode", INSTANTIATED):
            self._mode = INITIALIZATION

    def exit_initialization_mode(self) -> None:
        if not self._in_mode("ExitInitializationMode", INITIALIZATION):
            return
        self._mode = STEP
        try:
            problems = self.problems()
            if not problems:
                self.initialize()
                self._initialized = True
        except Exception as exc:  # would be fmi2Fatal; do_step reports it again and refuses
            problems = [f"initialization failed ({type(exc).__name__}: {exc})"]
        for problem in problems:
            self._refuse("ExitInitializationMode", problem)

    def terminate(self) -> None:
        if self._in_mode("Terminate", STEP):
            self._mode = TERMINATED

    # -- getters and setters: unknown references, types and states ---------------------------
    def _set(self, kind: type, vrs, values) -> None:
        call = f"Set{_TYPE_NAMES[kind]}"
        for vr, value in zip(vrs, values):
            var = self.vars.get(vr)
            why = self._may_not_set(var, vr, kind)
            if why:
                self._refuse(call, f"{why}; {value!r} not set", enter_error=True)
            else:
                var.setter(value)

    def _may_not_set(self, var, vr: int, kind: type) -> str | None:
        if var is None:
            return f"unknown value reference {vr}"
        if not isinstance(var, kind):
            return f"{var.name} (value reference {vr}) is not a {_TYPE_NAMES[kind]} variable"
        if var.causality not in (Causality.parameter, Causality.input) or var.setter is None:
            return f"{var.name} is an {var.causality.name}: it cannot be set"
        if self._mode == TERMINATED:
            return f"{var.name} cannot be set after {_PREFIX}Terminate"
        if (var.causality == Causality.parameter and self._mode == STEP
                and var.variability != Variability.tunable):
            return (f"{var.name} is a fixed parameter: it can be set only before "
                    f"{_PREFIX}ExitInitializationMode ({_PREFIX}Reset to change it)")
        return None

    def _get(self, kind: type, vrs, cast: Callable[[Any], Any], missing: Any) -> list:
        call = f"Get{_TYPE_NAMES[kind]}"
        if self._mode == INSTANTIATED and not self._describing:
            self._refuse(call, f"not allowed before {_PREFIX}EnterInitializationMode; "
                               f"reads as {missing}")
            return [missing] * len(vrs)
        values = []
        for vr in vrs:
            var = self.vars.get(vr)
            if var is None or not isinstance(var, kind):
                what = (f"unknown value reference {vr}" if var is None else
                        f"{var.name} (value reference {vr}) is not a {_TYPE_NAMES[kind]} variable")
                self._refuse(call, f"{what}; reads as {missing}")
                values.append(missing)
            else:
                values.append(cast(var.getter()))
        return values

    if FMI_VERSION == 3:
        def get_float64(self, vrs):
            return self._get(Real, vrs, float, math.nan)

        def get_int32(self, vrs):
            return self._get(Integer, vrs, int, 0)

        def get_boolean(self, vrs):
            return self._get(Boolean, vrs, bool, False)

        def set_float64(self, vrs, values):
            self._set(Real, vrs, values)

        def set_int32(self, vrs, values):
            self._set(Integer, vrs, values)

        def set_boolean(self, vrs, values):
            self._set(Boolean, vrs, values)
    else:
        def get_real(self, vrs):
            return self._get(Real, vrs, float, math.nan)

        def get_integer(self, vrs):
            return self._get(Integer, vrs, int, 0)

        def get_boolean(self, vrs):
            return self._get(Boolean, vrs, bool, False)

        def set_real(self, vrs, values):
            self._set(Real, vrs, values)

        def set_integer(self, vrs, values):
            self._set(Integer, vrs, values)

        def set_boolean(self, vrs, values):
            self._set(Boolean, vrs, values)

    # -- stepping ---------------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float):
        """Advance from current_time by step_size [s]: True (OK) or, refused with the reasons
        logged and the state untouched, a refusal (FMI 2.0: fmi2Discard, all pythonfmu can
        return; FMI 3.0: fmi3Error for misuse and bad values, fmi3Discard for a step that
        fails numerically). Never raises: an exception here would be fmi2Fatal."""
        if self._mode != STEP or self._error:
            why = self._error or (f"not allowed in {self._mode} (only after "
                                  f"{_PREFIX}ExitInitializationMode, before {_PREFIX}Terminate)")
            self._log(f"{_PREFIX}DoStep: {why}; step refused", Status.error, CALL_STATUS_CATEGORY)
            return self._refused(misuse=True)
        saved = None
        misuse = True
        try:
            problems = self._step_problems(current_time, step_size)
            if not problems:
                # Only what a step can change: parameters and inputs change through setters.
                saved = {name: getattr(self, name) for name in self._dynamic_names()}
                saved.update({name: copy.copy(getattr(self, name)) for name in self.internal_state_names})
                problems, misuse = self._step(current_time, step_size)
        except Exception as exc:
            misuse = False
            problems = [f"numerical failure ({type(exc).__name__}: {exc}) at {self._inputs_text()}, "
                        f"h={step_size}"]
        if not problems:
            return True
        if saved is not None:
            for name, value in saved.items():
                setattr(self, name, value)
        # misuse and bad values: fmi2Error through the native loader; a numerical failure
        # stays fmi2Discard (a smaller step may succeed)
        category = CALL_STATUS_CATEGORY if misuse else None
        for problem in problems:
            self._log(f"{problem}; step refused", Status.error, category)
        return self._refused(misuse)

    @staticmethod
    def _refused(misuse: bool):
        if FMI_VERSION == 3:
            return Fmi3StepResult(status=Status.error if misuse else Status.discard)
        return False

    def _step_problems(self, current_time: float, step_size: float) -> list[str]:
        problems = self.problems()
        if not (math.isfinite(step_size) and step_size > 0):
            problems.append(f"communication step size h must be > 0 and finite, got {step_size}")
        elif not (math.isfinite(current_time) and math.isfinite(current_time + step_size)):
            problems.append(f"communication point t must be finite, got t={current_time}, h={step_size}")
        return problems

    def _step(self, t: float, h: float) -> tuple[list[str], bool]:
        """The reasons to refuse the step (none: it is taken), and whether they are bad input
        values (advance's reasons) rather than a numerical failure."""
        if not self._initialized:  # initialization was refused; the values are fine now
            self.initialize()
            self._initialized = True
        why = self.advance(t, h)
        if why:
            return [why], True
        self.time = t + h
        bad = []
        for name in self._real_outputs():
            try:
                value = self._getters[name]() if name in self._getters else getattr(self, name)
            except Exception as exc:
                value = f"<{type(exc).__name__}: {exc}>"
            else:
                if math.isfinite(value):
                    continue
            bad.append(f"{name}={value}")
        if bad:
            return [f"outputs would not be finite ({', '.join(bad)}) at {self._inputs_text()}, h={h}"], False
        return [], False

    def _real_outputs(self) -> list[str]:
        if self._real_output_names is None:
            self._real_output_names = [v.name for v in self.vars.values()
                                       if v.causality == Causality.output and isinstance(v, Real)]
        return self._real_output_names

    def _dynamic_names(self) -> list[str]:
        """Scalars advance() and initialize() may change: stored outputs, time (the internal
        state, which may be mutable, is saved apart)."""
        if self._dynamic_state_names is None:
            self._dynamic_state_names = [
                v.name for v in self.vars.values()
                if v.causality == Causality.output and v.name not in self._getters
            ] + ["time", "_initialized"]
        return self._dynamic_state_names

    def problems(self) -> list[str]:
        """Every refused value and every parameter combination the model rejects."""
        # Per-variable checks and the model's own validation often say the same thing.
        if self._model_problems is None:
            self._model_problems = self.model_problems()
        if not self._bad:
            return list(self._model_problems)
        return list(dict.fromkeys(list(self._bad.values()) + self._model_problems))

    # -- what each model provides ---------------------------------------------------
    def model_problems(self) -> list[str]:
        """Parameter problems the per-variable checks cannot see (combinations)."""
        return []

    def initialize(self) -> None:
        """Set the internal state from the parameters (after initialization mode)."""

    def changed(self, name: str) -> None:
        """Called after the host set a parameter or input (not when a state is restored).

        Caches derived from parameters should key on ``self._parameter_token`` instead."""

    def advance(self, t: float, h: float) -> str | None:
        """Advance the model from t to t + h [s]; return why the inputs cannot be stepped
        (a bad value the host must replace: the step is refused), or None."""
        raise NotImplementedError

    # -- FMU state ----------------------------------------------------------------------
    def _get_fmu_state(self) -> dict[str, Any]:
        state = {name: getattr(self, name) for name in self._scalar_names()}  # immutable values
        state.update({name: copy.copy(getattr(self, name)) for name in self.internal_state_names})
        state["_bad"] = dict(self._bad)
        state["_initialized"] = self._initialized
        state["_parameter_token"] = self._parameter_token
        state["_model"] = self._model_id
        state["_mode"] = self._mode
        state["_error"] = self._error
        return state

    _BOOKKEEPING = ("_bad", "_initialized", "_parameter_token", "_model", "_mode", "_error")

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        model = state.get("_model") if isinstance(state, dict) else None
        if model != self._model_id:
            if isinstance(state, dict) and "_invalid" in state:
                what = f"not an FMU state ({state['_invalid']})"
            elif model is None:
                what = "not an FMU state of a tribofmu model"
            else:
                what = f"an FMU state of {model}"
            self._refuse(f"Set{_STATE}", f"{what}, not of this model and build ({self._model_id}); "
                                         f"not restored", enter_error=True)
            return
        token = state.get("_parameter_token")
        same_parameters = token == self._parameter_token
        self._bad = dict(state["_bad"])
        self._initialized = bool(state["_initialized"])
        self._mode = state["_mode"]
        self._error = state["_error"]
        for name, value in state.items():
            if name in self._BOOKKEEPING:
                continue
            elif not (same_parameters and name in self._parameter_set):
                setattr(self, name, value)
        if not same_parameters:  # a state of another instance (deserialized): its parameters
            self._new_parameters(token or f"{uuid.uuid4()}:0")

    def _scalar_names(self) -> list[str]:
        if self._scalar_state_names is None:
            names = [v.name for v in self.vars.values() if v.causality != Causality.output]
            names += [v.name for v in self.vars.values()
                      if v.causality == Causality.output and v.name not in self._getters]
            self._scalar_state_names = names + ["time"]
        return self._scalar_state_names

    internal_state_names: tuple[str, ...] = ()

    # pythonfmu calls these on the class, without an instance to log to: they never raise (an
    # exception would be fmi2Fatal and release the instance); a blob that is no state
    # deserializes to a marker that setting the state refuses with the reason.
    @staticmethod
    def _fmu_state_to_bytes(state: Any) -> bytes:
        try:
            return json.dumps(state).encode("utf-8")
        except Exception as exc:
            return json.dumps({"_invalid": f"{type(exc).__name__}: {exc}"}).encode("utf-8")

    @staticmethod
    def _fmu_state_from_bytes(blob: bytes) -> Any:
        try:
            state = json.loads(blob.decode("utf-8"))
        except Exception as exc:
            return {"_invalid": f"cannot be deserialized: {type(exc).__name__}: {exc}"}
        return state if isinstance(state, dict) else {"_invalid": "not an FMU state"}

    # -- modelDescription.xml ---------------------------------------------------------
    def to_xml(self, model_options: dict[str, str] = dict()) -> Element:
        self._describing = True  # pythonfmu reads each start value through the getters
        try:
            root = super().to_xml(model_options)
        finally:
            self._describing = False
        units = sorted(set(self._units.values()))
        unit_defs = Element("UnitDefinitions")
        for unit in units:
            SubElement(unit_defs, "Unit", name=unit)
        # UnitDefinitions precede LogCategories in the FMI 2.0 and 3.0 schema order.
        position = list(root).index(root.find("CoSimulation")) + 1
        root.insert(position, unit_defs)
        if FMI_VERSION == 3:
            self._fmi3_variables_and_structure(root)
        else:
            self._fmi2_variables_and_structure(root)
        return root

    def _fmi2_variables_and_structure(self, root: Element) -> None:
        index = {v.name: i + 1 for i, v in enumerate(self.vars.values())}
        for node in root.find("ModelVariables"):
            name = node.get("name")
            real = node.find("Real")
            if real is not None and name in self._units:
                real.set("unit", self._units[name])
            var = next(v for v in self.vars.values() if v.name == name)
            if var.causality == Causality.output:
                for child in node:
                    child.attrib.pop("start", None)  # initial="calculated" forbids a start
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        outputs = [v for v in self.vars.values() if v.causality == Causality.output]
        if outputs:
            out_node = SubElement(structure, "Outputs")
            init_node = SubElement(structure, "InitialUnknowns")
            for v in outputs:
                deps = " ".join(str(index[d]) for d in self._depends_on[v.name])
                SubElement(out_node, "Unknown", index=str(index[v.name]), dependencies=deps)
                # No dependencies attribute: initially an output may depend on anything.
                SubElement(init_node, "Unknown", index=str(index[v.name]))

    def _fmi3_variables_and_structure(self, root: Element) -> None:
        # FMI 3.0 names variables by valueReference (no indices), types are elements of their own.
        reference = {v.name: v.value_reference for v in self.vars.values()}
        for node in root.find("ModelVariables"):
            name = node.get("name")
            if node.tag == "Float64" and name in self._units:
                node.set("unit", self._units[name])
            if name in reference and self.vars[reference[name]].causality == Causality.output:
                node.attrib.pop("start", None)  # initial="calculated" forbids a start
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        outputs = [v for v in self.vars.values() if v.causality == Causality.output]
        for v in outputs:
            deps = " ".join(str(reference[d]) for d in self._depends_on[v.name])
            SubElement(structure, "Output", valueReference=str(v.value_reference), dependencies=deps)
        for v in outputs:
            # No dependencies attribute: initially an output may depend on anything.
            SubElement(structure, "InitialUnknown", valueReference=str(v.value_reference))


def positive(value: float) -> str | None:
    return None if value > 0 else f"must be > 0, got {value}"


def non_negative(value: float) -> str | None:
    return None if value >= 0 else f"must be >= 0, got {value}"
