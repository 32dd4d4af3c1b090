"""Mixed friction (the Stribeck curve): static friction breaking down to Coulomb friction
with a viscous term,

    F = [mu_c + (mu_s - mu_c) exp(-(|dv|/v_s)^delta)] L sgn(dv) + m dv,    L = -n S,

with true stick: at dv = 0 the contact holds any force up to mu_s L (the coupling's stick,
as for dry friction). The fourth basic type of friction the seed paper names and leaves aside.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..friction import FrictionLaw, sign
from ..parameters import above, parameter

# Below this relative width of a step's dv path the exact mean (a difference of
# antiderivatives over the width) loses more digits than the midpoint rule's error
# (width^2 relative) costs: the midpoint force is taken instead.
NARROW_PATH = 1e-6
# The series and continued fraction of the incomplete gamma function stop at this
# relative change (double precision).
GAMMA_EPS = 1e-16
GAMMA_MAX_TERMS = 500  # both converge in < 100 terms for the exponents a = 1/delta >= 1e-2


def lower_gamma_regularized(a: float, x: float) -> float:
    """P(a, x) = gamma(a, x) / Gamma(a) for a > 0, x >= 0 (series below a + 1, continued
    fraction above; Numerical Recipes 6.2): the physics ships without scipy."""
    if x <= 0.0:
        return 0.0
    log_prefactor = a * math.log(x) - x - math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        for k in range(1, GAMMA_MAX_TERMS):
            term *= x / (a + k)
            total += term
            if abs(term) < abs(total) * GAMMA_EPS:
                break
        return total * math.exp(log_prefactor)
    tiny = 1e-300  # Lentz's floor for a vanishing denominator
    b, c, d = x + 1.0 - a, 1.0 / tiny, 1.0 / (x + 1.0 - a)
    h = d
    for k in range(1, GAMMA_MAX_TERMS):
        an = -k * (k - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < GAMMA_EPS:
            break
    return 1.0 - math.exp(log_prefactor) * h


@dataclass(frozen=True)
class MixedLaw(FrictionLaw):
    """The Stribeck curve above: mu_c is mu_friction, m the fluid law's m at gamma = 0, S the
    contact area; what the law adds is declared below."""

    name, code, label = "mixed", 3, "mixed friction"
    keys = frozenset({"mu_friction", "m", "S"})  # and its own parameters, below
    sticks = True
    load_shown_as = "L"

    mu_static: float = parameter(0.6, "1", "mixed: static friction coefficient mu_s >= mu_friction (the kinetic mu_c)",
                                 symbol="μs")
    v_stribeck: float = parameter(0.01, "m/s", "mixed: Stribeck velocity v_s over which mu falls from mu_s to mu_c",
                                  above(0), symbol="vs", note="0.01 m/s is a sixth of `A ω` on Fig. 2's rig")
    stribeck_exponent: float = parameter(2.0, "1", "mixed: exponent delta of the Stribeck curve exp(-(|dv|/v_s)^delta)",
                                         above(0), symbol="δ", note="2: a Gaussian")

    def problems(self) -> list[str]:
        out = super().problems()
        if not self.mu_static >= self.mu_friction:
            out.append(f"mu_static must be >= mu_friction ({self.mu_friction}: static friction is not "
                       f"below kinetic), got {self.mu_static}")
        return out

    def input_problems(self, dv: float, n: float, T: float) -> list[str]:
        out = super().input_problems(dv, n, T)
        if n > 0:
            out.append(f"n must be <= 0 (compression) for mixed friction, got {n}")
        return out

    def coefficient(self, speed: float) -> float:
        """The Stribeck curve mu(|dv|) [1] at speed = |dv| [m/s]."""
        return self.mu_friction + (self.mu_static - self.mu_friction) * math.exp(
            -(speed / self.v_stribeck) ** self.stribeck_exponent)

    def slip_force(self, dv: float, n: float, direction: float) -> float:
        return direction * self.coefficient(abs(dv)) * self.load(n) + self.m * dv

    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        return self.slip_force(dv, n, sign(dv))

    def static_limit(self, n: float) -> float:
        return self.mu_static * abs(self.load(n))

    @property
    def slope_bounded(self) -> bool:
        """The Stribeck curve's slope at breakaway, -(mu_s - mu_c) delta (s/v_s)^delta / s,
        is bounded as s -> 0 only for delta >= 1 (or no Stribeck drop)."""
        return self.stribeck_exponent >= 1.0 or self.mu_static == self.mu_friction

    def _coefficient_integral(self, speed: float) -> float:
        """The integral of mu(s) ds from 0 to speed [m/s], exact (an incomplete gamma function)."""
        a = 1.0 / self.stribeck_exponent
        decay = self.v_stribeck * math.gamma(1.0 + a) * lower_gamma_regularized(
            a, (speed / self.v_stribeck) ** self.stribeck_exponent)
        return self.mu_friction * speed + (self.mu_static - self.mu_friction) * decay

    def path_mean_force(self, dv_start: float, dv: float, n: float, f: float) -> float:
        """Exact: the antiderivative of sgn(x) mu(|x|) is the integral of mu up to |x|."""
        width = dv - dv_start
        if abs(width) <= NARROW_PATH * (abs(dv) + abs(dv_start)) and dv * dv_start > 0.0:
            return self.force(0.5 * (dv + dv_start), n, f)
        coulomb = (self._coefficient_integral(abs(dv)) - self._coefficient_integral(abs(dv_start))) / width
        return coulomb * self.load(n) + self.m * 0.5 * (dv + dv_start)

    def plot_items(self, fmt) -> list[str]:
        return [f"μs = {fmt(self.mu_static)}", f"μc = {fmt(self.mu_friction)}",
                f"vs = {fmt(self.v_stribeck)} m/s", f"δ = {fmt(self.stribeck_exponent)}",
                f"m = {fmt(self.m)} N s/m"]
