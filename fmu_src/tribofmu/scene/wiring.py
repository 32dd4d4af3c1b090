"""Which FMUs a scene instantiates and how they connect: the one description of the system.

The master (:mod:`tribofmu.api` builds the coupled system from it), the SSP export
(:mod:`tribofmu.scene.ssp`), the scenario's validation and the README's wiring list all read
what is declared here; each FMU is one the build builds (:mod:`tribofmu.fmu.registry`, where
an FMU's adapter is registered). To add an FMU to scenes, declare it in :data:`FMUS` (file,
instance name, start values from the scenario, recorded outputs, constant inputs, which FMUs it
needs) and its connections in :data:`CONNECTIONS`; a constant input that a connection feeds in
a scene is left to the connection (e.g. a Load FMU's ``n`` replaces the constant ``n``).

Today's system (SSP connections cannot subtract, so BlockSpring forms ``dv = V - v`` itself)::

    Drive.V -> BlockSpring.V,  BlockSpring.dv -> Friction.dv,  Friction.F -> BlockSpring.F

with Friction's ``n`` [Pa] and ``T`` [K] held constant at the scene's conditions. Beyond the
paper, a scene may list a Load FMU (``Load.n -> Friction.n``, a normal-stress program) and a
Thermal FMU (``Thermal.T -> Friction.T``, fed ``Friction.F -> Thermal.F`` and
``BlockSpring.dv -> Thermal.dv``). The tribofmu master treats them apart from the dv -> F loop
(:mod:`tribofmu.coupling.system`): Load steps with the drive (a function of time); Thermal
follows the solved loop, its T exchanged explicitly, and it gets the step's exact mean
friction power through its input ``P`` instead of the F and dv connections (which an SSP
master, able only to connect variables, uses).

For masters that couple explicitly (every mainstream one), the SSP export can replace
BlockSpring and Friction by one :data:`PAIR` FMU, ``TriboPair``, which closes the dv -> F -> dv
loop inside itself (``pair=True`` in :func:`instances` and :func:`connections`)::

    Drive.V -> TriboPair.V,  Drive.a -> TriboPair.a_drive

with Load's n, Thermal's T and the Thermal's F and dv connected to the pair as to the FMUs it
replaces.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..coupling.interpolation import NS
from ..errors import ScenarioError
from ..fmu.registry import fmu_names
from ..physics.block import BlockParams
from ..physics.drive import DriveParams
from ..physics.friction import START_F, Conditions, Effects, FrictionLaw, LubricantConstants
from ..physics.laws import law_class, law_fields
from ..physics.load import PROGRAMS, LoadProgram
from ..physics.parameters import declared
from ..physics.thermal import START_T, ThermalParams

# "Scenario" in annotations is :class:`tribofmu.scene.scenario.Scenario`, not imported: the
# scenario module validates scenes with this one, which must not import it back.

Value = float | int | bool  # Python types carry the FMI types: Real, Integer, Boolean


@dataclass(frozen=True)
class FMU:
    """One FMU a scene may instantiate.

    name: the model name, also the file stem (``<fmu_dir>/<name>.fmu``) and the SSP component;
    instance: the instance name the master gives it (named in its error messages);
    start_values: the scenario -> the FMU's parameters (SI units, typed, in declaration order);
    outputs: the outputs a host should record (the SSP export declares them as connectors);
    constant_inputs: the scenario -> inputs held constant during the run, unless connected;
    needs: FMUs that must be in a scene that has this one; required: in every scene.
    """

    name: str
    instance: str
    start_values: Callable[["Scenario"], dict[str, Value]]
    outputs: tuple[str, ...]
    constant_inputs: Callable[["Scenario"], dict[str, float]] = lambda scenario: {}
    needs: tuple[str, ...] = ()
    required: bool = False

    def __post_init__(self):
        if self.name not in fmu_names():  # a scene could list it, but no FMU file would exist
            raise ValueError(f"FMU {self.name!r} is not one the build builds "
                             f"(tribofmu.fmu.registry.FMU_NAMES: {', '.join(fmu_names())})")

    @property
    def file(self) -> str:
        """The FMU's file name, ``<name>.fmu``."""
        return f"{self.name}.fmu"


