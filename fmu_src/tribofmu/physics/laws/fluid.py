"""Fluid friction of a power-law lubricant, eq. (11): ``F = m sgn(dv) |dv|^(gamma+1)``."""
from __future__ import annotations

from ..friction import FrictionLaw, power_mean


class FluidLaw(FrictionLaw):
    """m = k S / h^(gamma+1), eq. (12); gamma < 0 pseudoplastic, 0 Newtonian, > 0 dilatant.
    Independent of the load and the temperature."""

    name, code, label = "fluid", 1, "fluid friction"
    keys = frozenset({"m", "gamma"})

    @property
    def has_power_law_term(self) -> bool:
        return True

    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        return self.viscous_force(dv)

    def path_mean_force(self, dv_start: float, dv: float, n: float, f: float) -> float:
        return self.m * power_mean(dv_start, dv, self.gamma + 1.0)

    def plot_items(self, fmt) -> list[str]:
        return [f"m = {fmt(self.m)}", f"γ = {fmt(self.gamma)}"]
