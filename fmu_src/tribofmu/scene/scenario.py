"""Scenarios: a TOML file parsed into frozen dataclasses (SI units), with ``--set`` overrides.

A scenario names the FMUs it uses, their parameters, the constant conditions ``n`` and ``T``,
the time span (in drive periods, so ``--set drive.omega=80`` still covers the same number of
periods) and its figures. Every error is a :class:`ScenarioError` whose one-line message names
the file, the key and the value.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, make_dataclass, replace
from pathlib import Path
from typing import Any

from ..coupling.algorithms import ALGORITHMS
from ..errors import ScenarioError
from ..physics.block import BlockParams
from ..physics.drive import DriveParams
from ..physics.friction import START_F, Conditions, Effects, FrictionLaw, LubricantConstants
from ..physics.laws import LAWS, law_class, law_fields, make_law, regime_problem
from ..physics.load import PROGRAMS, LoadProgram
from ..physics.parameters import declared, display_unit
from ..physics.thermal import ThermalParams
from .scenario_file import _number, _short, _text_problem, one_toml_value, read_scenario_text
from .wiring import scene_problems

# What a scene lists when it does not say: the paper's rig, n and T held constant.
DEFAULT_FMUS = ("Drive", "BlockSpring", "Friction")


def _fields(parameters) -> list:
    """A scene table's fields for declared parameters, their defaults the declarations'."""
    return [(p.name, type(p.default), field(default=p.default)) for p in parameters]


def _table(name: str, table_fields: list, doc: str, **methods) -> type:
    """A scene table's frozen dataclass (picklable: named in this module)."""
    return make_dataclass(name, table_fields, frozen=True,
                          namespace={"__module__": __name__, "__qualname__": name, "__doc__": doc, **methods})


def _law(self) -> FrictionLaw:
    """The law object of ``regime`` (KeyError for an unknown name: :func:`validate` says so)."""
    return make_law(self.regime, **{f.name: getattr(self, f.name) for f in fields(self) if f.name != "regime"})


# [friction]: the regime's name, every law's parameters (a law reads those of its keys) and f0;
# the lubricant's constants are friction.* keys too, the switches the [effects] table.
_LAW_FIELDS = law_fields()
FrictionParams = _table(
    "FrictionParams",
    [("regime", str, field(default="dry")),  # a name of tribofmu.physics.laws.LAWS
     *_fields((*_LAW_FIELDS, START_F)),
     ("lubricant", LubricantConstants, field(default_factory=LubricantConstants)),
     ("effects", Effects, field(default_factory=Effects))],
    "[friction]: the law's name (regime), every law's parameters and f0, the lubricant, the switches.", law=_law)


@dataclass(frozen=True)
class ThermalTable(ThermalParams):
    """[thermal]: the Thermal FMU's heat balance C dT/dt = q F (V - v) - G (T - T_ambient), its
    parameters those of :class:`~tribofmu.physics.thermal.ThermalParams`; the film starts at
    conditions.T."""

    def params(self) -> ThermalParams:
        """The heat balance's parameters (the table is them)."""
        return self


def _program(self) -> LoadProgram:
    """The program of the Load FMU (its code for the name)."""
    return LoadProgram(program=PROGRAMS[self.program],
                       **{p.name: getattr(self, p.name) for p in declared(LoadProgram)[1:]})


# [load]: the Load FMU's normal-stress program n(t), named (constant | ramp | step | sine) where
# the FMU takes its code; replaces conditions.n. See :mod:`tribofmu.physics.load`.
LoadTable = _table("LoadTable", [("program", str, field(default="constant")), *_fields(declared(LoadProgram)[1:])],
                   "[load]: the Load FMU's normal-stress program n(t); replaces conditions.n.", program_=_program)


