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
from .stepsize import KINETICS_SUBSTEPS


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
        try:
            return self.m * sign(dv) * abs(dv) ** (self.gamma + 1.0)
        except OverflowError:  # not finite: for the FMU to refuse, naming F
            return self.m * sign(dv) * math.inf

    def mu_eff(self, f: float) -> float:
        """Effective shear modulus [Pa], eq. (19) floored at 0 (paper's note 2)."""
        lub = self.lubricant
        return max(0.0, lub.mu_shear - lub.mu_shear_bar * f)

    def melt_margin(self, f: float) -> float:
        """mu/mu_bar - f [1]: > 0 while the lubricant is solid-like (its elastic stress acts,
        eq. 19), <= 0 once molten; 1 for a law without a lubricant (or mu_bar = 0, when no f
        melts it): a phase change is a sign change, for a master to locate."""
        lub = self.lubricant
        if self.regime != BOUNDARY or not lub.mu_shear_bar > 0.0:
            return 1.0
        return lub.mu_shear / lub.mu_shear_bar - f

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

    def mean_force(self, dv_start: float, dv: float, n: float, f: float = 0.0) -> float:
        """Mean friction force [N] over a step in which dv moves linearly from dv_start to dv
        [m/s] with f held: exact, from the antiderivatives of the laws in dv.

        The coupling compares it with the force ramp the block felt: a force that peaks
        inside a step (a lubricant re-solidifying as dv passes 0) shows there, not at the
        step's ends."""
        if dv == dv_start:
            return self.force(dv, n, f)
        width = dv - dv_start

        def power_mean(exponent: float) -> float:  # mean of sgn(x)|x|^exponent on the path
            p = exponent + 1.0
            try:
                return (abs(dv) ** p - abs(dv_start) ** p) / (p * width)
            except OverflowError:  # as the force itself: not finite, for the FMU to refuse
                return math.copysign(math.inf, dv + dv_start)

        if self.regime == DRY:
            return self.mu_friction * (-n * self.S) * power_mean(0.0)
        viscous = self.m * power_mean(self.gamma + 1.0)
        if self.regime == FLUID:
            return viscous
        F = 0.0
        if self.effects.elastic:
            F += 2.0 * self.mu_eff(f) * self.shear_strain(0.5 * (dv + dv_start)) * self.S
        if self.effects.viscous:
            F += viscous
        return F

    # -- boundary kinetics ----------------------------------------------------------
    # Bounds the work of one advance_f call (a few seconds): the hardest inputs found by
    # fuzzing (f relaxing from 1e7 over 12 decades of time) take about 13 000 sub-steps.
    MAX_SUBSTEPS = 100_000

    def kinetics_rate(self, f: float, dv: float, n: float, T: float) -> float:
        """df/dt [1/s] of the Landau-Khalatnikov equation (21)."""
        return self.rate_function(dv, n, T)(f)

    def rate_function(self, dv: float, n: float, T: float):
        """df/dt [1/s] of eq. (21) as a function of f alone, for inputs held."""
        rate = self._rates(n, T)[0]
        return lambda f: rate(f, dv)

    def _rates(self, n: float, T: float):
        """Eq. (21) for n, T held: rate(f, dv) [1/s], its slope d rate/df (f) [1/s], and
        d rate/d(dv) divided by dv [1/(s (m/s)^2)].

        What does not depend on f or dv is computed once: the integrator calls these
        thousands of times per communication step."""
        lub, effects = self.lubricant, self.effects
        lam, lam_bar, mu, mu_bar = lub.lam, lub.lam_bar, lub.mu_shear, lub.mu_shear_bar
        phi1, phi2, phi3, inv_tau = lub.phi1, lub.phi2, lub.phi3, 1.0 / lub.tau_f
        # The floor keeps the pressure terms finite past both melting thresholds.
        floor = 1e-12 * (lam + mu)
        # mub e_ij^2 without its e_ii part, eq. (17): 2 mub eps^2 with eps = dv tau_e / h (22)
        strain = 2.0 * mu_bar * (lub.tau_e / lub.h) ** 2
        base = lub.phi0_star + (lub.alpha * T if effects.temperature else 0.0)
        pressure = effects.pressure
        # e_ii enters phi0 as (lamb/2 + mub/2) e_ii^2 (eqs. 15, 17) and the last term of
        # eq. (21) as -n^2 (lamb + mub) / moduli^2 = -(lamb + mub) e_ii^2.
        squeeze = -0.5 * (lam_bar + mu_bar) * n * n if pressure else 0.0

        def rate(f: float, dv: float) -> float:
            rhs = base + strain * dv * dv - phi1 * f + phi2 * f * f - phi3 * f * f * f
            if pressure:
                # max(max(0, lam_eff) + max(0, mu_eff), floor), without the builtin's calls
                # (the hottest line of the kinetics: ~4 evaluations a sub-step)
                lam_eff, mu_eff = lam - lam_bar * f, mu - mu_bar * f
                moduli = (lam_eff if lam_eff > 0.0 else 0.0) + (mu_eff if mu_eff > 0.0 else 0.0)
                if moduli < floor:
                    moduli = floor
                rhs += squeeze / (moduli * moduli)
            return rhs * inv_tau

        def slope(f: float) -> float:
            d = -phi1 + 2.0 * phi2 * f - 3.0 * phi3 * f * f
            if pressure:
                lam_eff, mu_eff = lam - lam_bar * f, mu - mu_bar * f
                moduli = (lam_eff if lam_eff > 0.0 else 0.0) + (mu_eff if mu_eff > 0.0 else 0.0)
                if moduli > floor:
                    d_moduli = -(lam_bar if lam_eff > 0.0 else 0.0) - (mu_bar if mu_eff > 0.0 else 0.0)
                    d -= 2.0 * squeeze / moduli ** 3 * d_moduli
            return d * inv_tau

        return rate, slope, 2.0 * strain * inv_tau

    def advance_f(self, f: float, dv: float, n: float, T: float, h: float,
                  rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None) -> float:
        """f(t+h) of :meth:`advance`."""
        return self.advance(f, dv, n, T, h, rtol, atol, dv_start)[0]

    def advance(self, f: float, dv: float, n: float, T: float, h: float,
                rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None) -> tuple[float, float]:
        """Advance the excess volume f over a step h [s] with n, T held; returns f(t+h) and
        the mean friction force [N] over the step along the way.

        dv [m/s] is held over the step, or, given dv_start, moves linearly from dv_start to
        dv over it (the relative velocity the coupling saw at the step's start and end).

        Eq. (21) is stiff (rates 1e5 to 1e7 1/s): f follows an equilibrium that moves with
        dv. Each sub-step is exponential Rosenbrock-Euler for the non-autonomous equation
        (Hochbruck & Ostermann): exact for the rate linearised in f *and in time* at the
        sub-step's start, so however stiff, f ends where the moving equilibrium is, less the
        lag the true solution has. (Holding dv over a piece instead lags f by half the
        piece; on fig6's rig with other viscous exponents that lag shifted every
        re-solidification at a velocity reversal: 0.5 nRMS(v).) A sub-step that would cross
        an equilibrium of the rate at its end is replaced by backward Euler with its root
        bracketed between f and that equilibrium, which cannot jump branches or blow up.
        The error of a sub-step is estimated from its defect (how far the true rate at its
        end is from the linear model's): one rate evaluation instead of step doubling's
        extra two sub-steps; sub-steps grow where f sits near its equilibrium.
        """
        dv0 = dv if dv_start is None else dv_start
        if self.regime != BOUNDARY or not self.effects.melting or h <= 0.0:
            return f, self.mean_force(dv0, dv, n, f)
        dv_rate = (dv - dv0) / h  # m/s^2
        rate, slope, rate_dv = self._rates(n, T)
        mean_force = self._boundary_mean_force(n)
        s, sub, min_sub = 0.0, h, 1e-12 * h
        r0 = rate(f, dv0)
        impulse = 0.0  # N s, the force integrated over the accepted sub-steps
        for count in range(self.MAX_SUBSTEPS):
            if s >= h:
                return f, impulse / h
            if count == self.MAX_SUBSTEPS // 2 and dv_rate != 0.0:
                # An input that swings the equilibrium across decades within the step (a host
                # jumping dv by 1e6 m/s) cannot be followed at this tolerance: hold it at its
                # end value for the rest of the step, where f lands on equilibria in a few
                # sub-steps (what the FMU did before it followed dv through the step).
                dv0, dv_rate, r0 = dv, 0.0, rate(f, dv)
            s1 = h if sub >= h - s else s + sub
            dv_s = dv0 + dv_rate * s if dv_rate else dv
            dv_s1 = dv if s1 >= h or not dv_rate else dv0 + dv_rate * s1
            f1, r1, err = self._substep(rate, slope, f, r0, dv_s1, rate_dv * dv_s * dv_rate, s1 - s)
            tol = atol + rtol * abs(f1)
            if err <= tol or sub <= min_sub:
                # f moves little where the sub-step is long: the force's mean over it is the
                # mean along dv at f's mean (the elastic term is linear in dv, the viscous
                # term integrated exactly)
                impulse += (s1 - s) * mean_force(dv_s, dv_s1, 0.5 * (f + f1))
                f, r0, s = f1, r1, s1
                # Floored: a sub-step forced through at the minimum must not shrink the next
                # one toward zero, or s would stop advancing.
                sub = max(min_sub, sub * KINETICS_SUBSTEPS.factor(err / tol, order=1))
            else:
                sub *= KINETICS_SUBSTEPS.factor(err / tol, order=1)
        if s >= h:
            return f, impulse / h
        raise ArithmeticError(f"eq. (21) needs more than {self.MAX_SUBSTEPS} sub-steps over "
                              f"h={h} s (reached f={f} with {h - s} s left)")

    def _boundary_mean_force(self, n: float):
        """:meth:`mean_force` of the boundary law for n held, as a function of (dv_start, dv,
        f): the same arithmetic, with the regime's branches and the parameters' lookups done
        once per :meth:`advance` instead of once per sub-step."""
        lub, effects = self.lubricant, self.effects
        elastic, viscous_on = effects.elastic, effects.viscous
        mu, mu_bar, tau_e, thickness, S = lub.mu_shear, lub.mu_shear_bar, lub.tau_e, lub.h, self.S
        m, p = self.m, self.gamma + 2.0
        force = self.force

        def mean_force(dv_start: float, dv: float, f: float) -> float:
            if dv == dv_start:
                return force(dv, n, f)
            try:
                viscous = m * ((abs(dv) ** p - abs(dv_start) ** p) / (p * (dv - dv_start)))
            except OverflowError:  # as the force itself: not finite, for the FMU to refuse
                viscous = m * math.copysign(math.inf, dv + dv_start)
            F = 0.0
            if elastic:
                mu_eff = mu - mu_bar * f
                F += 2.0 * (mu_eff if mu_eff > 0.0 else 0.0) * (0.5 * (dv + dv_start) * tau_e / thickness) * S
            if viscous_on:
                F += viscous
            return F

        return mean_force

    @staticmethod
    def _substep(rate, slope, f0: float, r0: float, dv1: float, r_t: float,
                 h: float) -> tuple[float, float, float]:
        """One sub-step over h [s] from f0 (rate r0) to the relative velocity dv1 at its end,
        the rate moving in time by r_t [1/s^2] through dv: (f1, its rate, estimated error)."""
        z = slope(f0) * h
        f_exp = None
        if z < 30.0:  # beyond, the linearisation grows without bound: leave it to Euler
            if abs(z) < 1e-5:
                phi1, phi2 = 1.0 + z / 2.0, 0.5 + z / 6.0
            else:
                em1 = math.expm1(z)
                phi1, phi2 = em1 / z, (em1 - z) / (z * z)
            f_exp = f0 + h * phi1 * r0 + h * h * phi2 * r_t
            if math.isfinite(f_exp):
                r1 = rate(f_exp, dv1)
                # The linear model's rate at the end; the true one is r1. The defect,
                # integrated over the sub-step's effective length (h when slow, 1/|slope|
                # when stiff), bounds the local error.
                r_model = r0 * (1.0 + z * phi1) + h * phi1 * r_t
                if r_model * r1 > 0.0 or r1 == 0.0:  # has not crossed an equilibrium
                    return f_exp, r1, 2.0 * abs((r1 - r_model) * h * phi1)
        end_rate = lambda y: rate(y, dv1)  # noqa: E731 (the rate at the sub-step's end)
        f1 = FrictionLaw._backward_euler(end_rate, f0, end_rate(f0), h)
        r1 = end_rate(f1)
        # Crossing: both the linear model and backward Euler land near the equilibrium;
        # where they disagree, the sub-step was too long for the curvature of the rate.
        err = abs(f_exp - f1) if f_exp is not None and math.isfinite(f_exp) else 0.5 * h * abs(r1 - r0)
        return f1, r1, err

    @staticmethod
    def _backward_euler(rate, f0: float, rate0: float, h: float) -> float:
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