@dataclass(frozen=True)
class Connection:
    """An output of one FMU feeding an input of another, e.g. ``Friction.F -> BlockSpring.F``."""

    start: str
    output: str
    end: str
    input: str

    def __str__(self) -> str:
        return f"{self.start}.{self.output} -> {self.end}.{self.input}"


@dataclass(frozen=True)
class Instance:
    """What a scene makes of one FMU: its start values and the constant inputs left unconnected."""

    fmu: FMU
    start_values: dict[str, Value]
    constant_inputs: dict[str, float]


def _declared(obj, parameters) -> dict[str, Value]:
    """The values of declared parameters on a scene table, by FMU variable name, typed as the
    declarations (Real, Integer, Boolean)."""
    return {p.fmu_variable: type(p.default)(getattr(obj, p.name)) for p in parameters}


def _drive(sc: "Scenario") -> dict[str, Value]:
    return _declared(sc.drive, declared(DriveParams))


def _block(sc: "Scenario") -> dict[str, Value]:
    return _declared(sc.block, declared(BlockParams))


def _friction(sc: "Scenario") -> dict[str, Value]:
    fr, shared = sc.friction, declared(FrictionLaw)  # every law's, f0, then those a law adds
    return {"regime": int(law_class(fr.regime).code), **_declared(fr, (*shared, START_F, *law_fields()[len(shared):])),
            **_declared(fr.lubricant, declared(LubricantConstants)), **_declared(fr.effects, declared(Effects))}


def _conditions(sc: "Scenario") -> dict[str, float]:
    return _declared(sc.conditions, declared(Conditions))


def _pair(sc: "Scenario") -> dict[str, Value]:
    values = {**_block(sc), **_friction(sc)}
    if sc.simulation.algorithm == "adaptive" and sc.simulation.tol is not None:
        values["tol"] = float(sc.simulation.tol)  # the scene's own coupling tolerance
    return values


def _thermal(sc: "Scenario") -> dict[str, Value]:
    # the film starts at the scene's T
    return {**_declared(sc.thermal, declared(ThermalParams)), START_T.name: float(sc.conditions.T)}


def _load(sc: "Scenario") -> dict[str, Value]:
    ld = sc.load_program
    return {"program": int(PROGRAMS[ld.program]), **_declared(ld, declared(LoadProgram)[1:])}


# Declaration order is the order of instantiation and of the SSP components.
FMUS: tuple[FMU, ...] = (
    FMU("Drive", "drive", _drive, outputs=("X", "V", "a")),
    FMU("BlockSpring", "blockspring", _block, outputs=("x", "v", "a", "dv"), required=True),
    FMU("Friction", "friction", _friction, outputs=("F", "f"), constant_inputs=_conditions,
        needs=("Drive",)),
    FMU("Thermal", "thermal", _thermal, outputs=("T", "Q", "Q_lost"), needs=("Friction",)),
    FMU("Load", "load", _load, outputs=("n",), needs=("Friction",)),
)
CONNECTIONS: tuple[Connection, ...] = (
    Connection("Drive", "V", "BlockSpring", "V"),
    Connection("BlockSpring", "dv", "Friction", "dv"),
    Connection("Friction", "F", "BlockSpring", "F"),
    Connection("Load", "n", "Friction", "n"),
    Connection("Thermal", "T", "Friction", "T"),
    Connection("Friction", "F", "Thermal", "F"),
    Connection("BlockSpring", "dv", "Thermal", "dv"),
)

# The pair: BlockSpring and Friction in one FMU, their loop closed inside (export-ssp --pair).
PAIR = FMU("TriboPair", "tribopair", _pair, outputs=("x", "v", "a", "F", "f", "dv", "stuck"),
           constant_inputs=_conditions, needs=("Drive",))
PAIRED = ("BlockSpring", "Friction")  # the FMUs the pair replaces


def _to_the_pair(connection: Connection) -> Connection:
    """The connection with BlockSpring and Friction replaced by the pair (same variable names)."""
    def end(name: str) -> str:
        return PAIR.name if name in PAIRED else name
    return Connection(end(connection.start), connection.output, end(connection.end), connection.input)


