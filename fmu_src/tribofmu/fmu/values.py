"""The typed getters and setters of :class:`.base.TriboModel` (FMI 2.0 ``fmi2GetReal`` ...,
FMI 3.0 ``fmi3GetFloat64`` ...): an unknown value reference, a variable of another type, an
output or a fixed parameter after initialization is refused by name, never a crash. Also each
variable's own setter (checks the value) and computed output's getter (computes it once per
state, never raises), which :meth:`.base.TriboModel.declare` gives pythonfmu."""
from __future__ import annotations

import math
from typing import Any, Callable

from .fmi import (_KINDS, _PREFIX, _TYPE_NAMES, CALL_STATUS_CATEGORY, FMI_VERSION, INSTANTIATED, STEP,
                  TERMINATED, Boolean, Causality, Integer, Real, Status, String, UInt64, Variability)

_UNKNOWN = object()  # an output not computed for the present state


class ValueAccessMixin:
    """Get and set by value reference, for every FMI type the models declare."""

    # value reference -> setter of each Real input, getter of each Real variable: made on
    # first use in step mode (every variable is declared by then)
    _real_input_setter_cache: dict | None = None
    _real_getter_cache: dict | None = None

    # -- each variable's setter and computed getter (declared with TriboModel.declare) --------
    def _value_problem(self, name: str, kind: type, value: Any) -> str | None:
        if kind is float and not math.isfinite(value):
            return f"must be finite, got {value}"
        check = self._checks.get(name)
        return check(value) if check else None

    def _setter(self, name: str, kind: type, is_parameter: bool) -> Callable[[Any], None]:
        def setter(value: Any) -> None:
            value = kind(value)
            # (_forget_outputs, inline: the hot path of a master) even for a refused value:
            # the outputs read as refused now
            self._output_values.clear()
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
            elif self._bad:
                self._bad.pop(name, None)
            setattr(self, name, value)
            if is_parameter:
                self._parameters_changed(name)
            else:
                self.changed(name)
        return setter

    def _safe_getter(self, name: str, getter: Callable[[], Any]) -> Callable[[], Any]:
        # An exception escaping a getter would make fmi2GetReal return fmi2Fatal.
        def get() -> Any:
            value = self._output_values.get(name, _UNKNOWN)
            if value is not _UNKNOWN:
                return value
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
            else:  # a refusal is not kept: every read of it logs it again
                self._output_values[name] = value
            return value
        return get

    # -- by value reference ----------------------------------------------------------------
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

    def _real_input_setters(self) -> dict[int, Callable[[Any], None]]:
        """Value reference -> setter of every Real input (variables are declared once)."""
        setters = self._real_input_setter_cache
        if setters is None:
            setters = self._real_input_setter_cache = {
                vr: var.setter for vr, var in self.vars.items()
                if isinstance(var, Real) and var.causality == Causality.input and var.setter is not None}
        return setters

    def _real_getters(self) -> dict[int, Callable[[], Any]]:
        """Value reference -> getter of every Real variable."""
        getters = self._real_getter_cache
        if getters is None:
            getters = self._real_getter_cache = {vr: var.getter for vr, var in self.vars.items()
                                                 if isinstance(var, Real)}
        return getters

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
                self._refuse(call, f"{what}; reads as {missing!r}")
                values.append(missing)
            else:
                values.append(cast(var.getter()))
        return values


def _accessors(kind: type, cast: Callable[[Any], Any], missing: Any):
    """The getter and setter of one FMI type, by value reference."""
    if kind is Real:
        return _get_reals, _set_reals

    def get(self, vrs):
        return self._get(kind, vrs, cast, missing)

    def set(self, vrs, values):
        self._set(kind, vrs, values)
    return get, set


def _get_reals(self, vrs) -> list:
    if self._mode == STEP:
        # the hot path of a master: known Real variables read in step mode need none of the
        # checks of _get
        getters = self._real_getter_cache or self._real_getters()
        try:
            chosen = [getters[vr] for vr in vrs]
        except KeyError:  # not all Real variables: _get refuses the others by name
            pass
        else:
            return [float(getter()) for getter in chosen]
    return self._get(Real, vrs, float, math.nan)


def _set_reals(self, vrs, values) -> None:
    if self._mode == STEP:
        # the hot path of a master (inputs between steps): a Real input passes every check
        # of _may_not_set in step mode, so its setter (which still checks the value) is
        # called straight away; anything else takes the checked path of _set
        setters = self._real_input_setter_cache or self._real_input_setters()
        try:
            chosen = [setters[vr] for vr in vrs]
        except KeyError:  # not all Real inputs
            pass
        else:
            for setter, value in zip(chosen, values):
                setter(value)
            return
    self._set(Real, vrs, values)


# The typed calls by the suffix of pythonfmu's (FMI 2.0) or pythonfmu3's (FMI 3.0) method:
# (variable type, Python type of a value read, what a refused read gives). The models declare
# no String (nor UInt64) variable: pythonfmu's own versions raise on any other type, which is
# fmi2Fatal/fmi3Fatal (the instance lost); these refuse by name.
_TYPED_CALLS = {("float64" if FMI_VERSION == 3 else "real"): (Real, float, math.nan),
                ("int32" if FMI_VERSION == 3 else "integer"): (Integer, int, 0),
                "boolean": (Boolean, bool, False),
                "string": (String, str, "")}
if FMI_VERSION == 3:
    _TYPED_CALLS["uint64"] = (UInt64, int, 0)
for _suffix, (_kind, _cast, _missing) in _TYPED_CALLS.items():
    for _name, _method in zip(("get_", "set_"), _accessors(_kind, _cast, _missing)):
        _method.__name__ = _method.__qualname__ = _name + _suffix
        setattr(ValueAccessMixin, _name + _suffix, _method)
