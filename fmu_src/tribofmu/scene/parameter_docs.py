"""The parameter tables of docs/model.md, generated from the physics' declarations
(:mod:`tribofmu.physics.parameters`): one table a group, written between the markers

    <!-- parameters: NAME -->
    ...
    <!-- end parameters: NAME -->

``python -m tribofmu.scene.parameter_docs [docs/model.md]`` rewrites them in place; a test
fails when the page's tables differ from what the declarations generate.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

from ..physics.block import BlockParams
from ..physics.drive import DriveParams
from ..physics.friction import START_F, Conditions, Effects, FrictionLaw, LubricantConstants
from ..physics.laws import LAWS
from ..physics.load import LoadProgram
from ..physics.parameters import Parameter, declared, display_unit, own_parameters
from ..physics.thermal import ThermalParams


def groups() -> dict[str, tuple[str, tuple[Parameter, ...]]]:
    """Each table's name: (the scene table its keys are in, its parameters); a law that adds
    parameters has its own table, named after the law."""
    out = {"drive": ("drive", declared(DriveParams)), "block": ("block", declared(BlockParams)),
           "conditions": ("conditions", declared(Conditions)),
           "friction": ("friction", (*declared(FrictionLaw), START_F)),
           "lubricant": ("friction", declared(LubricantConstants)), "effects": ("effects", declared(Effects))}
    out.update({law.name: ("friction", own) for law in LAWS.values() if (own := own_parameters(law, FrictionLaw))})
    out.update({"thermal": ("thermal", declared(ThermalParams)), "load": ("load", declared(LoadProgram))})
    return out


_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def number(value) -> str:
    """A default as the docs write it: ``2·10¹¹``, ``10⁻⁹``, ``0.45``, ``true``."""
    if isinstance(value, bool):
        return str(value).lower()
    if value == 0 or 1e-3 <= abs(value) < 1e5:
        return f"{value:g}"
    mantissa, exponent = f"{value:e}".split("e")
    power = "10" + str(int(exponent)).translate(_SUPERSCRIPT)
    mantissa = f"{float(mantissa):g}"
    return power if mantissa == "1" else f"{mantissa}·{power}"


def unit(text: str) -> str:
    """``J/(K.m3)`` -> ``J/(K m³)``."""
    return display_unit(text).replace("^2", "²").replace("^3", "³")


def table(name: str) -> str:
    """The markdown table of one group."""
    scene_table, parameters = groups()[name]
    rows = ["| symbol | scene key | FMU variable | unit | default | range | meaning |",
            "|---|---|---|---|---|---|---|"]
    for p in parameters:
        meaning = p.description + (f"; {p.note}" if p.note else "")
        allowed = p.check.described if p.check else "finite"
        cells = [f"`{p.symbol or p.name}`", f"`{scene_table}.{p.name}`", f"`{p.fmu_variable}`", unit(p.unit),
                 number(p.default), allowed, meaning]
        rows.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(rows)


_BLOCK = re.compile(r"(<!-- parameters: (\S+) -->\n).*?(<!-- end parameters: \2 -->)", re.DOTALL)


def render(text: str) -> str:
    """The page with every marked table replaced by what the declarations generate."""
    return _BLOCK.sub(lambda m: f"{m.group(1)}{table(m.group(2))}\n{m.group(3)}", text)


def marked(text: str) -> list[str]:
    """The names of the tables a page marks."""
    return [m.group(2) for m in _BLOCK.finditer(text)]


def main(argv: list[str] | None = None) -> int:
    path = Path((argv if argv is not None else sys.argv[1:] or ["docs/model.md"])[0])
    text = path.read_text(encoding="utf-8")
    path.write_text(render(text), encoding="utf-8")
    missing = sorted(set(groups()) - set(marked(text)))
    if missing:
        print(f"{path}: no table marked for {', '.join(missing)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