# The unit of each scene key a user sweeps or sets (for axis labels): the declarations', and
# those of the keys that are no physics parameter.
UNITS = {**{f"{table}.{p.name}": display_unit(p.unit) for table, parameters in (
            ("drive", declared(DriveParams)), ("block", declared(BlockParams)),
            ("friction", (*_LAW_FIELDS, START_F, *declared(LubricantConstants))),
            ("conditions", declared(Conditions)), ("thermal", declared(ThermalParams)),
            ("load", declared(LoadProgram)[1:])) for p in parameters},
         "time.periods": "drive periods", "simulation.step": "s", "simulation.tol": "1", "simulation.max_wall": "s"}


def key_label(key: str) -> str:
    """``key [unit]`` for an axis label (the key alone where the unit is not known)."""
    unit = UNITS.get(key)
    return f"{key} [{unit}]" if unit else key


@dataclass(frozen=True)
class TimeSpan:
    periods: float = 6.5  # simulate from 0 to this many drive periods
    window: tuple[float, float] = (5.0, 6.5)  # shown window, in periods


@dataclass(frozen=True)
class SimulationSettings:
    algorithm: str = "adaptive"
    step: float | None = None  # s; None: the algorithm's default
    tol: float | None = None  # nRMS-like tolerance for adaptive coupling
    # s: a run whose projected wall time exceeds this stops with a message (0: no limit)
    max_wall: float = 1800.0


@dataclass(frozen=True)
class Scenario:
    name: str
    title: str = ""
    fmus: tuple[str, ...] = DEFAULT_FMUS
    drive: DriveParams = field(default_factory=DriveParams)
    block: BlockParams = field(default_factory=BlockParams)
    friction: FrictionParams = field(default_factory=FrictionParams)
    conditions: Conditions = field(default_factory=Conditions)
    thermal: ThermalTable = field(default_factory=ThermalTable)
    load_program: LoadTable = field(default_factory=LoadTable)
    time: TimeSpan = field(default_factory=TimeSpan)
    simulation: SimulationSettings = field(default_factory=SimulationSettings)
    source: str = "<scenario>"

    @property
    def stop_time(self) -> float:
        """End of the simulated span [s]."""
        return self.time.periods * self.drive.period

    @property
    def window(self) -> tuple[float, float]:
        """The shown window [s]."""
        return self.time.window[0] * self.drive.period, self.time.window[1] * self.drive.period

    @property
    def load(self) -> float:
        """Dry load L = -n S [N] at t = 0."""
        return -self.normal_stress(0.0) * self.friction.S

    def normal_stress(self, t: float) -> float:
        """n [Pa] at time t [s]: the Load FMU's program if the scene lists it, else conditions.n."""
        return self.load_program.program_().n(t) if "Load" in self.fmus else self.conditions.n

    def with_overrides(self, overrides: dict[str, Any] | list[str]) -> "Scenario":
        """A copy with ``{"drive.omega": 80}`` (or ``["drive.omega=80"]``) applied and validated."""
        if isinstance(overrides, (list, tuple)):
            overrides = dict(_split_assignment(item, self.source) for item in overrides)
        data = to_dict(self)
        for key, value in overrides.items():
            _assign(data, key, value, self.source)
        result = from_dict(data, self.source)
        problems = override_problems(result, list(overrides))
        if problems:
            raise ScenarioError(f"{self.source}: {problems[0]}")
        return result


# -- the TOML layout: table -> dataclass ------------------------------------------------
_TABLES = {"drive": DriveParams, "block": BlockParams, "conditions": Conditions,
           "thermal": ThermalTable, "load": LoadTable, "time": TimeSpan, "simulation": SimulationSettings}
_ATTRIBUTES = {"load": "load_program"}  # table -> Scenario attribute, where they differ
_FRICTION_KEYS = ({f.name for f in fields(FrictionParams)} - {"lubricant", "effects"}
                  | {f.name for f in fields(LubricantConstants)})
_EFFECT_KEYS = {f.name for f in fields(Effects)}
_SCENARIO_KEYS = {"name", "title", "fmus"}




