"""Scene options a user sees without running anything: options that cannot apply refused with
the reason, enum errors listing the choices, one canonical folder name per run, scenes by
name."""
from pathlib import Path

import pytest

from tribofmu import api, cli
from tribofmu.errors import ScenarioError
from tribofmu.scene.library import resolve_scene, scenes_dir


def test_a_bare_name_finds_the_shipped_scene_unless_a_file_here_has_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fig2_dry").mkdir()  # a run's output folder of that name hides nothing
    assert resolve_scene("fig2_dry") == scenes_dir() / "fig2_dry.toml"
    (tmp_path / "fig2_dry.toml").write_text("[drive]\nomega = 7.0\n")
    assert resolve_scene("fig2_dry.toml") == Path("fig2_dry.toml")
    assert api.load("fig2_dry.toml").drive.omega == 7.0
    assert resolve_scene("sub/fig2_dry") == Path("sub/fig2_dry")  # a path stays a path
    with pytest.raises(ScenarioError, match="no scene named 'fig9'"):
        resolve_scene("fig9")


# -- options that cannot apply -----------------------------------------------------------------------
@pytest.mark.parametrize("scene, override, reason", [
    ("fig2_dry", "thermal.C=1e-11", "no Thermal FMU"),
    ("fig2_dry", "load.n0=-30", "no Load FMU"),
    ("fig2_dry", "friction.gamma=0.5", "dry friction does not use it"),
    ("fig2_dry", "friction.tau_e=1e-7", "dry friction does not use it"),
    ("fig2_dry", "effects.melting=false", "boundary friction only"),
    ("fig2_dry", "conditions.T=350", "does not depend on the temperature"),
    ("fig5_newtonian", "friction.mu_friction=0.3", "fluid friction does not use it"),
    ("fig5_newtonian", "conditions.n=-40", "does not depend on the normal stress"),
    ("fig6_boundary", "friction.mu_friction=0.3", "boundary friction does not use it"),
    ("dry_load_oscillation", "conditions.n=-40", "comes from its Load FMU"),
    ("free_oscillator", "friction.mu_friction=0.3", "no Friction FMU"),
    ("free_oscillator", "drive.A=1e-3", "no Drive FMU"),
])
def test_an_override_that_cannot_apply_says_why(scene, override, reason):
    with pytest.raises(ScenarioError) as err:
        api.load(scene, [override])
    assert str(err.value).startswith(f"{scene}.toml: {override.split('=')[0]}: ") and reason in str(err.value)


def test_overrides_that_apply_are_accepted_and_checked_on_the_resulting_scene():
    sc = api.load("fig2_dry", ["friction.regime=fluid", "friction.gamma=0.5"])
    assert sc.friction.regime == "fluid" and sc.friction.gamma == 0.5
    assert api.load("boundary_heating", ["thermal.C=1e-11", "conditions.T=300"]).thermal.C == 1e-11
    assert api.load("fig6_boundary", ["effects.melting=false", "friction.tau_e=2e-8"]).friction.effects.melting is False
    assert api.load("free_oscillator", ["drive.omega=20"]).drive.omega == 20  # sets its time span


@pytest.mark.parametrize("key, value, choices", [("friction.regime", "2", "dry, fluid, boundary"),
                                                 ("load.program", "3", "constant, ramp, step, sine"),
                                                 ("simulation.algorithm", "1", "jacobi")])
def test_an_enum_error_lists_the_choices(key, value, choices):
    with pytest.raises(ScenarioError, match=f"{key} must be one of {choices}"):
        api.load("dry_load_oscillation", [f"{key}={value}"])


# -- one folder per run ------------------------------------------------------------------------------
def label(argv):
    args = cli._parser().parse_args(["simulate", *argv])
    scene = resolve_scene(args.scenario)
    sc = api.load(scene, args.overrides)
    return cli.label_overrides(args.overrides, args.algorithm, args.step, args.tol, args.max_wall, args.fmi,
                               scenario=sc, base=api.load(scene))


def test_equivalent_command_lines_name_the_same_folder():
    same = [["fig2_dry", "--step", "1e-3"], ["fig2_dry", "--set", "simulation.step=1e-3"],
            ["fig2_dry", "--set", "simulation.step=0.001"], ["fig2_dry", "--step", "0.0010"]]
    assert len({tuple(label(a).items()) for a in same}) == 1
    assert label(["fig2_dry", "--set", "drive.omega=80", "--set", "block.M=1"]) == \
        label(["fig2_dry", "--set", "block.M=1.0", "--set", "drive.omega=80.0"])
    assert label(["fig2_dry", "--set", "drive.omega=30"]) == {}  # the scene's own value: the same run
    assert label(["fig2_dry", "--fmi", "3"]) == {"fmi": "3"}
    assert label(["fig2_dry", "--max-wall", "60"]) == {"simulation.max_wall": "60"}
    assert label(["fig2_dry", "--set", "drive.omega=80.000001"]) != label(["fig2_dry", "--set", "drive.omega=80"])


