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


# Mixed (Stribeck) friction (scene mixed_stribeck) at parameter points no scene uses: other
# rig, load, both coefficients, Stribeck velocity and exponent (Gaussian, exponential,
# steeper) and viscous coefficient (including none).
MIXED_POINTS = {
    "p1": {"drive.omega": 26.0, "drive.A": 1.7e-3, "block.M": 0.45, "block.K": 5200.0,
           "friction.mu_friction": 0.33, "friction.mu_static": 0.52, "friction.v_stribeck": 0.008,
           "friction.m": 3.0, "conditions.n": -13.0},
    "p2": {"drive.omega": 35.0, "drive.A": 2.2e-3, "block.M": 0.8, "block.K": 6100.0,
           "friction.mu_friction": 0.45, "friction.mu_static": 0.6, "friction.v_stribeck": 0.02,
           "friction.stribeck_exponent": 1.0, "friction.m": 0.0, "conditions.n": -25.0},
    "p3": {"drive.omega": 22.0, "drive.A": 1.5e-3, "block.M": 0.5, "block.K": 4000.0,
           "friction.mu_friction": 0.25, "friction.mu_static": 0.45, "friction.v_stribeck": 0.005,
           "friction.stribeck_exponent": 3.0, "friction.m": 8.0, "conditions.n": -18.0},
}
MIXED_SHORT = {"time.periods": 2.0, "time.window": [1.0, 2.0]}  # two periods: seconds a run