def load_scenario(path: str | Path, overrides: dict[str, Any] | list[str] | None = None) -> Scenario:
    """Read a scenario file, apply overrides and validate; raises :class:`ScenarioError`.

    The file must be a regular file (not a FIFO or device) of at most 1 MB of UTF-8 TOML
    with keys at most 8 levels deep and arrays or inline tables at most 16 deep."""
    path = Path(path)
    source = path.name
    text = read_scenario_text(path)
    problem = _text_problem(text)
    if problem:
        raise ScenarioError(f"{source}: {problem}")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    except (RecursionError, ValueError) as exc:  # e.g. an integer of more than 4300 digits
        raise ScenarioError(f"{source}: cannot be parsed: {_short(str(exc))}") from None
    data = {"scenario": {"name": path.stem}}
    for table, content in raw.items():
        if not isinstance(content, dict):
            raise ScenarioError(f"{source}: top-level key {_short(table)!r} must be a table, "
                                f"got {_short(repr(content))}")
        if table not in data:
            data[table] = {}
        data[table].update(content)
    scenario = from_dict(data, source)
    return scenario.with_overrides(overrides) if overrides else scenario


def to_dict(scenario: Scenario) -> dict[str, dict[str, Any]]:
    """The scenario as the TOML tables it is written in."""
    fr = scenario.friction
    friction = {k: getattr(fr, k) for k in _FRICTION_KEYS if hasattr(fr, k)}
    friction.update({f.name: getattr(fr.lubricant, f.name) for f in fields(LubricantConstants)})
    out = {"scenario": {"name": scenario.name, "title": scenario.title, "fmus": list(scenario.fmus)},
           "friction": friction,
           "effects": {f.name: getattr(fr.effects, f.name) for f in fields(Effects)}}
    for table, cls in _TABLES.items():
        obj = getattr(scenario, _ATTRIBUTES.get(table, table))
        out[table] = {f.name: getattr(obj, f.name) for f in fields(cls) if getattr(obj, f.name) is not None}
    out["time"]["window"] = list(scenario.time.window)
    return out


def from_dict(data: dict[str, dict[str, Any]], source: str) -> Scenario:
    known = {"scenario": _SCENARIO_KEYS, "friction": _FRICTION_KEYS, "effects": _EFFECT_KEYS,
             **{t: {f.name for f in fields(c)} for t, c in _TABLES.items()}}
    for table, content in data.items():
        if table not in known:
            raise ScenarioError(f"{source}: unknown table [{table}] (known: {', '.join(sorted(known))})")
        for key in content:
            if key not in known[table]:
                raise ScenarioError(f"{source}: unknown key {table}.{key} "
                                    f"(known: {', '.join(sorted(known[table]))})")

    def typed(table: str, cls: type, values: dict[str, Any]) -> Any:
        defaults = cls()
        kwargs = {}
        for f in fields(cls):
            if f.name not in values:
                continue
            kwargs[f.name] = _coerce(values[f.name], getattr(defaults, f.name), f"{table}.{f.name}", source)
        return cls(**kwargs)

    sc = data.get("scenario", {})
    fr = dict(data.get("friction", {}))
    lubricant = typed("friction", LubricantConstants,
                      {k: fr.pop(k) for k in list(fr) if k in {f.name for f in fields(LubricantConstants)}})
    effects = typed("effects", Effects, data.get("effects", {}))
    friction = replace(typed("friction", FrictionParams, fr), lubricant=lubricant, effects=effects)
    time_values = dict(data.get("time", {}))
    window = time_values.pop("window", None)
    time = typed("time", TimeSpan, time_values)
    if window is not None:
        if not (isinstance(window, (list, tuple)) and len(window) == 2
                and all(isinstance(w, (int, float)) and not isinstance(w, bool) for w in window)):
            raise ScenarioError(f"{source}: time.window must be two numbers [start, end] in periods, got {window!r}")
        time = replace(time, window=(float(window[0]), float(window[1])))
    fmus = sc.get("fmus", list(DEFAULT_FMUS))
    if not (isinstance(fmus, (list, tuple)) and all(isinstance(f, str) for f in fmus)):
        raise ScenarioError(f"{source}: scenario.fmus must be a list of FMU names, got {fmus!r}")
    scenario = Scenario(
        name=str(sc.get("name", "scenario")), title=str(sc.get("title", "")), fmus=tuple(fmus),
        drive=typed("drive", DriveParams, data.get("drive", {})),
        block=typed("block", BlockParams, data.get("block", {})),
        friction=friction,
        conditions=typed("conditions", Conditions, data.get("conditions", {})),
        thermal=typed("thermal", ThermalTable, data.get("thermal", {})),
        load_program=typed("load", LoadTable, data.get("load", {})),
        time=time,
        simulation=typed("simulation", SimulationSettings, data.get("simulation", {})),
        source=source)
    problems = validate(scenario)
    if problems:
        raise ScenarioError(f"{source}: {problems[0]}")
    return scenario


