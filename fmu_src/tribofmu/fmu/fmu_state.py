"""Saving and restoring the complete state of a :class:`.base.TriboModel` (variables plus the
model's internal state), so get/set and serialize/deserialize FMU state continue
bit-identically; a state names the model and build it came from, and one of another model or
build is refused."""
from __future__ import annotations

import copy
import functools
import json
import operator
import uuid
from typing import Any, Callable, Sequence

from .fmi import (_STATE, INITIALIZATION, INSTANTIATED, STEP, TERMINATED, Boolean, Causality, Integer,
                  Real)


def parameter_cached(method):
    """A model's method of no argument whose answer depends on the parameters alone (a law, a
    program, the parameters' values in a state): made once, and again only after a parameter
    changed (``_parameter_token``)."""
    slot = f"_cached_{method.__name__}"

    @functools.wraps(method)
    def cached(self):
        token, value = getattr(self, slot, (None, None))
        if token != self._parameter_token:
            token, value = self._parameter_token, method(self)
            setattr(self, slot, (token, value))
        return value
    return cached


def attribute_reader(names: Sequence[str]) -> Callable[[Any], tuple]:
    """A function reading the attributes ``names`` of an object as a tuple, in this order: one
    C call (``operator.attrgetter``), for what is read on every step or state save."""
    if len(names) > 1:
        return operator.attrgetter(*names)
    if names:  # (attrgetter of one name gives the value itself, not a tuple of one)
        read = operator.attrgetter(names[0])
        return lambda model: (read(model),)
    return lambda model: ()


class OwnState:
    """An FMU state as :meth:`FMUStateMixin._get_fmu_state` took it, in this process: what the
    state's variables hold (inputs, stored outputs, time) and the model's internal state, in
    the model's own order, with the bookkeeping beside. A master takes and restores states
    thousands of times a run (fig6's default call: every FMU saves at each accepted step, the
    friction FMU restores 1.8 times a step), so a save copies only what a step or a setter can
    change: the parameters are fixed once initialization ends, and a state refers to the one
    dict of their values that every state of the same parameter set shares (never changed: a
    setter makes a new one). Every value is one this model wrote, so restoring needs none of
    the checks a state deserialized from bytes (a plain dict, :meth:`as_dict`'s form) gets."""

    __slots__ = ("parameters", "names", "values", "internal_names", "internal", "bad", "initialized",
                 "token", "model", "mode", "error")

    def __init__(self, parameters, names, values, internal_names, internal, bad, initialized, token,
                 model, mode, error):
        self.parameters, self.names, self.values = parameters, names, values
        self.internal_names, self.internal = internal_names, internal
        self.bad, self.initialized, self.token = bad, initialized, token
        self.model, self.mode, self.error = model, mode, error

    def as_dict(self) -> dict[str, Any]:
        """The state as a plain dict: the form serialized to bytes and restored with checks."""
        state = dict(self.parameters)
        state.update(zip(self.names, self.values))
        state.update(zip(self.internal_names, self.internal))
        state.update(_bad=dict(self.bad), _initialized=self.initialized, _parameter_token=self.token,
                     _model=self.model, _mode=self.mode, _error=self.error)
        return state


_NO_PROBLEMS: dict[str, str] = {}  # the refused values of a state that has none (never changed)


def _not_ours(state: Any, model: str | None) -> str:
    """What a state that another model or build made (or no model) is, for the refusal."""
    if isinstance(state, dict) and "_invalid" in state:
        return f"not an FMU state ({state['_invalid']})"
    if model is None:
        return "not an FMU state of a tribofmu model"
    return f"an FMU state of {model}"


