"""The shared framework of the tribofmu FMUs: a thin layer over pythonfmu's ``Fmi2Slave``
(FMI 2.0) or pythonfmu3's ``Fmi3Slave`` (FMI 3.0), chosen at build time by
:data:`.fmi_version.FMI_VERSION`; the adapters import everything FMI-specific from here, so
the same adapter files build for both versions.

Each FMU script declares its variables with :meth:`TriboModel.declare` and implements
:meth:`TriboModel.advance`. This module, with the mixins beside it, is the one place that

- writes what pythonfmu 0.7 leaves out of ``modelDescription.xml`` and takes the start values
  from the FMU's own description (:mod:`.description`);
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
is the state table of docs/hosts.md. A step is all or nothing: a refused step (bad value, numerical
failure, non-finite outputs) leaves the state as it was.

- saves and restores the complete state (:mod:`.fmu_state`);
- computes an output declared with a getter once per state: where doStep checks that its
  outputs are finite, or where a host first reads it after a set or a restore; the value is
  kept until a doStep, a set or a restore changes what it is computed from.

No physics here: the models live in :mod:`tribofmu.physics`.
"""
from __future__ import annotations

import functools
import math
import uuid
from typing import Any, Callable, Iterable

from .description import ModelDescriptionMixin, _parse_start, _start_values
# the adapters import the FMI names they declare with from here (DefaultExperiment, the causalities)
from .fmi import (_KINDS, _PREFIX, AUTHOR, CALL_STATUS_CATEGORY, FMI_VERSION, INITIALIZATION,
                  INPUT, INSTANTIATED, LICENSE, OUTPUT, PARAMETER, STEP, TERMINATED, VERSION,
                  Causality, DefaultExperiment, Initial, Real, Status, Variability, _PythonFMUSlave)
from .fmu_state import FMUStateMixin, attribute_reader
from .values import ValueAccessMixin

if FMI_VERSION == 3:  # fmi.py has it from pythonfmu3 only
    from .fmi import Fmi3StepResult

__all__ = ["TriboModel", "DefaultExperiment", "PARAMETER", "INPUT", "OUTPUT", "positive", "non_negative"]


class TriboModel(ValueAccessMixin, FMUStateMixin, ModelDescriptionMixin, _PythonFMUSlave):
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
        # The values those outputs have for the present state, inputs and parameters: each is
        # computed once, where doStep checks it or a host reads it first, and forgotten by
        # every call that changes what it is computed from (_forget_outputs).
        self._output_values: dict[str, Any] = {}
        self._initialized = False  # initialize() ran (it is skipped while values are bad)
        # caches (variables are declared once): the Real outputs' getters, and how the finite
        # check reads them (_output_checks)
        self._real_output_getters: list | None = None
        self._output_check_readers: tuple | None = None
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
        else:  # the attribute, read in C (pythonfmu's own getter is a Python lambda)
            kwargs["getter"] = functools.partial(getattr, self, name)
            if causality == Causality.output:
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

    def _parameters_changed(self, name: str) -> None:
        uid, count = self._parameter_token.rsplit(":", 1)
        self._new_parameters(f"{uid}:{int(count) + 1}")
        self.changed(name)

    def _new_parameters(self, token: str) -> None:
        """Parameter values changed: drop what was derived from them."""
        self._model_problems = None
        self._parameter_token = token

    def _forget_outputs(self) -> None:
        """The state, an input or a parameter changed: the outputs are computed again when read."""
        self._output_values.clear()

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
            self._forget_outputs()

    def enter_initialization_mode(self) -> None:
        if self._in_mode("EnterInitializationMode", INSTANTIATED):
            self._mode = INITIALIZATION

    def exit_initialization_mode(self) -> None:
        if not self._in_mode("ExitInitializationMode", INITIALIZATION):
            return
        self._mode = STEP
        self._forget_outputs()  # initialize() sets the state
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
        self._output_values.clear()  # (_forget_outputs, inline: the hot path of a master)
        saved = None
        misuse = True
        try:
            problems = self._step_problems(current_time, step_size)
            if not problems:
                saved = self._save_step_state()
                problems, misuse = self._step(current_time, step_size)
        except Exception as exc:
            misuse = False
            problems = [f"numerical failure ({type(exc).__name__}: {exc}) at {self._inputs_text()}, "
                        f"h={step_size}"]
        if not problems:
            return True
        if saved is not None:
            self._restore_step_state(saved)
        self._forget_outputs()  # the check may have kept values of the state just undone
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
        # (no refused value and a parameter set found good: no problems() to copy, every step)
        problems = self.problems() if self._bad or self._model_problems != [] else []
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
        # A step whose outputs would not be finite is refused (all or nothing), so each output
        # is computed here; what is computed is kept for the host's reads of this state.
        if self._outputs_finite():
            return [], False
        return self._output_problems(h), False

    def _outputs_finite(self) -> bool:
        """Whether every Real output is finite, each computed one kept: the common case,
        checked with the least work (stored values read at once); False where any is not, or
        raises, for :meth:`_output_problems` to name."""
        getters, read_stored = self._output_check_readers or self._output_checks()
        computed = self._output_values
        try:
            for name, getter in getters:
                value = getter()
                if not math.isfinite(value):
                    return False
                computed[name] = value
            return all(map(math.isfinite, read_stored(self)))
        except Exception:
            return False

    def _output_problems(self, h: float) -> list[str]:
        """Why the outputs refuse the step: each output that is not finite or raises, named
        (none: every output is finite, each computed one kept)."""
        bad = []
        computed = self._output_values
        for name, getter in self._real_output_getters or self._real_outputs():
            try:
                value = getter() if getter is not None else getattr(self, name)
            except Exception as exc:
                value = f"<{type(exc).__name__}: {exc}>"
            else:
                if math.isfinite(value):
                    if getter is not None:
                        computed[name] = value
                    continue
            bad.append(f"{name}={value}")
        if bad:
            return [f"outputs would not be finite ({', '.join(bad)}) at {self._inputs_text()}, h={h}"]
        return []

    def _real_outputs(self) -> list[tuple[str, Callable[[], Any] | None]]:
        """Each Real output's name and its getter (None: a stored value)."""
        if self._real_output_getters is None:
            self._real_output_getters = [(v.name, self._getters.get(v.name)) for v in self.vars.values()
                                         if v.causality == Causality.output and isinstance(v, Real)]
        return self._real_output_getters

    def _output_checks(self) -> tuple[list[tuple[str, Callable[[], Any]]], Callable[[Any], tuple]]:
        """The Real outputs' getters by name, and the reader of the stored ones' values."""
        outputs = self._real_outputs()
        self._output_check_readers = ([(name, getter) for name, getter in outputs if getter is not None],
                                      attribute_reader([name for name, getter in outputs if getter is None]))
        return self._output_check_readers

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

        Caches derived from parameters use :func:`.fmu_state.parameter_cached` instead (keyed on
        ``self._parameter_token``, which a restored state sets too)."""

    def advance(self, t: float, h: float) -> str | None:
        """Advance the model from t to t + h [s]; return why the inputs cannot be stepped
        (a bad value the host must replace: the step is refused), or None."""
        raise NotImplementedError

def positive(value: float) -> str | None:
    return None if value > 0 else f"must be > 0, got {value}"


def non_negative(value: float) -> str | None:
    return None if value >= 0 else f"must be >= 0, got {value}"
