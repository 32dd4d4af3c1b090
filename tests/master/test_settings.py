"""The coupling's and its check's constants live in one place (coupling/settings.py), each of
one kind (tuning, resolution, limit, switch), the tuning counted; what is read from there is
what the coupling and the check use: an instance given other values behaves differently, the
module names the check reads are the settings' values."""
import ast
import dataclasses
import importlib
import inspect
from pathlib import Path

import pytest

from tribofmu import checked
from tribofmu.coupling import settings
from tribofmu.coupling.embedded import EmbeddedCoupling, LocalError
from tribofmu.coupling.system import Contact, Point
from tribofmu.physics import stepsize

from test_error_norm import solid_lubricant

# The most tuning values the coupling and its check may have (issue 36's target is 15): lower
# it as values go, never raise it. (15: 3 of the step, 4 of the error estimate, 5 of the
# step-size rule, 3 of the check.)
MAX_TUNING = 15

PACKAGE = Path(settings.__file__).resolve().parents[1]  # fmu_src/tribofmu


def field_names(groups) -> set[str]:
    return {f"{name}.{f.name}" for name, cls in groups.items() for f in dataclasses.fields(cls)}


def test_the_tuning_is_counted_and_at_most_its_bound():
    tuning = field_names(settings.TUNING_GROUPS)
    assert len(tuning) <= MAX_TUNING, sorted(tuning)
    assert settings.STEP_CONTROL.__class__ is settings.TUNING_GROUPS["STEP_CONTROL"]


def test_every_group_of_the_settings_is_of_one_kind():
    """A dataclass added to settings.py (or a field added to one) is tuning, resolution, a
    limit or a switch: no group is left unclassified, and no field is of two kinds."""
    groups = {**settings.TUNING_GROUPS, **settings.OTHER_GROUPS}
    assert len(groups) == len(settings.TUNING_GROUPS) + len(settings.OTHER_GROUPS)
    defined = {name for name, obj in vars(settings).items()
               if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and obj.__module__ == settings.__name__}
    assert defined <= set(groups), defined - set(groups)
    assert set(settings.OTHER_GROUPS) == {"Resolution", "Limits", "Switches"}
    # every value the coupling runs with is an instance of one of the groups
    for name in ("SETTINGS", "ERROR_SETTINGS", "CHECK_SETTINGS", "RESOLUTION", "LIMITS", "SWITCHES", "STEP_CONTROL"):
        assert type(getattr(settings, name)) in groups.values(), name
    # switches are what a comparison turns off: booleans only
    assert all(f.type in ("bool", bool) for f in dataclasses.fields(settings.Switches))


def test_calibrated_values_are_tuning_values_and_say_where():
    assert set(settings.CALIBRATED) <= field_names(settings.TUNING_GROUPS)
    assert all(where.strip() for where in settings.CALIBRATED.values())  # each names where it was measured


def module_numbers(path: Path) -> set[str]:
    """The module-level names of a file bound to an expression with a number in it (a bool is
    no number): the constants a reader would take for tuning."""
    def numeric(node) -> bool:
        return any(isinstance(n, ast.Constant) and isinstance(n.value, (int, float)) and not isinstance(n.value, bool)
                   for n in ast.walk(node))

    names = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        value = getattr(node, "value", None)
        if value is not None and numeric(value):
            names |= {t.id for t in targets if isinstance(t, ast.Name)}
    return names


