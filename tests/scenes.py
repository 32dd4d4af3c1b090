"""The project's scenario files, named once for every test tier and benchmark: the scenes
that ship inside the package (tribofmu/scenarios; the repository's scenarios/ links there)."""
from __future__ import annotations

from pathlib import Path

from tribofmu.scene.library import scenes_dir

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = scenes_dir()
PAPER_SCENES = ("fig2_dry", "fig4_dry_w130", "fig5_pseudoplastic", "fig5_newtonian", "fig5_dilatant",
                "fig6_boundary")
FIG2 = SCENARIOS / "fig2_dry.toml"
NEWTONIAN = SCENARIOS / "fig5_newtonian.toml"


def scene(name: str) -> Path:
    """``scenarios/<name>.toml``."""
    return SCENARIOS / f"{name}.toml"
