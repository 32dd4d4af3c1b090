"""Dry (Amontons) friction, eqs. (4), (5): ``F = mu L sgn(dv)``, ``L = -n S``."""
from __future__ import annotations

from ..friction import FrictionLaw, power_mean, sign


class DryLaw(FrictionLaw):
    """mu_friction the friction coefficient, S the contact area. The law is single-valued
    (sgn(0) = 0); holding the blocks at dv = 0 up to mu L is the coupling's."""

    name, code, label = "dry", 0, "dry friction"
    keys = frozenset({"mu_friction", "S"})
    sticks = True
    constant_slip_force = True
    load_shown_as = "L"

    def input_problems(self, dv: float, n: float, T: float) -> list[str]:
        out = super().input_problems(dv, n, T)
        if n > 0:
            out.append(f"n must be <= 0 (compression) for dry friction, got {n}")
        return out

    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        return self.mu_friction * self.load(n) * sign(dv)

    def path_mean_force(self, dv_start: float, dv: float, n: float, f: float) -> float:
        return self.mu_friction * self.load(n) * power_mean(dv_start, dv, 0.0)

    def static_limit(self, n: float) -> float:
        return self.mu_friction * abs(self.load(n))

    def slip_force(self, dv: float, n: float, direction: float) -> float:
        return direction * self.static_limit(n)

    def plot_items(self, fmt) -> list[str]:
        return [f"μ = {fmt(self.mu_friction)}"]