class FMUStateMixin:
    """The FMU-state calls of :class:`.base.TriboModel`."""

    def _get_fmu_state(self) -> OwnState:
        names = self._variable_state_names or self._variable_names()
        internal_names = self.internal_state_names
        read_internal = (self._step_state_readers or self._step_state_reader())[1]
        return OwnState(self._parameter_values(), names, self._variable_values(self),
                        internal_names, tuple(map(copy.copy, read_internal(self))) if internal_names else (),
                        dict(self._bad) if self._bad else _NO_PROBLEMS, self._initialized,
                        self._parameter_token, self._model_id, self._mode, self._error)

    _BOOKKEEPING = ("_bad", "_initialized", "_parameter_token", "_model", "_mode", "_error")

    def _set_fmu_state(self, state: Any) -> None:
        own = type(state) is OwnState
        model = state.model if own else (state.get("_model") if isinstance(state, dict) else None)
        if model != self._model_id:
            self._refuse(f"Set{_STATE}", f"{_not_ours(state, model)}, not of this model and build "
                                         f"({self._model_id}); not restored", enter_error=True)
            return
        if own:
            # taken by this model and build in this process: its values are right, and
            # setting them cannot fail
            self._restore_own(state)
            return
        why = self._state_problem(state)
        if why is None:
            before = self._get_fmu_state()
            try:
                self._apply_fmu_state(state)
            except Exception as exc:  # a value the model cannot take: back to where it was
                why = f"{type(exc).__name__}: {exc}"
                try:
                    self._apply_fmu_state(before.as_dict(), every_value=True)
                except Exception as again:  # cannot happen for a state just taken; say so if it does
                    why += f"; restoring the previous state failed too ({type(again).__name__}: {again})"
        if why is not None:
            self._refuse(f"Set{_STATE}", f"a damaged FMU state of this model ({why}); not restored",
                         enter_error=True)

    def _restore_own(self, state: OwnState) -> None:
        self._output_values.clear()  # (_forget_outputs, inline: the hot path of a master)
        self._bad = dict(state.bad) if state.bad else {}
        self._initialized, self._mode, self._error = state.initialized, state.mode, state.error
        same_parameters = state.token == self._parameter_token
        if not same_parameters:  # e.g. a state taken before a reset: its parameters first
            for name, value in state.parameters.items():
                setattr(self, name, value)
        for name, value in zip(state.names, state.values):
            setattr(self, name, value)
        for name, value in zip(state.internal_names, state.internal):
            setattr(self, name, value)
        if not same_parameters:
            self._new_parameters(state.token)

    def _state_problem(self, state: dict[str, Any]) -> str | None:
        """Why a state that names this model cannot be one this model made (keys, types)."""
        expected = set(self._scalar_names()) | set(self.internal_state_names) | set(self._BOOKKEEPING)
        missing, unknown = expected - state.keys(), state.keys() - expected
        if missing or unknown:
            parts = [f"lacks {', '.join(sorted(missing))}" if missing else "",
                     f"has unknown {', '.join(sorted(map(str, unknown)))}" if unknown else ""]
            return " and ".join(p for p in parts if p)
        if not isinstance(state["_bad"], dict) or not isinstance(state["_initialized"], bool):
            return "its bookkeeping is not of the right types"
        if state["_mode"] not in (INSTANTIATED, INITIALIZATION, STEP, TERMINATED):
            return f"unknown mode {state['_mode']!r}"
        if not (state["_error"] is None or isinstance(state["_error"], str)):
            return "its error entry is not text"
        if not isinstance(state["_parameter_token"], str):
            return "its parameter token is not text"
        for var in self.vars.values():
            value = state.get(var.name)
            if var.name in state and not self._state_value_ok(var, value):
                return f"{var.name} = {value!r} is not a value of its type"
        if not isinstance(state["time"], (int, float)) or isinstance(state["time"], bool):
            return f"time = {state['time']!r} is not a number"
        return None

    @staticmethod
    def _state_value_ok(var, value: Any) -> bool:
        if isinstance(var, Real):  # JSON keeps NaN and inf; ints are whole floats
            return isinstance(value, (int, float)) and not isinstance(value, bool)
        if isinstance(var, Boolean):
            return isinstance(value, bool)
        if isinstance(var, Integer):
            return isinstance(value, int) and not isinstance(value, bool)
        return True

    def _apply_fmu_state(self, state: dict[str, Any], every_value: bool = False) -> None:
        self._forget_outputs()
        token = state.get("_parameter_token")
        same_parameters = token == self._parameter_token and not every_value
        self._bad = dict(state["_bad"])
        self._initialized = bool(state["_initialized"])
        self._mode = state["_mode"]
        self._error = state["_error"]
        for name, value in state.items():
            if name in self._BOOKKEEPING:
                continue
            elif not (same_parameters and name in self._parameter_set):
                setattr(self, name, value)
        if token != self._parameter_token:  # a state of another instance (deserialized): its parameters
            self._new_parameters(token or f"{uuid.uuid4()}:0")

    @parameter_cached
    def _parameter_values(self) -> dict[str, Any]:
        """The parameters' values, taken once per parameter set and shared by every state taken
        with it (never changed): a state holds them all, but they change only through their
        setters."""
        return {name: getattr(self, name) for name in self._parameter_names}

    _variable_state_names: list[str] | None = None
    _variable_values: Callable[[Any], tuple] | None = None

    def _variable_names(self) -> list[str]:
        """The scalars of a state other than the parameters (inputs, stored outputs, time);
        ``_variable_values(self)`` reads them, in this order, as a tuple."""
        names = self._variable_state_names
        if names is None:
            names = self._variable_state_names = [n for n in self._scalar_names() if n not in self._parameter_set]
            self._variable_values = attribute_reader(names)
        return names

    # -- what a step may change: saved before it, restored where it is refused ----------------
    _step_scalar_names: list[str] | None = None
    _step_state_readers: tuple[Callable[[Any], tuple], Callable[[Any], tuple]] | None = None

    def _save_step_state(self) -> tuple[tuple, tuple]:
        """What advance() and initialize() may change: the stored outputs, time, whether
        initialized, and the internal state (copied: it may be mutable). Parameters and inputs
        change through their setters only."""
        read_scalars, read_internal = self._step_state_readers or self._step_state_reader()
        return read_scalars(self), (tuple(map(copy.copy, read_internal(self))) if self.internal_state_names else ())

    def _restore_step_state(self, saved: tuple[tuple, tuple]) -> None:
        """Back to what :meth:`_save_step_state` saved (a refused step)."""
        scalars, internal = saved
        for name, value in zip(self._step_scalar_names, scalars):
            setattr(self, name, value)
        for name, value in zip(self.internal_state_names, internal):
            setattr(self, name, value)

    def _step_state_reader(self) -> tuple[Callable[[Any], tuple], Callable[[Any], tuple]]:
        self._step_scalar_names = [v.name for v in self.vars.values()
                                   if v.causality == Causality.output and v.name not in self._getters]
        self._step_scalar_names += ["time", "_initialized"]
        self._step_state_readers = (attribute_reader(self._step_scalar_names),
                                    attribute_reader(self.internal_state_names))
        return self._step_state_readers

    def _scalar_names(self) -> list[str]:
        if self._scalar_state_names is None:
            names = [v.name for v in self.vars.values() if v.causality != Causality.output]
            names += [v.name for v in self.vars.values()
                      if v.causality == Causality.output and v.name not in self._getters]
            # (FMI 3.0 declares time as a variable; FMI 2.0 keeps it beside them)
            self._scalar_state_names = list(dict.fromkeys(names + ["time"]))
        return self._scalar_state_names

    internal_state_names: tuple[str, ...] = ()

    # pythonfmu calls these on the class, without an instance to log to: they never raise (an
    # exception would be fmi2Fatal and release the instance); a blob that is no state
    # deserializes to a marker that setting the state refuses with the reason.
    @staticmethod
    def _fmu_state_to_bytes(state: Any) -> bytes:
        try:
            return json.dumps(state.as_dict() if type(state) is OwnState else state).encode("utf-8")
        except Exception as exc:
            return json.dumps({"_invalid": f"{type(exc).__name__}: {exc}"}).encode("utf-8")

    @staticmethod
    def _fmu_state_from_bytes(blob: bytes) -> Any:
        try:
            state = json.loads(blob.decode("utf-8"))
        except Exception as exc:
            return {"_invalid": f"cannot be deserialized: {type(exc).__name__}: {exc}"}
        return state if isinstance(state, dict) else {"_invalid": "not an FMU state"}