def validate(scenario: Scenario) -> list[str]:
    """Every problem with the scenario, each as ``table.key must be ..., got value``."""
    out = scene_problems(scenario.fmus)
    fr = scenario.friction
    if len(set(scenario.fmus)) != len(scenario.fmus):
        out.append(f"scenario.fmus lists an FMU twice, got {list(scenario.fmus)}")
    out += [f"thermal.{p}" for p in scenario.thermal.params().problems()]
    ld = scenario.load_program
    if ld.program not in PROGRAMS:
        out.append(f"load.program must be one of {', '.join(PROGRAMS)}, got {ld.program!r}")
    else:
        program = ld.program_()
        out += [f"load.{p}" for p in program.problems()]
        if (not program.problems() and "Load" in scenario.fmus and regime_problem(fr.regime) is None
                and math.isfinite(scenario.stop_time)):
            highest, law = program.extremes(0.0, scenario.stop_time)[1], fr.law()
            if any(p.startswith("n ") for p in law.input_problems(0.0, highest, scenario.conditions.T)):
                out.append(f"load.n0 = {ld.n0} with load.program = {ld.program!r} makes n reach "
                           f"{highest:.6g} Pa > 0 within the run ({law.label} needs compression, n <= 0)")
    out += [f"drive.{p}" for p in scenario.drive.problems()]
    out += [f"block.{p}" for p in scenario.block.problems()]
    if regime_problem(fr.regime) is not None:
        out.append(f"friction.regime {regime_problem(fr.regime)}")
    else:
        law = fr.law()
        out += [f"friction.{p}" for p in law.problems()]
        cond = scenario.conditions
        out += [f"conditions.{p}" for p in law.input_problems(0.0, cond.n, cond.T)]
    out += [f"friction.{p}" for p in START_F.problems(fr.f0)]
    ts = scenario.time
    if not (math.isfinite(ts.periods) and ts.periods > 0):
        out.append(f"time.periods must be > 0, got {ts.periods}")
    elif not (0 <= ts.window[0] < ts.window[1] <= ts.periods):
        out.append(f"time.window must satisfy 0 <= start < end <= time.periods ({ts.periods}), got {list(ts.window)}")
    sim = scenario.simulation
    if sim.step is not None and not (math.isfinite(sim.step) and sim.step > 0):
        out.append(f"simulation.step must be > 0, got {sim.step}")
    if sim.tol is not None and not (math.isfinite(sim.tol) and sim.tol > 0):
        out.append(f"simulation.tol must be > 0, got {sim.tol}")
    if not (math.isfinite(sim.max_wall) and sim.max_wall >= 0):
        out.append(f"simulation.max_wall must be >= 0 s (0: no limit), got {sim.max_wall}")
    return out


def _coerce(value: Any, default: Any, key: str, source: str) -> Any:
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
        raise ScenarioError(f"{source}: {key} must be true or false, got {value!r}")
    if isinstance(default, float) or (default is None and key in ("simulation.step", "simulation.tol")):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return _number(value, key, source)
        raise ScenarioError(f"{source}: {key} must be a number, got {_short(repr(value))}")
    if isinstance(default, str):
        if isinstance(value, str):
            return value
        choices = enum_choices(key)
        if choices:
            raise ScenarioError(f"{source}: {key} must be one of {', '.join(choices)}, got {value!r}")
        raise ScenarioError(f"{source}: {key} must be a string, got {value!r}")
    return value


