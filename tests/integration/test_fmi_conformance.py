"""FMI 2.0 conformance of the built FMUs, through fmpy as an external host would see them.

Integration tier: the FMUs are built from the working tree into a temporary directory
(``fmu_paths``), so nothing here depends on a pre-existing ``build/``.
"""
from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu
from tribofmu.build import private_package_name, rewrite_imports

from fmi_harness import FMU_NAMES, OK, Instance, bits
from scenes import ROOT

pytestmark = pytest.mark.integration

PACKAGE = ROOT / "fmu_src" / "tribofmu"

# Direct feedthrough declared in ModelStructure/Outputs: output -> inputs it depends on.
DEPENDENCIES = {
    "Friction": {"F": {"dv", "n"}, "f": set(), "F_mean": set(), "melt_margin": set()},
    "BlockSpring": {"x": set(), "v": set(), "a": set(), "dv": {"V"}},
    "Drive": {"X": set(), "V": set(), "a": set()},
    "Thermal": {"T": set(), "Q": set(), "Q_lost": set()},
    "Load": {"n": set()},
    # the pair's outputs come from its internal steps: no direct feedthrough
    "TriboPair": {name: set() for name in ("x", "v", "a", "F", "f", "dv", "stuck")},
}
# The paper's boundary lubricant (Fig. 6): S [m^2], m [SI], gamma [1].
BOUNDARY = dict(regime=2, S=3e-9, m=0.05, gamma=-2.0 / 3.0)
# Per FMU: parameters away from the defaults, and the inputs of step k (k = 0, 1, ...).
SCENARIOS = {
    "Friction": (BOUNDARY,
                 lambda k: dict(dv=2e-3 * math.sin(0.7 * k), n=-1e6, T=290.0 + k)),
    "BlockSpring": (dict(M=0.7, K=1300.0, x0=1e-3),
                    lambda k: dict(F=0.5 * math.cos(0.3 * k), F_rate=0.1 * k, V=0.01 * k)),
    "Drive": (dict(A=1.4e-6, omega=30.0), lambda k: {}),
    "Thermal": (dict(C=2e-11, q=0.7, G=3e-11, T_ambient=300.0, T0=310.0),
                lambda k: dict(P=1e-8 * (1.0 + math.sin(k)), F=1e-3 * k, dv=1e-6 * math.cos(k))),
    "Load": (dict(program=3, n0=-1e5, amplitude=2e4, period=0.05, phase=0.3), lambda k: {}),
    "TriboPair": (dict(BOUNDARY, M=0.7, K=1300.0, tol=3e-3),
                  lambda k: dict(V=4e-5 * math.sin(0.03 * k), a_drive=1.2e-3 * math.cos(0.03 * k), n=-1e6,
                                 T=290.0 + k)),
}
H = 1e-3  # s, communication step


def run(inst: Instance, steps: int, first: int = 0) -> list[bytes]:
    """Step ``steps`` times with the scenario's inputs; returns the outputs' bits after each."""
    _, inputs = SCENARIOS[inst.md.modelName]
    record = []
    for k in range(first, first + steps):
        inst.set(**inputs(k))
        assert inst.step(k * H, H) == OK, inst.messages[-3:]
        record += bits(inst.get_outputs().values())
    return record


@pytest.fixture
def instances():
    """Instances created by a test, freed afterwards even when it fails."""
    made: list[Instance] = []
    yield made
    for inst in made:
        inst.free()


def started(instances, path, name="inst", **overrides) -> Instance:
    inst = Instance(path, name=name)
    instances.append(inst)
    params = dict(SCENARIOS[inst.md.modelName][0], **overrides)
    inst.start(**params)
    return inst