# The pair is connected as the FMUs it replaces, less the dv -> F -> dv loop it closes inside,
# plus the drive's acceleration, so that it follows V within a step instead of holding it.
PAIR_CONNECTIONS: tuple[Connection, ...] = (
    Connection("Drive", "a", "TriboPair", "a_drive"),
    *(_to_the_pair(c) for c in CONNECTIONS if not (c.start in PAIRED and c.end in PAIRED)),
)


def scene_problems(names: tuple[str, ...] | list[str]) -> list[str]:
    """What is wrong with a scene's list of FMU names, each as ``scenario.fmus ...``."""
    known = [fmu.name for fmu in FMUS]
    out = [f"scenario.fmus names an unknown FMU {name!r} (known: {', '.join(known)})"
           for name in names if name not in known]
    for fmu in FMUS:
        if fmu.required and fmu.name not in names:
            out.append(f"scenario.fmus must include {fmu.name!r}, got {list(names)}")
        if fmu.name in names:
            out += [f"scenario.fmus must include {need!r} when it includes {fmu.name!r}, got {list(names)}"
                    for need in fmu.needs if need not in names]
    return out


def pair_problems(scenario: "Scenario") -> list[str]:
    """Why the scene cannot run with BlockSpring and Friction replaced by the pair."""
    missing = [name for name in PAIRED + PAIR.needs if name not in scenario.fmus]
    return [f"{scenario.source}: the pair replaces BlockSpring and Friction and is driven by Drive: "
            f"scenario.fmus must include {', '.join(map(repr, missing))}, got {list(scenario.fmus)}"] if missing else []


def _fmus(scenario: "Scenario", pair: bool) -> list[FMU]:
    if not pair:
        return [fmu for fmu in FMUS if fmu.name in scenario.fmus]
    problems = pair_problems(scenario)
    if problems:
        raise ScenarioError(problems[0])
    listed = [fmu for fmu in FMUS if fmu.name in scenario.fmus and fmu.name not in PAIRED]
    at = next(i for i, fmu in enumerate(listed) if fmu.name == "Drive") + 1
    return listed[:at] + [PAIR] + listed[at:]


def connections(scenario: "Scenario", pair: bool = False) -> list[Connection]:
    """The connections between the scene's FMUs (both ends present); pair: with BlockSpring
    and Friction replaced by :data:`PAIR` (a ScenarioError if the scene has not both)."""
    names = {fmu.name for fmu in _fmus(scenario, pair)}
    return [c for c in (PAIR_CONNECTIONS if pair else CONNECTIONS) if c.start in names and c.end in names]


def instances(scenario: "Scenario", pair: bool = False) -> list[Instance]:
    """The scene's FMU instances in declaration order, with start values and the constant
    inputs that no connection of the scene feeds; pair: as :func:`connections`."""
    fed = {(c.end, c.input) for c in connections(scenario, pair)}
    return [Instance(fmu, fmu.start_values(scenario),
                     {k: v for k, v in fmu.constant_inputs(scenario).items() if (fmu.name, k) not in fed})
            for fmu in _fmus(scenario, pair)]


def fmu_parameters(scenario: "Scenario") -> dict[str, dict[str, Value]]:
    """Start values by FMU name, for the FMUs the scene uses; SI units."""
    return {inst.fmu.name: inst.start_values for inst in instances(scenario)}


def constant_inputs(scenario: "Scenario") -> dict[str, float]:
    """The Friction FMU's constant inputs (n [Pa], T [K]), as the coupled system takes them
    today (``CoupledSystem(conditions=...)``); every FMU's are in :func:`instances`."""
    return next((inst.constant_inputs for inst in instances(scenario) if inst.fmu.name == "Friction"), {})


def input_signals(points, grid) -> dict:
    """The friction's inputs T [K], n [Pa] and the heat the Thermal FMU received Q [J], on
    the time grid [s], interpolated linearly between communication points."""
    # numpy here, not at the top: the scene is read by commands that never interpolate (loading a
    # scene, the SSP export), and numpy costs 58 ms at start-up (-X importtime, min of 5,
    # 2026-11-26 23:59 UTC, load 5.5)
    import numpy as np

    t = np.array([p.t_ns for p in points], dtype=np.int64) / NS
    return {name: np.interp(grid, t, np.array([getattr(p, name) for p in points]))
            for name in ("T", "n", "Q")}
