"""The scene's wiring: one description that the master's inputs, the SSP export, the
scenario's validation and docs/hosts.md all follow, so that a new FMU is added in one place."""
from __future__ import annotations

import dataclasses
import pytest

from tribofmu.fmu import registry
from tribofmu.scene import wiring
from tribofmu.scene.scenario import ScenarioError, load_scenario
from tribofmu.scene.ssp import parameter_values, system_structure

from scenes import FIG2, ROOT, scene



def test_todays_system_is_drive_block_friction_in_a_loop():
    sc = load_scenario(FIG2)
    assert [str(c) for c in wiring.connections(sc)] == [
        "Drive.V -> BlockSpring.V", "BlockSpring.dv -> Friction.dv", "Friction.F -> BlockSpring.F"]
    insts = {i.fmu.name: i for i in wiring.instances(sc)}
    assert [i.fmu.instance for i in insts.values()] == ["drive", "blockspring", "friction"]
    assert insts["Friction"].constant_inputs == {"n": -20.0, "T": 290.0}
    assert insts["Drive"].constant_inputs == {} == insts["BlockSpring"].constant_inputs


def test_start_values_follow_the_scenario_at_an_unused_point():
    sc = load_scenario(FIG2, ["drive.omega=17.5", "block.x0=3e-4", "friction.regime=boundary",
                              "effects.viscous=false", "friction.tau_f=0.02", "conditions.T=310"])
    values = wiring.fmu_parameters(sc)
    assert values["Drive"] == {"A": 2e-3, "omega": 17.5}
    assert values["BlockSpring"]["x0"] == 3e-4
    friction = values["Friction"]
    assert friction["regime"] == 2 and isinstance(friction["regime"], int)
    assert friction["viscous_term"] is False and friction["elastic_term"] is True
    assert friction["tau_f"] == 0.02
    assert wiring.constant_inputs(sc) == {"n": -20.0, "T": 310.0}
    # The SSP export binds the same values, plus the constant inputs.
    assert parameter_values(sc)["Friction"] == {**friction, "n": -20.0, "T": 310.0}


def test_a_scene_without_friction_has_no_friction_wiring():
    sc = load_scenario(scene("free_oscillator"))
    assert [i.fmu.name for i in wiring.instances(sc)] == ["BlockSpring"]
    assert wiring.connections(sc) == [] and wiring.constant_inputs(sc) == {}


@pytest.mark.parametrize("fmus, message", [
    (["BlockSpring", "Gearbox"], "scenario.fmus names an unknown FMU 'Gearbox'"),
    (["Drive", "Friction"], "scenario.fmus must include 'BlockSpring'"),
    (["BlockSpring", "Friction"], "scenario.fmus must include 'Drive' when it includes 'Friction'"),
])
def test_the_wiring_validates_a_scenes_fmu_list(fmus, message):
    with pytest.raises(ScenarioError, match=message):
        load_scenario(FIG2, {"scenario.fmus": fmus})


def test_a_new_fmu_is_added_in_one_place(monkeypatch):
    """An FMU no scene has (a hydraulic press whose n feeds Friction.n), declared only in
    wiring.FMUS and wiring.CONNECTIONS: the scene validates, instantiates and connects it,
    stops holding n constant, the SSP export declares it, and the build and the CLI's
    ``build`` command list it (its adapter registered in tribofmu.fmu.registry, the FMU side)."""
    names = registry.FMU_NAMES
    monkeypatch.setattr(registry, "FMU_NAMES", names[:-1] + ("Press",) + names[-1:])
    press = wiring.FMU("Press", "press", lambda sc: {"n0": float(sc.conditions.n)}, outputs=("n",),
                       needs=("Friction",))
    monkeypatch.setattr(wiring, "FMUS", wiring.FMUS + (press,))
    monkeypatch.setattr(wiring, "CONNECTIONS",
                        wiring.CONNECTIONS + (wiring.Connection("Press", "n", "Friction", "n"),))
    base = load_scenario(FIG2)
    sc = dataclasses.replace(base, fmus=base.fmus + ("Press",))
    assert wiring.scene_problems(sc.fmus) == []
    assert wiring.scene_problems(("BlockSpring", "Press")) == [
        "scenario.fmus must include 'Friction' when it includes 'Press', got ['BlockSpring', 'Press']"]
    assert "Press.n -> Friction.n" in [str(c) for c in wiring.connections(sc)]
    insts = {i.fmu.name: i for i in wiring.instances(sc)}
    assert insts["Press"].start_values == {"n0": -20.0}
    assert insts["Friction"].constant_inputs == {"T": 290.0}  # n now comes through the connection
    ssd = system_structure(sc).decode()
    assert 'startElement="Press" startConnector="n" endElement="Friction" endConnector="n"' in ssd
    assert 'source="resources/Press.fmu"' in ssd
    # without the new FMU the archive is unchanged
    assert system_structure(base) == system_structure(dataclasses.replace(sc, fmus=base.fmus))
    # what gets built, and the CLI's help, follow the same declaration
    from tribofmu import build
    assert build.fmu_names()[-2:] == ("Press", "TriboPair")
    from tribofmu import cli
    assert "Thermal, Load, Press, TriboPair)" in " ".join(cli._parser().format_help().split())


def test_the_wiring_names_only_fmus_the_build_builds(monkeypatch):
    """Every FMU a scene can list is one tribofmu builds; an entry naming another is refused
    where it is declared."""
    assert {fmu.name for fmu in (*wiring.FMUS, wiring.PAIR)} == set(registry.fmu_names())
    with pytest.raises(ValueError, match="'Gearbox' is not one the build builds"):
        wiring.FMU("Gearbox", "gearbox", lambda sc: {}, outputs=())


def test_the_readme_lists_the_wiring():
    readme = (ROOT / "docs" / "hosts.md").read_text(encoding="utf-8")  # the page on archives and hosts
    for c in wiring.CONNECTIONS:
        assert str(c).replace(" -> ", " → ") in readme