# -- the build ----------------------------------------------------------------------------
def test_fmus_are_built_fresh_and_carry_the_physics(fmu_paths):
    """Each FMU comes from this session's build and ships the current physics and framework."""
    assert set(fmu_paths) == set(FMU_NAMES)
    for name, path in fmu_paths.items():
        assert path.is_file() and path.parent.name.startswith("fmus")
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
            assert "modelDescription.xml" in names
            private = private_package_name()  # the shipped copy's name: never shadows tribofmu
            for rel in ("fmu/base.py", "fmu/fmi.py", "fmu/values.py", "fmu/fmu_state.py", "fmu/description.py",
                        "physics/friction.py", "physics/block.py", "physics/drive.py",
                        "physics/thermal.py", "physics/load.py", "physics/roots.py"):
                shipped = z.read(f"resources/{private}/{rel}").decode()
                assert shipped == rewrite_imports((PACKAGE / rel).read_text(), private), f"{name}: stale {rel}"


# -- model description ----------------------------------------------------------------------
@pytest.mark.parametrize("name", FMU_NAMES)
def test_validate_fmu_finds_nothing(fmu_paths, name):
    assert validate_fmu(str(fmu_paths[name])) == []


@pytest.mark.parametrize("name", FMU_NAMES)
def test_model_structure_declares_direct_feedthrough(fmu_paths, name):
    md = read_model_description(str(fmu_paths[name]))
    inputs = {v.name for v in md.modelVariables if v.causality == "input"}
    declared = {}
    for unknown in md.outputs:
        assert unknown.dependencies is not None, f"{unknown.variable.name}: dependencies not declared"
        deps = {v.name for v in unknown.dependencies}
        assert deps <= inputs, f"{unknown.variable.name} depends on non-inputs {deps - inputs}"
        declared[unknown.variable.name] = deps
    assert declared == DEPENDENCIES[name]
    outputs = {v.name for v in md.modelVariables if v.causality == "output"}
    assert {u.variable.name for u in md.initialUnknowns} == outputs


