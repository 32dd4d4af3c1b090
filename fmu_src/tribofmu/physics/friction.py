"""Friction laws of the seed paper: dry (Amontons), fluid (power law) and boundary (Landau).

Pure physics, no FMI. Units are SI throughout:
dv [m/s] relative velocity ``V - v``; n [Pa] normal stress (negative in compression);
T [K] lubricant temperature; F [N] friction force on the lower block; f [1] excess volume.

Equation numbers refer to the seed paper (see ``shared/MODEL.md``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from .roots import illinois


DRY, FLUID, BOUNDARY = 0, 1, 2
REGIMES = {"dry": DRY, "fluid": FLUID, "boundary": BOUNDARY}
REGIME_NAMES = {code: name for name, code in REGIMES.items()}


def sign(x: float) -> float:
    """sgn(x) with sgn(0) = 0: the single-valued choice; the set-valued stick force is the
    coupling algorithm's business, not the law's."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@dataclass(frozen=True)
class LubricantConstants:
    """Landau boundary-lubricant constants (paper ref. [19]); SI units."""

    phi0_star: float = 5.0  # J/m^3
    lam: float = 2e11  # Pa, lambda
    lam_bar: float = 1e8  # Pa, lambda-bar
    mu_shear: float = 4.1e11  # Pa, shear modulus mu (not the friction coefficient)
    mu_shear_bar: float = 4e11  # Pa, mu-bar
    phi1: float = 1100.0  # J/m^3
    phi2: float = 2700.0  # J/m^3
    phi3: float = 2070.0  # J/m^3
    alpha: float = 0.45  # J/(K m^3)
    h: float = 1e-9  # m, lubricant thickness
    tau_f: float = 0.01  # Pa s, relaxation time of f
    tau_e: float = 1e-8  # s, Maxwell time


@dataclass(frozen=True)
class Effects:
    """Which terms of the boundary model are simulated (all on = the paper's model)."""

    melting: bool = True  # f evolves by eq. (21); off: f stays at its start value
    pressure: bool = True  # the normal-stress terms (e_ii in eq. 15, last term of eq. 21)
    temperature: bool = True  # alpha T in eq. (15)
    viscous: bool = True  # m sgn(dv)|dv|^(gamma+1) in eq. (23)
    elastic: bool = True  # tau S in eq. (23)


