"""Boundary friction: the Landau theory of a thin lubricant layer, eqs. (13)-(23).

The lubricant's state is its excess volume f [1]; its kinetics, eq. (21), is stiff and
advanced inside a step by exponential Rosenbrock-Euler sub-steps (:meth:`BoundaryLaw.advance`).
"""
from __future__ import annotations

import math
import sys

from ..friction import START_F, FrictionLaw, LubricantConstants, power_mean
from ..parameters import declared
from ..roots import illinois
from ..stepsize import KINETICS_SUBSTEPS
from .tangent import StepTangent

# The sub-steps' rule (KINETICS_SUBSTEPS.factor at order 1: the defect estimate of a stiff
# sub-step grows as its length squared), its constants bound once.
_SUBSTEP_FACTOR = KINETICS_SUBSTEPS.factor_function(order=1)

# The kinetics' tolerance (absolute and relative on f) inside a step: the Friction and TriboPair
# FMUs' default ``kinetics_tol``, and the one the coupling's carry differentiates the step at
# (coupling/variational.py). Twenty times below the master's default step tolerance on the
# force; tighter only costs sub-steps (fig6: the same nRMS(v) at 1e-5 and 1e-6).
KINETICS_TOL = 1e-5

# Below this span of dv over a step (relative to |dv|), the viscous mean's slopes in closed form
# lose more to cancellation (eps / r^2: their numerators are of order span^2) than the middle's
# slope misses them by (r): the two balance at r = eps^(1/3).
_CANCELLATION = sys.float_info.epsilon ** (1.0 / 3.0)