# The numbers at module level in coupling/, the check and the step-size rule that are not tuning,
# and why (a new one must be added here with its reason, or go into settings.py).
NOT_TUNING = {
    "coupling/settings.py": {"STEP_CONTROL",  # a tuning group (TUNING_GROUPS), counted above
                             "MAX_ORDER",  # derived (its comment): an error-per-step run's order
                             "ROUND_OFF"},  # a block step's round-off, which Resolution's fields are
    # a unit; the output grid, not the coupling's; the cubic Hermite error bound's 384
    "coupling/interpolation.py": {"NS", "SAMPLES_PER_PERIOD", "HERMITE_ERROR_DIVISOR"},
    "coupling/controlled.py": {"STUCK_ORDER"},  # a stuck step's order (its breakaway miss ~ h^4): a definition
    "coupling/blocks.py": {"SERIES_BELOW"},  # where a closed form's round-off passes its Taylor series'
    "coupling/estimate.py": {"EXP_LIMIT"},  # exp() overflows a float past it
    "coupling/variational.py": {"PADE_POLE", "PADE_RESIDUE"},  # the (1,2) Pade approximant's pole and residue
    "coupling/quadrature.py": {"GAUSS_NODES", "GAUSS_WEIGHTS"},  # the three-point Gauss rule
    # the (2,3) Pade approximant of e^z: its denominator, poles and residues, and those with the
    # poles' inverse powers
    "coupling/path_error.py": {"_DENOMINATOR", "PADE_POLES", "PADE_RESIDUES", "_POLE_TERMS"},
    # the rule's default (the coupling's is STEP_CONTROL's); the lubricant's sub-steps (physics')
    "physics/stepsize.py": {"MIN_PREVIOUS_ERROR", "KINETICS_SUBSTEPS"},
}


def test_no_number_outside_the_settings_is_taken_for_tuning():
    files = sorted((PACKAGE / "coupling").glob("*.py")) + [PACKAGE / "checked.py", PACKAGE / "physics" / "stepsize.py"]
    for path in files:
        key = path.relative_to(PACKAGE).as_posix()
        found = module_numbers(path)
        assert found <= NOT_TUNING.get(key, set()), (key, found - NOT_TUNING.get(key, set()))


def test_the_check_reads_the_check_settings():
    values = settings.CHECK_SETTINGS
    assert (checked.CHECK_RATIO, checked.MIN_ORDER, checked.ESTIMATE_SAFETY, checked.MAX_JUMP) == (
        values.check_ratio, values.min_order, values.estimate_safety, values.max_jump)
    assert (checked.MAX_RUNS, checked.MIN_BUDGET, checked.MIN_STEP_TOL) == (
        settings.LIMITS.max_runs, settings.LIMITS.min_budget, settings.RESOLUTION.min_step_tol)
    assert checked.CHAIN_TIGHTENING_MAX == values.check_ratio ** 2
    assert checked.MAX_JUMP == values.check_ratio ** 3  # derived: one check ratio beyond a chain
    assert checked.checked_error(1.0) == pytest.approx(1.0 / (values.check_ratio ** values.min_order - 1.0))
    # the plan's order is the highest credited one: an error 3x tol asks for 3x the per-step tolerance
    assert checked.wanted_tightening(3e-3, 1e-3) == pytest.approx(3.0 ** (1.0 / settings.MAX_ORDER))
    assert checked.observed_order(1e-6, 1e-3) == settings.MAX_ORDER


def test_the_coupling_steps_by_the_settings_rule():
    controlled = importlib.import_module("tribofmu.coupling.controlled")
    assert controlled.ErrorControlledCoupling.controller is settings.STEP_CONTROL
    assert not hasattr(stepsize, "COUPLING_STEPS")  # physics/ does not reach up into coupling/
    assert settings.STEP_CONTROL.beta > 0.0  # PI, as its reason says
    # the lubricant's sub-steps keep their own rule (physics/, without the coupling)
    assert stepsize.KINETICS_SUBSTEPS.beta == 0.0 and stepsize.KINETICS_SUBSTEPS.max_factor == 10.0


def test_an_instance_given_other_error_weights_judges_by_them():
    system, algorithm, _ = solid_lubricant(1e-3)
    point = Point(0, v=1e-3, x=1e-6, mode=Contact.FORWARD)
    new = Point(1_000_000, v=1.1e-3, x=1.1e-6, mode=Contact.FORWARD)
    local = LocalError(x=1e-12, v=1e-8, impulse=0.0)
    plain = algorithm.error_ratio(point, new, local, 1e-3)
    algorithm.errors = dataclasses.replace(settings.ERROR_SETTINGS,
                                           error_weight=settings.ERROR_SETTINGS.error_weight / 2.0)
    assert algorithm.error_ratio(point, new, local, 1e-3) == pytest.approx(2.0 * plain, rel=1e-12)
    assert EmbeddedCoupling.errors is settings.ERROR_SETTINGS  # (the class keeps the shipped ones)
    assert EmbeddedCoupling.switches is settings.SWITCHES and EmbeddedCoupling.settings is settings.SETTINGS


