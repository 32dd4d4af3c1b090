"""The parameter tables of docs/model.md are what the physics' declarations generate
(tribofmu.scene.parameter_docs), and every declared group has its table there."""
from __future__ import annotations

from tribofmu.physics.parameters import declared
from tribofmu.physics.thermal import ThermalParams
from tribofmu.scene import parameter_docs

from scenes import ROOT

MODEL = ROOT / "docs" / "model.md"


def test_the_model_page_tables_are_the_declarations():
    text = MODEL.read_text(encoding="utf-8")
    assert parameter_docs.render(text) == text, (
        "docs/model.md's parameter tables differ from the declarations: "
        "run python -m tribofmu.scene.parameter_docs docs/model.md")


def test_every_declared_group_has_its_table_once():
    names = parameter_docs.marked(MODEL.read_text(encoding="utf-8"))
    assert sorted(names) == sorted(parameter_docs.groups())


def test_a_table_row_says_what_the_declaration_says():
    row = next(line for line in parameter_docs.table("friction").splitlines() if "`friction.gamma`" in line)
    assert row == ("| `γ` | `friction.gamma` | `gamma` | 1 | 0 | > -1 (force must vanish at rest) | "
                   "power-law exponent: < 0 pseudoplastic, 0 Newtonian, > 0 dilatant |")
    q = next(p for p in declared(ThermalParams) if p.name == "q")
    assert f"| {q.check.text} | {q.description} |" in parameter_docs.table("thermal")
    assert parameter_docs.number(2e11) == "2·10¹¹" and parameter_docs.number(1e-9) == "10⁻⁹"
    assert parameter_docs.unit("J/(K.m3)") == "J/(K m³)"


def test_the_tables_name_every_physics_key_a_scene_and_set_accept():
    """--set and a scene file accept exactly the keys of the tables (besides friction.regime
    and the scene's own tables: scenario, time, simulation)."""
    from tribofmu.scene.scenario import Scenario, to_dict

    tables = to_dict(Scenario("x"))
    accepted = {f"{table}.{key}" for table, keys in tables.items() if table not in ("scenario", "time", "simulation")
                for key in keys} - {"friction.regime"}
    documented = {f"{table}.{p.name}" for table, parameters in parameter_docs.groups().values() for p in parameters}
    assert accepted == documented