class BoundaryLaw(FrictionLaw):
    """F = tau S + m sgn(dv)|dv|^(gamma+1), eq. (23), with the lubricant's constants and the
    model's switches (``effects``). S the contact area; m, gamma the viscous term."""

    name, code, label = "boundary", 2, "boundary friction"
    keys = frozenset({"S", "m", "gamma", START_F.name} | {p.name for p in declared(LubricantConstants)})
    has_state = True
    gives_step_map = True  # (step_sensitivities)
    load_shown_as = "n"
    reads_temperature = True

    def input_problems(self, dv: float, n: float, T: float) -> list[str]:
        out = super().input_problems(dv, n, T)
        if T < 0:
            out.append(f"T must be >= 0 K, got {T}")
        return out

    @property
    def has_power_law_term(self) -> bool:
        return self.effects.viscous

    def mu_eff(self, f: float) -> float:
        """Effective shear modulus [Pa], eq. (19) floored at 0 (paper's note 2)."""
        lub = self.lubricant
        return max(0.0, lub.mu_shear - lub.mu_shear_bar * f)

    def melt_threshold(self) -> float | None:
        """mu/mu_bar [1]: the elastic stress acts below it (eq. 19); None for mu_bar = 0
        (no f melts the layer)."""
        lub = self.lubricant
        return lub.mu_shear / lub.mu_shear_bar if lub.mu_shear_bar > 0.0 else None

    def shear_strain(self, dv: float) -> float:
        """Stationary elastic shear strain eps [1], eq. (22)."""
        return dv * self.lubricant.tau_e / self.lubricant.h

    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        """Eq. (23): the elastic term ``tau S = 2 mu_eff eps S`` carries its own sign."""
        F = 0.0
        if self.effects.elastic:
            F += 2.0 * self.mu_eff(f) * self.shear_strain(dv) * self.S
        if self.effects.viscous:
            F += self.viscous_force(dv)
        return F

    def path_mean_force(self, dv_start: float, dv: float, n: float, f: float) -> float:
        F = 0.0
        if self.effects.elastic:
            F += 2.0 * self.mu_eff(f) * self.shear_strain(0.5 * (dv + dv_start)) * self.S
        if self.effects.viscous:
            F += self.m * power_mean(dv_start, dv, self.gamma + 1.0)
        return F

    def plot_items(self, fmt) -> list[str]:
        return [f"m = {fmt(self.m)}", f"γ = {fmt(self.gamma)}"]

    # -- kinetics -------------------------------------------------------------------
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

    def _kinetics(self, n: float, T: float):
        """(rate, slope, rate_dv) of :meth:`_rates` and the mean force of
        :meth:`_boundary_mean_force` for n, T held, made once per (n, T) a law sees in a row
        (a scene holds n and T, or moves them slowly: the FMU asks again on every step)."""
        cached = self.__dict__.get("_kinetics_cache")
        if cached is not None and cached[0] == n and cached[1] == T:
            return cached[2]
        made = (*self._rates(n, T), self._boundary_mean_force(n))
        # the law is frozen (its fields never change), so what they make stays valid
        self.__dict__["_kinetics_cache"] = (n, T, made)
        return made

    def __getstate__(self):
        """The law's fields without the kinetics made from them (closures: not picklable)."""
        state = dict(self.__dict__)
        state.pop("_kinetics_cache", None)
        return state

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

    def advance(self, f: float, dv: float, n: float, T: float, h: float,
                rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None,
                tangent: StepTangent | None = None) -> tuple[float, float]:
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

        tangent: a :class:`StepTangent` for this step, given each accepted sub-step to follow
        (:meth:`step_sensitivities`), the mean force then not summed (NaN: the map takes the
        force's sensitivities only, from the tangent); None: none (the FMUs).
        """
        dv0 = dv if dv_start is None else dv_start
        if not self.effects.melting or h <= 0.0:
            return f, self.mean_force(dv0, dv, n, f)
        dv_rate = (dv - dv0) / h  # m/s^2
        rate, slope, rate_dv, mean_force = self._kinetics(n, T)
        substep, grow = self._substep, _SUBSTEP_FACTOR
        s, sub, min_sub = 0.0, h, 1e-12 * h
        r0 = rate(f, dv0)
        # N s, the force integrated over the accepted sub-steps (not with a tangent: its map's)
        impulse = 0.0 if tangent is None else math.nan
        halfway, switched = self.MAX_SUBSTEPS // 2, False
        for count in range(self.MAX_SUBSTEPS):
            if s >= h:
                return f, impulse / h
            if count == halfway and dv_rate != 0.0:
                # An input that swings the equilibrium across decades within the step (a host
                # jumping dv by 1e6 m/s) cannot be followed at this tolerance: hold it at its
                # end value for the rest of the step, where f lands on equilibria in a few
                # sub-steps (what the FMU did before it followed dv through the step).
                dv0, dv_rate, r0 = dv, 0.0, rate(f, dv)
                switched = True
            s1 = h if sub >= h - s else s + sub
            dv_s = dv0 + dv_rate * s if dv_rate else dv
            dv_s1 = dv if s1 >= h or not dv_rate else dv0 + dv_rate * s1
            f1, r1, err, f_mean, f_late = substep(rate, slope, f, r0, dv_s1, rate_dv * dv_s * dv_rate, s1 - s)
            tol = atol + rtol * abs(f1)
            if err <= tol or sub <= min_sub:
                # the force's mean over the sub-step along f's own path (the elastic term is
                # f times dv, dv linear in time: its mean is dv_s f_mean + (dv_s1 - dv_s) f_late;
                # the viscous term integrated exactly)
                if tangent is None:
                    impulse += (s1 - s) * mean_force(dv_s, dv_s1, f_mean, dv_s * f_mean + (dv_s1 - dv_s) * f_late)
                else:  # (its map needs the force's sensitivities only, the tangent's)
                    tangent.substep(f, f1, dv_s, dv_s1, 1.0 if switched else s / h, 1.0 if switched else s1 / h, s1 - s)
                f, r0, s = f1, r1, s1
                # Floored: a sub-step forced through at the minimum must not shrink the next
                # one toward zero, or s would stop advancing.
                sub *= grow(err / tol)
                if not sub > min_sub:  # max(min_sub, sub), as the builtin compares
                    sub = min_sub
            else:
                sub *= grow(err / tol)
        if s >= h:
            return f, impulse / h
        raise ArithmeticError(f"eq. (21) needs more than {self.MAX_SUBSTEPS} sub-steps over "
                              f"h={h} s (reached f={f} with {h - s} s left)")

    def step_sensitivities(self, f: float, dv: float, n: float, T: float, h: float, rtol: float = 1e-6,
                           atol: float = 1e-6, dv_start: float | None = None):
        """:meth:`advance`'s f over the step with its first-order sensitivities: (f1, (d f1,
        d F_mean) each against (f, dv_start, dv)), F_mean [N] the step's mean force; the
        derivatives of the step's own map along the path its sub-steps take
        (:class:`StepTangent`). None where the melting is off (f does not move) or a slope is
        not finite (a shear-thinning term at rest)."""
        dv0 = dv if dv_start is None else dv_start
        if not self.effects.melting or h <= 0.0:
            return None
        tangent = StepTangent(self, n, T)
        f1, _ = self.advance(f, dv, n, T, h, rtol, atol, dv0, tangent)
        viscous0, viscous1 = self._viscous_mean_slopes(dv0, dv)  # (the elastic term's: the tangent's)
        elastic = tangent.impulse
        f_row, mean_row = tuple(tangent.f), (elastic[0] / h, elastic[1] / h + viscous0, elastic[2] / h + viscous1)
        if not all(map(math.isfinite, f_row + mean_row)):
            return None
        return f1, (f_row, mean_row)

    def _viscous_mean_slopes(self, dv0: float, dv1: float) -> tuple[float, float]:
        """d/d(dv0) and d/d(dv1) [N s/m] of the viscous term's mean along dv linear from dv0 to
        dv1 [m/s], m (G(dv1) - G(dv0)) / (dv1 - dv0) with G(u) = |u|^(gamma+2) / (gamma+2)."""
        if not self.effects.viscous:
            return 0.0, 0.0
        m, gamma = self.m, self.gamma
        span = dv1 - dv0
        if abs(span) <= _CANCELLATION * max(abs(dv0), abs(dv1)) or span == 0.0:  # (the middle's slope, half each)
            middle = 0.5 * (dv0 + dv1)
            slope = m * (gamma + 1.0) * abs(middle) ** gamma if middle != 0.0 else (math.inf if gamma < 0.0 else 0.0)
            return 0.5 * slope, 0.5 * slope
        p = gamma + 2.0
        G0, G1 = abs(dv0) ** p / p, abs(dv1) ** p / p
        g0, g1 = math.copysign(abs(dv0) ** (p - 1.0), dv0), math.copysign(abs(dv1) ** (p - 1.0), dv1)
        return m * (G1 - G0 - g0 * span) / (span * span), m * (g1 * span - (G1 - G0)) / (span * span)

    def _boundary_mean_force(self, n: float):
        """:meth:`mean_force` of the boundary law for n held, as a function of (dv_start, dv,
        f): the same arithmetic, with the switches' branches and the parameters' lookups done
        once per :meth:`advance` instead of once per sub-step."""
        lub, effects = self.lubricant, self.effects
        elastic, viscous_on = effects.elastic, effects.viscous
        mu, mu_bar, tau_e, thickness, S = lub.mu_shear, lub.mu_shear_bar, lub.tau_e, lub.h, self.S
        m, p = self.m, self.gamma + 2.0
        force = self.force

        def mean_force(dv_start: float, dv: float, f: float, f_dv: float | None = None) -> float:
            """The force's mean along dv moving linearly from dv_start to dv [m/s], f's mean f
            [1] (which side of the melt) and f dv's mean f_dv [m/s] (default f times dv's mean)."""
            if dv == dv_start:  # (then f_dv is f dv: dv held, f's mean is the one to take)
                return force(dv, n, f)
            try:
                viscous = m * ((abs(dv) ** p - abs(dv_start) ** p) / (p * (dv - dv_start)))
            except OverflowError:  # as the force itself: not finite, for the FMU to refuse
                viscous = m * math.copysign(math.inf, dv + dv_start)
            F = 0.0
            if elastic and mu - mu_bar * f > 0.0:
                dv_mean = 0.5 * (dv + dv_start)
                F += 2.0 * (mu * dv_mean - mu_bar * (f * dv_mean if f_dv is None else f_dv)) * tau_e / thickness * S
            if viscous_on:
                F += viscous
            return F

        return mean_force

    @staticmethod
    def _substep(rate, slope, f0: float, r0: float, dv1: float, r_t: float,
                 h: float) -> tuple[float, float, float, float, float]:
        """One sub-step over h [s] from f0 (rate r0) to the relative velocity dv1 at its end,
        the rate moving in time by r_t [1/s^2] through dv: (f1, its rate, estimated error, and
        along the sub-step the means of f and of f u, u = s / h its fraction).

        The means are the linear model's own, f0 + h phi2(z) r0 + h^2 phi3(z) r_t and f0 / 2 +
        h (phi2 - phi3)(z) r0 + h^2 (phi3 - phi4)(z) r_t, not the ends' average: where the
        sub-step is many relaxation times long (|z| >> 1, f on its moving equilibrium after
        1/|slope| of it) f sits at its end value nearly all along, and the ends' average put
        the force's mean (``F_mean``, from which the coupling charges a slip step's local
        error, coupling/path_error.py) half the jump of f away. At a hot film that melts and
        re-solidifies every half period (omega = 9.51, gamma = 0.926, T = 336 K) the run's
        carried estimate read 0.15-0.25x its true error, and 0.9-1.05x with the kinetics 1000x
        tighter, where the motion itself did not change; the difference of F_mean from the
        ends' average (what the error is charged from) was off by 100 % of itself, 45 % with
        f's mean, 19 % with f u's too (RMS along that run at per-step 1e-4)."""
        z = slope(f0) * h
        f_exp = None
        if z < 30.0:  # beyond, the linearisation grows without bound: leave it to Euler
            if -1e-5 < z < 1e-5:  # (abs(z) < 1e-5 without the builtin's call, NaN included)
                phi1, phi2 = 1.0 + z / 2.0, 0.5 + z / 6.0
            else:
                em1 = math.expm1(z)
                phi1, phi2 = em1 / z, (em1 - z) / (z * z)
            if -1e-2 < z < 1e-2:  # (phi_k+1 = (phi_k - 1/k!) / z loses digits to cancellation here)
                phi3 = 1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z / 720.0))
                phi4 = 1.0 / 24.0 + z * (1.0 / 120.0 + z * (1.0 / 720.0 + z / 5040.0))
            else:
                phi3 = (phi2 - 0.5) / z
                phi4 = (phi3 - 1.0 / 6.0) / z
            f_exp = f0 + h * phi1 * r0 + h * h * phi2 * r_t
            if math.isfinite(f_exp):
                r1 = rate(f_exp, dv1)
                # The linear model's rate at the end; the true one is r1. The defect,
                # integrated over the sub-step's effective length (h when slow, 1/|slope|
                # when stiff), bounds the local error.
                r_model = r0 * (1.0 + z * phi1) + h * phi1 * r_t
                if r_model * r1 > 0.0 or r1 == 0.0:  # has not crossed an equilibrium
                    return (f_exp, r1, 2.0 * abs((r1 - r_model) * h * phi1),
                            f0 + h * phi2 * r0 + h * h * phi3 * r_t,
                            0.5 * f0 + h * (phi2 - phi3) * r0 + h * h * (phi3 - phi4) * r_t)
        f1, r1 = BoundaryLaw._backward_euler(rate, dv1, f0, h)
        # Crossing: both the linear model and backward Euler land near the equilibrium;
        # where they disagree, the sub-step was too long for the curvature of the rate.
        # (Its path unknown: f taken linear between the ends.)
        err = abs(f_exp - f1) if f_exp is not None and math.isfinite(f_exp) else 0.5 * h * abs(r1 - r0)
        return f1, r1, err, 0.5 * (f0 + f1), (f0 + 2.0 * f1) / 6.0

    @staticmethod
    def _backward_euler(rate, dv1: float, f0: float, h: float) -> tuple[float, float]:
        """f1 = f0 + h rate(f1, dv1), its root bracketed between f0 and the equilibrium, and
        the rate there (the last evaluation of the rate, where the root finder stopped on it)."""
        rate0 = rate(f0, dv1)
        if rate0 == 0.0:
            return f0, rate0
        direction = 1.0 if rate0 > 0 else -1.0
        last = [f0, rate0]  # the last y the rate was evaluated at, and its rate

        def residual(y: float) -> float:  # signed so it starts < 0 and rises through the root
            r = rate(y, dv1)
            last[0], last[1] = y, r
            return direction * (y - f0 - h * r)

        # At least a few ulps: below that f0 + width == f0 and the bracket never opens
        # (a step of 1e-300 s moves f by less than one ulp).
        lo, width = f0, max(min(abs(h * rate0), 1e-3 * (1.0 + abs(f0))), 4.0 * math.ulp(f0))
        r_lo = direction * (f0 - f0 - h * rate0)  # the residual at f0, from the rate there
        hi = f0 + direction * width
        for _ in range(400):
            r_hi = residual(hi)
            if r_hi >= 0.0:
                break
            lo, r_lo, width = hi, r_hi, 2.0 * width
            hi = f0 + direction * width
        else:  # the cubic term guarantees an equilibrium; only non-finite inputs get here
            raise ArithmeticError(f"no equilibrium of eq. (21) found from f={f0}")
        f1 = illinois(residual, lo, hi, r_lo, r_hi)
        return f1, (last[1] if last[0] == f1 else rate(f1, dv1))

    def state_jacobian(self, dv: float, f: float, n: float, T: float) -> tuple[float, float, float, float]:
        """:meth:`FrictionLaw.state_jacobian`, exact: (dF/d(dv) [N s/m], dF/df [N], dg/d(dv)
        [1/m], dg/df [1/s]) of eq. (23) and eq. (21) at (dv, f), n and T held. The elastic
        term's modulus is floored at 0 (eq. 19): past the melt threshold it is 0 and moves with
        neither dv nor f (at the kink itself, the molten side's slopes). The viscous slope
        m (gamma + 1) |dv|^gamma is infinite at rest for gamma < 0. With melting off, f does
        not move (:meth:`advance`): g's slopes are 0."""
        lub, effects = self.lubricant, self.effects
        F_dv = F_f = 0.0
        if effects.elastic:
            mu_eff = lub.mu_shear - lub.mu_shear_bar * f
            if mu_eff > 0.0:
                stiffness = 2.0 * lub.tau_e / lub.h * self.S  # m^2 s / m: tau S per unit modulus and dv
                F_dv, F_f = stiffness * mu_eff, -stiffness * lub.mu_shear_bar * dv
        if effects.viscous:
            if dv != 0.0:
                F_dv += self.m * (self.gamma + 1.0) * abs(dv) ** self.gamma
            else:
                F_dv += math.inf if self.gamma < 0.0 else (self.m if self.gamma == 0.0 else 0.0)
        if not effects.melting:
            return F_dv, F_f, 0.0, 0.0
        _, slope, rate_dv, _ = self._kinetics(n, T)
        return F_dv, F_f, rate_dv * dv, slope(f)
