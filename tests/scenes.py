"""The project's scenario files, named once for every test tier and benchmark."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
PAPER_SCENES = ("fig2_dry", "fig4_dry_w130", "fig5_pseudoplastic", "fig5_newtonian", "fig5_dilatant",
                "fig6_boundary")
FIG2 = SCENARIOS / "fig2_dry.toml"
NEWTONIAN = SCENARIOS / "fig5_newtonian.toml"


def scene(name: str) -> Path:
    """``scenarios/<name>.toml``."""
    return SCENARIOS / f"{name}.toml"
