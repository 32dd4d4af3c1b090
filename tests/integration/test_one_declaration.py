"""One declaration per parameter, live: a made-up parameter added to the mixed law in ONE
place (one line in physics/laws/mixed.py, in a copy of the source tree) reaches the scene file,
``--set``, its axis unit, the wiring to the FMU, the Friction FMU's modelDescription.xml (built
from that copy) and the docs table generator; its range is checked by the law with the
declaration's message. A second test holds each law parameter's unit and range written once."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
import zipfile

import pytest

from scenes import ROOT

pytestmark = pytest.mark.integration

SOURCE = ROOT / "fmu_src" / "tribofmu"
ANCHOR = "    stribeck_exponent: float = parameter("
WOBBLE = ('    wobble: float = parameter(0.25, "m/s", "mixed: a made-up speed, for a test", above(0), '
          'symbol="w")\n')

PROBE = textwrap.dedent('''
    import sys
    from pathlib import Path
    import tribofmu
    assert Path(tribofmu.__file__).resolve().is_relative_to(Path(sys.argv[1]).resolve()), tribofmu.__file__
    from tribofmu.build import build_fmus
    from tribofmu.errors import ScenarioError
    from tribofmu.scene.parameter_docs import table
    from tribofmu.scene.scenario import UNITS, load_scenario
    from tribofmu.scene.wiring import fmu_parameters

    scene = Path(sys.argv[1]) / "wobble.toml"
    scene.write_text('[friction]\\nregime = "mixed"\\nwobble = 0.3\\n')
    sc = load_scenario(scene)
    print("scene", sc.friction.wobble, sc.friction.law().wobble)
    print("set", load_scenario(scene, ["friction.wobble=0.4"]).friction.wobble)
    for values in (["friction.wobble=-1"], ["friction.regime=dry", "friction.wobble=0.4"]):
        try:
            load_scenario(scene, values)
        except ScenarioError as exc:
            print("refused", exc)
    print("unit", UNITS["friction.wobble"])
    print("wiring", fmu_parameters(sc)["Friction"]["wobble"])
    print("docs", [line for line in table("mixed").splitlines() if "wobble" in line][0])
    build_fmus(Path(sys.argv[1]) / "fmus", names=("Friction",))
''')


def test_a_parameter_declared_once_reaches_scene_set_wiring_fmu_and_docs(tmp_path):
    copy = tmp_path / "src" / "tribofmu"
    shutil.copytree(SOURCE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    mixed = copy / "physics" / "laws" / "mixed.py"
    text = mixed.read_text(encoding="utf-8")
    assert text.count(ANCHOR) == 1
    mixed.write_text(text.replace(ANCHOR, WOBBLE + ANCHOR), encoding="utf-8")

    env = {**os.environ, "PYTHONPATH": str(tmp_path / "src"), "TRIBOFMU_CACHE": str(tmp_path / "cache")}
    run = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path)], env=env, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "scene 0.3 0.3" in out
    assert "set 0.4" in out
    assert "refused wobble.toml: friction.wobble must be > 0, got -1" in out
    assert "refused wobble.toml: friction.wobble: mixed friction does not use it" not in out
    assert "refused wobble.toml: friction.wobble: dry friction does not use it" in out
    assert "unit m/s" in out and "wiring 0.3" in out
    assert "| `w` | `friction.wobble` | `wobble` | m/s | 0.25 | > 0 | mixed: a made-up speed, for a test |" in out

    with zipfile.ZipFile(tmp_path / "fmus" / "Friction.fmu") as fmu:
        xml = fmu.read("modelDescription.xml").decode()
    variable = re.search(r'<ScalarVariable name="wobble"[^>]*>\s*<Real[^>]*/>', xml)
    assert variable, "wobble is no variable of the built Friction FMU"
    assert 'causality="parameter"' in variable.group(0)
    assert 'description="mixed: a made-up speed, for a test"' in variable.group(0)
    assert 'start="0.25"' in variable.group(0) and 'unit="m/s"' in variable.group(0)


def test_each_law_parameter_unit_and_range_is_written_once():
    """In fmu_src, the unit and the range message of each law parameter stand once: in its
    declaration (the FMU, the scene, the wiring and the docs read it from there)."""
    from tribofmu.physics.laws import law_fields

    sources = {p: p.read_text(encoding="utf-8") for p in SOURCE.rglob("*.py")}
    for parameter in law_fields():
        declaration = re.compile(rf"\b{parameter.name}: float = parameter\(")
        where = [p.relative_to(SOURCE).as_posix() for p, text in sources.items() if declaration.search(text)]
        assert len(where) == 1, (parameter.name, where)
        if parameter.check is not None:
            message = f"{parameter.name} must be {parameter.check.text}"
            stated = [p for p, text in sources.items() if message in text]
            assert not stated, (message, stated)  # the message is the Range's, written nowhere
    assert sum(text.count("force must vanish at rest") for text in sources.values()) == 1
    assert sum(text.count('"N.(s/m)^(gamma+1)"') for text in sources.values()) == 1