def _split_assignment(item: str, source: str) -> tuple[str, Any]:
    if "=" not in item:
        raise ScenarioError(f"{source}: --set expects KEY=VALUE, got {_short(repr(item))}")
    key, text = item.split("=", 1)
    key, text = key.strip(), text.strip()
    return key, one_toml_value(text, f"{source}: --set {_short(key)}")


def _assign(data: dict[str, dict[str, Any]], key: str, value: Any, source: str) -> None:
    table, _, name = key.partition(".")
    if not name:
        raise ScenarioError(f"{source}: override key must be TABLE.KEY (e.g. drive.omega), got {key!r}")
    data.setdefault(table, {})[name] = value


def scales(scenario: Scenario) -> tuple[float, float, float]:
    """Position [m], velocity [m/s] and time [s] scales of the scene, for tolerances."""
    b, d = scenario.block, scenario.drive
    w0 = math.sqrt(2 * b.K / b.M)
    position = max(abs(d.A) if "Drive" in scenario.fmus else 0.0, abs(b.x0), abs(b.v0) / max(w0, d.omega))
    velocity = max(position * d.omega, abs(b.v0), abs(b.x0) * w0)
    return position or 1e-9, velocity or 1e-9, d.period


# -- overrides that cannot apply to the scene ----------------------------------------------
def enum_choices(key: str) -> list[str]:
    """The allowed values of a key that takes one of a few names (empty for other keys)."""
    if key == "friction.regime":
        return list(LAWS)
    if key == "load.program":
        return list(PROGRAMS)
    if key == "simulation.algorithm":
        return list(ALGORITHMS)
    return []


# A law reading more friction keys than this (the boundary model's 16) is named, not listed.
LISTED_KEYS_MAX = 8


def override_problems(scenario: Scenario, keys) -> list[str]:
    """Why each overridden key would change nothing in this scene (one message per key):
    a table of an FMU the scene does not list, a friction key its regime does not read, a
    boundary-model switch or condition its regime ignores."""
    fmus, regime = set(scenario.fmus), scenario.friction.regime
    law = law_class(regime) if regime_problem(regime) is None else None
    listed = f"scenario.fmus = {list(scenario.fmus)}"
    out = []
    for key in keys:
        table, _, name = str(key).partition(".")
        if table == "thermal" and "Thermal" not in fmus:
            out.append(f"{key}: this scene has no Thermal FMU ({listed}), so [thermal] is not used")
        elif table == "load" and "Load" not in fmus:
            out.append(f"{key}: this scene has no Load FMU ({listed}), so [load] is not used "
                       "(the constant normal stress is conditions.n)")
        elif table == "drive" and name != "omega" and "Drive" not in fmus:
            out.append(f"{key}: this scene has no Drive FMU ({listed}); "
                       "drive.omega only sets its time span")
        elif table in ("friction", "effects", "conditions") and "Friction" not in fmus:
            out.append(f"{key}: this scene has no Friction FMU ({listed}), so [{table}] is not used")
        elif law is None:
            continue  # validate() names the unknown regime
        elif table == "friction" and name != "regime" and name not in law.keys:
            used = ", ".join(f"friction.{k}" for k in sorted(law.keys)) \
                if len(law.keys) <= LISTED_KEYS_MAX else f"the {law.name} model's keys"
            out.append(f"{key}: {law.label} does not use it (it uses {used})")
        elif table == "effects" and not law.has_state:
            out.append(f"{key}: the boundary-model switches apply to boundary friction only, "
                       f"this scene's friction is {regime}")
        elif key == "conditions.n" and "Load" in fmus:
            out.append(f"{key}: this scene's normal stress comes from its Load FMU (set [load] instead)")
        elif key == "conditions.n" and law.load_shown_as is None:
            out.append(f"{key}: {law.label} does not depend on the normal stress")
        elif key == "conditions.T" and not law.reads_temperature and "Thermal" not in fmus:
            out.append(f"{key}: {law.label} does not depend on the temperature")
    return out
