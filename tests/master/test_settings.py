"""The coupling's and its check's tuning live in one place (coupling/settings.py), and what is
read from there is what the coupling and the check use: an instance given other values
behaves differently, the module names the check reads are the settings' values."""
import dataclasses
import importlib

import pytest

from tribofmu import checked
from tribofmu.coupling import settings
from tribofmu.coupling.embedded import EmbeddedCoupling, LocalError
from tribofmu.coupling.system import Contact, Point
from tribofmu.physics import stepsize

from test_error_norm import solid_lubricant


def test_every_named_value_is_a_setting():
    fields = {f"{cls.__name__}.{f.name}" for cls in (settings.CouplingSettings, settings.ErrorSettings,
                                                      settings.CheckSettings) for f in dataclasses.fields(cls)}
    fields |= {f"STEP_CONTROL.{f.name}" for f in dataclasses.fields(stepsize.StepSizeController)}
    assert set(settings.CALIBRATED) <= fields and set(settings.RESOLUTION) <= fields
    assert not set(settings.CALIBRATED) & set(settings.RESOLUTION)
    assert all(where.strip() for where in settings.CALIBRATED.values())  # each names where it was measured


def test_the_check_reads_the_check_settings():
    values = settings.CHECK_SETTINGS
    assert (checked.CHECK_RATIO, checked.MIN_ORDER, checked.ORDER_SAFETY, checked.MAX_RUNS) == (
        values.check_ratio, values.min_order, values.order_safety, values.max_runs)
    assert checked.CHAIN_TIGHTENING_MAX == values.check_ratio ** 2
    assert checked.checked_error(1.0) == pytest.approx(1.0 / (values.check_ratio ** values.min_order - 1.0))


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


def test_the_settings_table_of_the_docs_counts_what_is_there():
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "coupling.md").read_text(encoding="utf-8")
    rows = dict(re.findall(r"^\| `(\w+)` \| (\d+) \|", page, re.M))
    assert rows == {"CouplingSettings": str(len(dataclasses.fields(settings.CouplingSettings))),
                    "ErrorSettings": str(len(dataclasses.fields(settings.ErrorSettings))),
                    "STEP_CONTROL": str(len(dataclasses.fields(settings.STEP_CONTROL))),
                    "CheckSettings": str(len(dataclasses.fields(settings.CheckSettings)))}
    for name in settings.CALIBRATED:  # every calibrated value is named in the table
        assert f"`{name.split('.')[1]}`" in page