@pytest.mark.parametrize("name", FMU_NAMES)
def test_every_variable_has_description_and_every_real_a_defined_unit(fmu_paths, name):
    md = read_model_description(str(fmu_paths[name]))
    defined = {u.name for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description and v.description.strip(), f"{name}.{v.name}: no description"
        if v.type == "Real":
            assert v.unit, f"{name}.{v.name}: no unit"
            assert v.unit in defined, f"{name}.{v.name}: unit {v.unit!r} not in UnitDefinitions"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


# -- instances --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", FMU_NAMES)
def test_two_instances_do_not_share_state(fmu_paths, instances, name):
    """Stepping (and re-parametrising) one instance leaves the other's values untouched."""
    a = started(instances, fmu_paths[name], "a")
    b = started(instances, fmu_paths[name], "b")
    run(b, 2)
    before = bits(b.get(*b.reals))
    run(a, 20)
    assert bits(b.get(*b.reals)) == before
    # and b continues exactly like an instance that never had a sibling
    alone = started(instances, fmu_paths[name], "alone")
    run(alone, 2)
    assert run(b, 5, first=2) == run(alone, 5, first=2)


@pytest.mark.parametrize("name", FMU_NAMES)
def test_reset_returns_to_the_start(fmu_paths, instances, name):
    inst = started(instances, fmu_paths[name], "used")
    run(inst, 30)
    inst.reset()
    inst.start(**SCENARIOS[name][0])
    fresh = started(instances, fmu_paths[name], "fresh")
    assert bits(inst.get(*inst.reals)) == bits(fresh.get(*fresh.reals))
    assert run(inst, 10) == run(fresh, 10)


@pytest.mark.parametrize("name", FMU_NAMES)
def test_get_set_fmu_state_continues_bit_identically(fmu_paths, instances, name):
    inst = started(instances, fmu_paths[name])
    n, m = 25, 15
    run(inst, n)
    state = inst.call(inst.fmu.getFMUstate)
    try:
        first = run(inst, m, first=n)
        inst.call(inst.fmu.setFMUstate, state)
        again = run(inst, m, first=n)
    finally:
        inst.call(inst.fmu.freeFMUstate, state)
    assert len(first) > 0 and again == first


@pytest.mark.parametrize("name", FMU_NAMES)
def test_serialized_fmu_state_continues_bit_identically_in_a_fresh_instance(fmu_paths, instances, name):
    inst = started(instances, fmu_paths[name], "origin")
    n, m = 25, 15
    run(inst, n)
    state = inst.call(inst.fmu.getFMUstate)
    blob = inst.call(inst.fmu.serializeFMUstate, state)
    inst.call(inst.fmu.freeFMUstate, state)
    first = run(inst, m, first=n)

    # A fresh instance with default parameters: everything must come from the blob.
    fresh = Instance(fmu_paths[name], name="restored")
    instances.append(fresh)
    fresh.start()
    restored = fresh.call(fresh.fmu.deSerializeFMUstate, blob)
    fresh.call(fresh.fmu.setFMUstate, restored)
    fresh.call(fresh.fmu.freeFMUstate, restored)
    assert run(fresh, m, first=n) == first


# -- Friction alone under fmpy.simulate_fmu -----------------------------------------------------
def _input_table(n: float) -> np.ndarray:
    """dv [m/s] through both signs and through zero, n [Pa], T [K]."""
    t = np.linspace(0.0, 1.0, 201)
    table = np.zeros(t.size, dtype=[("time", float), ("dv", float), ("n", float), ("T", float)])
    table["time"] = t
    table["dv"] = 0.05 * np.sin(2 * np.pi * 2 * t)
    table["dv"][100] = 0.0
    table["n"] = n
    table["T"] = 290.0
    return table


def _dry_force(F, dv, f, moving):  # |F| = mu L with L = -n S
    assert np.all(np.abs(F[moving]) == 0.5 * 20.0)


def _newtonian_force(F, dv, f, moving):  # F = m dv
    np.testing.assert_allclose(F, 25.0 * dv, rtol=1e-15, atol=0)


def _stribeck_force(F, dv, f, moving):  # between mu_c L and mu_s L, plus m dv
    coulomb = np.abs(F[moving] - 4.0 * dv[moving])
    assert np.all(coulomb >= 0.35 * 20.0 * (1 - 1e-12)) and np.all(coulomb <= 0.55 * 20.0 * (1 + 1e-12))
    assert np.ptp(coulomb) > 0.1 * (0.55 - 0.35) * 20.0  # it does fall from mu_s toward mu_c


def _lubricant_evolves(F, dv, f, moving):
    assert np.ptp(f) > 0.0


REGIME_CASES = {  # law: (parameters, n [Pa], what its force must satisfy)
    "dry": (dict(regime=0, mu_friction=0.5, S=1.0), -20.0, _dry_force),
    "fluid": (dict(regime=1, m=25.0, gamma=0.0), -20.0, _newtonian_force),
    "boundary": (BOUNDARY, -1e6, _lubricant_evolves),
    "mixed": (dict(regime=3, mu_friction=0.35, mu_static=0.55, v_stribeck=0.015, stribeck_exponent=1.5,
                   m=4.0, S=1.0), -20.0, _stribeck_force),
}


@pytest.mark.parametrize("regime", REGIME_CASES)
def test_friction_runs_alone_in_simulate_fmu_and_dissipates(fmu_paths, regime):
    params, n, law_holds = REGIME_CASES[regime]
    result = simulate_fmu(str(fmu_paths["Friction"]), start_time=0.0, stop_time=1.0,
                          output_interval=5e-3, start_values=params, input=_input_table(n),
                          output=["F", "f", "dv"], debug_logging=True)
    # dv is recorded from the FMU itself: the very value F was computed from.
    F, dv, f = result["F"], result["dv"], result["f"]
    assert np.all(np.isfinite(F)) and np.all(np.isfinite(f))
    moving = dv != 0.0
    assert moving.sum() > 100 and (dv > 0).any() and (dv < 0).any()
    assert np.all(np.sign(F[moving]) == np.sign(dv[moving]))
    assert np.all(F * dv >= 0.0)
    law_holds(F, dv, f, moving)