@dataclass(frozen=True)
class FrictionLaw:
    """One friction pair: the regime, its parameters, and (boundary) the lubricant.

    mu_friction [1] dry friction coefficient; S [m^2] contact area (dry load ``L = -n S``);
    m [Pa s^(gamma+1) m^(1-gamma)] and gamma [1] the power-law fluid, eq. (11)-(12).
    """

    regime: int = DRY
    mu_friction: float = 0.5
    S: float = 1.0
    m: float = 25.0
    gamma: float = 0.0
    lubricant: LubricantConstants = field(default_factory=LubricantConstants)
    effects: Effects = field(default_factory=Effects)

    # -- validation -------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Every parameter that is out of range, as ``name must be ..., got value``."""
        out = []
        if self.regime not in REGIME_NAMES:
            out.append(f"regime must be one of {sorted(REGIME_NAMES)} "
                       f"({', '.join(f'{k}={v}' for k, v in REGIME_NAMES.items())}), got {self.regime}")
        for name in ("mu_friction", "S", "m", "gamma"):
            if not math.isfinite(getattr(self, name)):
                out.append(f"{name} must be finite, got {getattr(self, name)}")
        if self.mu_friction < 0:
            out.append(f"mu_friction must be >= 0, got {self.mu_friction}")
        if not self.S > 0:
            out.append(f"S must be > 0, got {self.S}")
        if self.m < 0:
            out.append(f"m must be >= 0, got {self.m}")
        if not self.gamma > -1:
            out.append(f"gamma must be > -1 (force must vanish at rest), got {self.gamma}")
        lub = self.lubricant
        for f in fields(lub):
            value = getattr(lub, f.name)
            if not math.isfinite(value):
                out.append(f"{f.name} must be finite, got {value}")
        for name in ("lam", "mu_shear", "h", "tau_f", "tau_e", "phi3"):
            if not getattr(lub, name) > 0:
                out.append(f"{name} must be > 0, got {getattr(lub, name)}")
        for name in ("lam_bar", "mu_shear_bar"):
            if getattr(lub, name) < 0:
                out.append(f"{name} must be >= 0, got {getattr(lub, name)}")
        return out

    def input_problems(self, dv: float, n: float, T: float) -> list[str]:
        """Out-of-range inputs for this regime."""
        out = [f"{name} must be finite, got {value}"
               for name, value in (("dv", dv), ("n", n), ("T", T)) if not math.isfinite(value)]
        if self.regime == DRY and n > 0:
            out.append(f"n must be <= 0 (compression) for dry friction, got {n}")
        if self.regime == BOUNDARY and T < 0:
            out.append(f"T must be >= 0 K, got {T}")
        return out

    # -- force ----------------------------------------------------------------------
    def viscous_force(self, dv: float) -> float:
        """Power-law fluid force ``m sgn(dv) |dv|^(gamma+1)`` [N], eq. (11)."""
        return self.m * sign(dv) * abs(dv) ** (self.gamma + 1.0)

    def mu_eff(self, f: float) -> float:
        """Effective shear modulus [Pa], eq. (19) floored at 0 (paper's note 2)."""
        lub = self.lubricant
        return max(0.0, lub.mu_shear - lub.mu_shear_bar * f)

    def shear_strain(self, dv: float) -> float:
        """Stationary elastic shear strain eps [1], eq. (22)."""
        return dv * self.lubricant.tau_e / self.lubricant.h

    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        """Friction force F [N] on the lower block at relative velocity dv.

        Dry: ``mu L sgn(dv)`` with ``L = -n S``; fluid: eq. (11); boundary: eq. (23), the
        elastic term ``tau S = 2 mu_eff eps S`` carrying its own sign.
        """
        if self.regime == DRY:
            return self.mu_friction * (-n * self.S) * sign(dv)
        if self.regime == FLUID:
            return self.viscous_force(dv)
        F = 0.0
        if self.effects.elastic:
            F += 2.0 * self.mu_eff(f) * self.shear_strain(dv) * self.S
        if self.effects.viscous:
            F += self.viscous_force(dv)
        return F

    # -- boundary kinetics ----------------------------------------------------------
    # Bounds the work of one advance_f call (a few seconds): the hardest inputs found by
    # fuzzing (f relaxing from 1e7 over 12 decades of time) take about 13 000 sub-steps.
    MAX_SUBSTEPS = 100_000

    def kinetics_rate(self, f: float, dv: float, n: float, T: float) -> float:
        """df/dt [1/s] of the Landau-Khalatnikov equation (21)."""
        return self.rate_function(dv, n, T)(f)

    def rate_function(self, dv: float, n: float, T: float):
        """df/dt [1/s] of eq. (21) as a function of f alone, for inputs held over a step.

        What does not depend on f is computed once: the integrator calls this thousands
        of times per communication step."""
        lub, effects = self.lubricant, self.effects
        lam, lam_bar, mu, mu_bar = lub.lam, lub.lam_bar, lub.mu_shear, lub.mu_shear_bar
        phi1, phi2, phi3, inv_tau = lub.phi1, lub.phi2, lub.phi3, 1.0 / lub.tau_f
        # The floor keeps the pressure terms finite past both melting thresholds.
        floor = 1e-12 * (lam + mu)
        eps = self.shear_strain(dv)
        strain_term = mu_bar * 0.5 * (2.0 * eps) ** 2  # mub e_ij^2 without its e_ii part, eq. (17)
        base = lub.phi0_star + strain_term + (lub.alpha * T if effects.temperature else 0.0)
        pressure = effects.pressure
        # e_ii enters phi0 as (lamb/2 + mub/2) e_ii^2 (eqs. 15, 17) and the last term of
        # eq. (21) as -n^2 (lamb + mub) / moduli^2 = -(lamb + mub) e_ii^2.
        squeeze = -0.5 * (lam_bar + mu_bar) * n * n if pressure else 0.0

        def rate(f: float) -> float:
            rhs = base - phi1 * f + phi2 * f * f - phi3 * f * f * f
            if pressure:
                moduli = max(max(0.0, lam - lam_bar * f) + max(0.0, mu - mu_bar * f), floor)
                rhs += squeeze / (moduli * moduli)
            return rhs * inv_tau

        return rate

    # A moving relative velocity is followed in this many pieces, each held at its value in
    # the piece's middle (second order in the input where f is slow, so a melting happens
    # at the right time; where f is stiff it ends within an eighth of the step's change of
    # dv of the final equilibrium). Measured on fig6: with dv held at the step's end the
    # melting time converged like tol^0.6; with these pieces nRMS(v) follows tol.
    DV_PIECES = 4

    def advance_f(self, f: float, dv: float, n: float, T: float, h: float,
                  rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None) -> float:
        """Advance the excess volume f over a step h [s] with n, T held; returns f(t+h).

        dv [m/s] is held over the step, or, given dv_start, moves linearly from dv_start to
        dv (followed in DV_PIECES pieces, each held at its value in the piece's middle).

        Eq. (21) is stiff (rates 1e5 to 1e7 1/s) and, with inputs held, scalar and
        autonomous: its solution moves monotonically toward the nearest equilibrium and
        never crosses it. Each sub-step is exponential Rosenbrock-Euler, exact for the rate
        linearised at the sub-step's start (second order here), which lands on an
        equilibrium like a Newton step however stiff the rate. A sub-step that would cross
        an equilibrium is replaced by backward Euler with its root bracketed between f and
        that equilibrium, which cannot jump branches or blow up. The error of a sub-step is
        estimated from its defect (how far the true rate at its end is from the linear
        model's), which costs one rate evaluation instead of step doubling's extra two
        sub-steps; sub-steps grow where f sits near equilibrium.
        """
        if not self.effects.melting or h <= 0.0:
            return f
        if dv_start is None or dv_start == dv:
            return self._advance_held(f, dv, n, T, h, h, rtol, atol)[0]
        pieces = self.DV_PIECES
        sub = h / pieces
        for k in range(1, pieces + 1):
            dv_k = dv_start + (dv - dv_start) * (k - 0.5) / pieces
            f, sub = self._advance_held(f, dv_k, n, T, h / pieces, sub, rtol, atol)
        return f

    def _advance_held(self, f: float, dv: float, n: float, T: float, h: float, sub: float,
                      rtol: float, atol: float) -> tuple[float, float]:
        """advance_f with dv held, starting with sub-steps of sub [s]; returns f(t+h) and
        the sub-step to go on with."""
        rate = self.rate_function(dv, n, T)
        t_left, min_sub = h, 1e-12 * h
        r0 = rate(f)
        for _ in range(self.MAX_SUBSTEPS):
            if t_left <= 0.0 or r0 == 0.0:
                return f, sub
            sub = min(sub, t_left)
            f1, r1, err = self._substep(rate, f, r0, sub)
            tol = atol + rtol * abs(f1)
            if err <= tol or sub <= min_sub:
                f, r0 = f1, r1
                t_left -= sub
                # Floored: a sub-step forced through at the minimum must not shrink the next
                # one toward zero, or t_left would stop decreasing.
                sub = max(min_sub, sub * min(10.0, 0.9 * (tol / max(err, 1e-300)) ** 0.5))
            else:
                sub *= max(0.1, 0.9 * (tol / err) ** 0.5)
        if t_left <= 0.0 or r0 == 0.0:
            return f, sub
        raise ArithmeticError(f"eq. (21) needs more than {self.MAX_SUBSTEPS} sub-steps over "
                              f"h={h} s (reached f={f} with {t_left} s left)")

    def _substep(self, rate, f0: float, r0: float, h: float) -> tuple[float, float, float]:
        """One sub-step from f0 (rate r0) over h: (f1, its rate, estimated local error)."""
        eps = 1e-7 * (1.0 + abs(f0))
        slope = (rate(f0 + eps) - r0) / eps  # d(rate)/df [1/s]
        z = slope * h
        f_exp = None
        if z < 30.0:  # beyond, the linearisation grows without bound: leave it to Euler
            phi = h if abs(z) < 1e-12 else math.expm1(z) / slope
            f_exp = f0 + r0 * phi
            if math.isfinite(f_exp):
                r1 = rate(f_exp)
                if r0 * r1 > 0.0:  # has not crossed an equilibrium
                    # The linear model's rate at the end is r0 e^z; the true one is r1. The
                    # defect, integrated over the sub-step's effective length phi (h when
                    # slow, 1/|slope| when stiff), bounds the local error.
                    defect = r1 - r0 * math.exp(min(z, 30.0))
                    return f_exp, r1, 2.0 * abs(defect * phi)
        f1 = self._backward_euler(rate, f0, r0, h)
        r1 = rate(f1)
        # Crossing: both the linear model and backward Euler land near the equilibrium;
        # where they disagree, the sub-step was too long for the curvature of the rate.
        err = abs(f_exp - f1) if f_exp is not None and math.isfinite(f_exp) else 0.5 * h * abs(r1 - r0)
        return f1, r1, err

    def _backward_euler(self, rate, f0: float, rate0: float, h: float) -> float:
        if rate0 == 0.0:
            return f0
        direction = 1.0 if rate0 > 0 else -1.0

        def residual(y: float) -> float:  # signed so it starts < 0 and rises through the root
            return direction * (y - f0 - h * rate(y))

        # At least a few ulps: below that f0 + width == f0 and the bracket never opens
        # (a step of 1e-300 s moves f by less than one ulp).
        lo, width = f0, max(min(abs(h * rate0), 1e-3 * (1.0 + abs(f0))), 4.0 * math.ulp(f0))
        hi = f0 + direction * width
        for _ in range(400):
            if residual(hi) >= 0.0:
                break
            lo, width = hi, 2.0 * width
            hi = f0 + direction * width
        else:  # the cubic term guarantees an equilibrium; only non-finite inputs get here
            raise ArithmeticError(f"no equilibrium of eq. (21) found from f={f0}")
        return illinois(residual, lo, hi)
