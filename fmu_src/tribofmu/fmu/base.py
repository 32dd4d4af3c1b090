"""The shared framework of the tribofmu FMUs: a thin layer over pythonfmu's ``Fmi2Slave``
(FMI 2.0) or pythonfmu3's ``Fmi3Slave`` (FMI 3.0), chosen at build time by
:data:`.fmi_version.FMI_VERSION`; the adapters import everything FMI-specific from here, so
the same adapter files build for both versions.

Each FMU script declares its variables with :meth:`TriboModel.declare` and implements
:meth:`TriboModel.advance`. This module is the one place that

- writes what pythonfmu 0.7 leaves out of ``modelDescription.xml``: units, ``initial``
  attributes, ``InitialUnknowns`` and the output dependencies of ``ModelStructure``;
- turns bad values into FMI statuses a host can act on. pythonfmu maps any Python
  exception to ``fmi2Fatal`` (the instance is lost) and ``do_step`` returning False to
  ``fmi2Discard``. So setters never raise: a NaN input or an out-of-range parameter is
  recorded, ``do_step`` logs it with category ``logStatusError`` naming the variable and
  value, and returns ``fmi2Discard``; the host can set a valid value and step again.
  A step is all or nothing: a refused step (bad value, numerical failure, non-finite
  outputs) leaves the state as it was. Getters never raise either (an output that cannot
  be evaluated reads as NaN, with a warning);
- saves and restores the complete state (variables plus the model's internal state), so
  get/set and serialize/deserialize FMU state continue bit-identically.

No physics here: the models live in :mod:`tribofmu.physics`.
"""
from __future__ import annotations

import copy
import math
import uuid
from typing import Any, Callable, Iterable
from xml.etree.ElementTree import Element, SubElement

from .fmi_version import FMI_VERSION

if FMI_VERSION == 3:
    from pythonfmu3 import Boolean, Fmi3Causality as Causality, Fmi3Slave as _PythonFMUSlave
    from pythonfmu3 import Fmi3Variability as Variability, Float64 as Real, Int32 as Integer
    from pythonfmu3.default_experiment import DefaultExperiment
    from pythonfmu3.enums import Fmi3Initial as Initial, Fmi3Status as Status
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


class TriboModel(_PythonFMUSlave):
    """Base of every tribofmu FMU: declare variables, implement :meth:`advance`."""

    author = AUTHOR
    license = LICENSE
    version = VERSION

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

    def _setter(self, name: str, kind: type, is_parameter: bool) -> Callable[[Any], None]:
        def setter(value: Any) -> None:
            value = kind(value)
            if kind is float and not math.isfinite(value):
                why = f"must be finite, got {value}"
            else:
                check = self._checks.get(name)
                why = check(value) if check else None
            if why:
                self._bad[name] = f"{name} {why}"
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
            try:
                return getter()
            except Exception as exc:
                self._log(f"{name} cannot be evaluated ({type(exc).__name__}: {exc}) "
                          f"at {self._inputs_text()}; reads as NaN", Status.warning)
                return math.nan
        return get

    def _log(self, msg: str, status: Status) -> None:
        text = f"{self.instance_name}: {msg}"
        if FMI_VERSION == 2:
            # pythonfmu hands the text to the host's logger as its printf format string
            # (FMI 2.0 says the message is one): an unescaped "%s", e.g. from a host-chosen
            # instance name, makes a formatting host read arguments that are not there.
            # FMI 3.0's logMessage takes plain text: nothing to escape.
            text = text.replace("%", "%%")
        self.log(text, status)

    def _inputs_text(self) -> str:
        names = [v.name for v in self.vars.values() if v.causality == Causality.input]
        return ", ".join(f"{n}={getattr(self, n)}" for n in names) or "no inputs"

    # -- stepping ---------------------------------------------------------------------
    def setup_experiment(self, start_time: float, stop_time=None, tolerance=None) -> None:
        self.time = start_time

    def exit_initialization_mode(self) -> None:
        try:
            problems = self.problems()
            if not problems:
                self.initialize()
                self._initialized = True
        except Exception as exc:  # would be fmi2Fatal; do_step reports it again and refuses
            problems = [f"initialization failed ({type(exc).__name__}: {exc})"]
        for problem in problems:
            self._log(problem, Status.error)

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Advance from current_time by step_size [s]: True (fmi2OK) or, refused with the
        reasons logged and the state untouched, False (fmi2Discard). Never raises: an
        exception here would be fmi2Fatal."""
        saved = None
        try:
            problems = self._step_problems(current_time, step_size)
            if not problems:
                # Only what a step can change: parameters and inputs change through setters.
                saved = {name: getattr(self, name) for name in self._dynamic_names()}
                saved.update({name: copy.copy(getattr(self, name)) for name in self.internal_state_names})
                problems = self._step(current_time, step_size)
        except Exception as exc:
            problems = [f"numerical failure ({type(exc).__name__}: {exc}) at {self._inputs_text()}, "
                        f"h={step_size}"]
        if not problems:
            return True
        if saved is not None:
            for name, value in saved.items():
                setattr(self, name, value)
        for problem in problems:
            self._log(f"{problem}; step refused", Status.error)
        return False

    def _step_problems(self, current_time: float, step_size: float) -> list[str]:
        problems = self.problems()
        if not (math.isfinite(step_size) and step_size > 0):
            problems.append(f"communication step size h must be > 0 and finite, got {step_size}")
        elif not (math.isfinite(current_time) and math.isfinite(current_time + step_size)):
            problems.append(f"communication point t must be finite, got t={current_time}, h={step_size}")
        return problems

    def _step(self, t: float, h: float) -> list[str]:
        if not self._initialized:  # initialization was refused; the values are fine now
            self.initialize()
            self._initialized = True
        why = self.advance(t, h)
        if why:
            return [why]
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
            return [f"outputs would not be finite ({', '.join(bad)}) at {self._inputs_text()}, h={h}"]
        return []

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
        """Advance the model from t to t + h [s]; return a reason to refuse the step, or None."""
        raise NotImplementedError

    # -- FMU state ----------------------------------------------------------------------
    def _get_fmu_state(self) -> dict[str, Any]:
        state = {name: getattr(self, name) for name in self._scalar_names()}  # immutable values
        state.update({name: copy.copy(getattr(self, name)) for name in self.internal_state_names})
        state["_bad"] = dict(self._bad)
        state["_initialized"] = self._initialized
        state["_parameter_token"] = self._parameter_token
        return state

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        token = state.get("_parameter_token")
        same_parameters = token == self._parameter_token
        for name, value in state.items():
            if name == "_bad":
                self._bad = dict(value)
            elif name == "_initialized":
                self._initialized = bool(value)
            elif name == "_parameter_token":
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

    # -- modelDescription.xml ---------------------------------------------------------
    def to_xml(self, model_options: dict[str, str] = dict()) -> Element:
        root = super().to_xml(model_options)
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