def test_the_settings_table_of_the_docs_counts_what_is_there():
    import re

    page = (PACKAGE.parents[1] / "docs" / "coupling.md").read_text(encoding="utf-8")
    rows = dict(re.findall(r"^\| `(\w+)` \| (\d+) \|", page, re.M))
    groups = {**settings.TUNING_GROUPS, **settings.OTHER_GROUPS}
    assert rows == {name: str(len(dataclasses.fields(cls))) for name, cls in groups.items()}
    for name in settings.CALIBRATED:  # every calibrated value is named in the table
        assert f"`{name.split('.')[1]}`" in page


def test_the_interpolation_bound_plans_with_the_controllers_safety():
    """One safety for one reason: a step planned from the last step's jerk (the interpolation
    bound) is the controller's safety times the bound's step, as a step planned from the last
    step's error is (before, its own 0.5 of tol, whatever the controller's)."""
    from fakes import drive_scales, fig2_system

    system, scales = fig2_system(), drive_scales()
    algorithm = EmbeddedCoupling(step=1e-4, tol=1e-3)
    algorithm.prepare(system, scales)
    point = Point(0, X=2e-3, V=0.0, aX=-1.8, x=1e-3, v=0.0, mode=Contact.STUCK)
    shipped = algorithm.drive_interpolation_limit(point)
    algorithm.controller = dataclasses.replace(settings.STEP_CONTROL, safety=1.0)
    unsafe = algorithm.drive_interpolation_limit(point)
    assert 0.0 < shipped < unsafe < float("inf")
    assert shipped / unsafe == pytest.approx(settings.STEP_CONTROL.safety, rel=1e-12)


def test_a_stick_onset_is_located_to_one_nanosecond(monkeypatch):
    """The time grid's resolution, not a number: every stick onset inside a step is located to
    1 ns of it, whatever the step's length (before, to 1e-9 of the step: 1e-12 s in 1 ms)."""
    import math

    from fakes import drive_scales, fig2_system
    from tribofmu.coupling import solvers
    from tribofmu.master.run import run

    asked = []
    located = solvers.stick_onset

    def recording(dv0, slope0, dv_end, slope_end, h, xtol):
        asked.append(xtol * h)
        return located(dv0, slope0, dv_end, slope_end, h, xtol)

    monkeypatch.setattr(solvers, "stick_onset", recording)
    outcome = run(fig2_system(), EmbeddedCoupling(step=1e-4, tol=1e-3), 2 * math.pi / 30.0, drive_scales())
    assert outcome.ok, outcome.message
    assert len(asked) > 3 and all(t == pytest.approx(1e-9, rel=1e-9) for t in asked)


def test_a_ramp_gain_of_zero_holds_the_force_everywhere():
    """The first-order coupling for comparison needs no switch of its own (second_order, gone):
    a loop gain is never negative, so max_ramp_gain = 0 holds the force over every step, where
    the shipped value ramps it while the contact slips on the same way."""
    import math

    from fakes import drive_scales, fig2_system
    from tribofmu.master.run import run

    ramped = {}
    for gain in (settings.SETTINGS.max_ramp_gain, 0.0):
        algorithm = EmbeddedCoupling(step=1e-4, tol=1e-3)
        algorithm.settings = dataclasses.replace(settings.SETTINGS, max_ramp_gain=gain)
        outcome = run(fig2_system(), algorithm, 2 * math.pi / 30.0, drive_scales())
        assert outcome.ok, outcome.message
        ramped[gain] = sum(p.ramped for p in outcome.points)
    assert ramped[settings.SETTINGS.max_ramp_gain] > 10 and ramped[0.0] == 0
