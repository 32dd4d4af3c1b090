"""The first-order sensitivities of one step of the boundary law's kinetics, followed along
its sub-steps (:class:`StepTangent`, for :meth:`.boundary.BoundaryLaw.step_sensitivities`)."""
from __future__ import annotations

import math


def _phis(z: float) -> tuple[float, float, float]:
    """phi1, phi2, phi3 of z (phi_k+1 = (phi_k - 1/k!) / z; series where that cancels)."""
    if -1e-2 < z < 1e-2:
        return (1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)), 0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z / 120.0)),
                1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z / 720.0)))
    em1 = math.expm1(z)
    phi1 = em1 / z
    phi2 = (phi1 - 1.0) / z
    return phi1, phi2, (phi2 - 0.5) / z


class StepTangent:
    """The first-order sensitivities of one :meth:`.boundary.BoundaryLaw.advance` to its inputs (f0 [1],
    dv0 and dv1 [m/s]: f at the step's start, dv at its start and end), followed sub-step by
    sub-step along the path f takes: over a sub-step of dt the variations move by

        df' = g_f df + g_dv D(s),    dF = F_dv D(s) + F_f df,

    D(s) = (0, 1 - s/h, s/h) the variation of dv (linear over the step), the slopes at the
    sub-step's middle, in closed form with the phi functions: df(dt) = e^z df(0) + dt g_dv
    (phi1 D0 + phi2 (D1 - D0)), its integral dt (phi1 df(0) + dt g_dv (phi2 D0 + phi3 (D1 -
    D0))), z = g_f dt. These are the derivatives of the true flow along the computed path,
    not a linearisation at one point: where f falls across a melt inside a step, the slopes
    change within it, and the carry taken at the step's middle lost part of an error at each
    melt (bench_carry_sensitivity.py). The viscous term's share of F_mean, a function of dv0
    and dv1 alone, is differentiated in closed form (:meth:`.boundary.BoundaryLaw.step_sensitivities`)."""

    def __init__(self, law, n: float, T: float):
        _, self.slope, self.rate_dv, _ = law._kinetics(n, T)  # (g_f of f; g_dv over dv)
        lub = law.lubricant
        # the elastic term 2 (mu - mu_bar f) tau_e / h S dv, where its modulus is positive
        self.elastic = law.effects.elastic
        self.mu, self.mu_bar, self.k = lub.mu_shear, lub.mu_shear_bar, 2.0 * lub.tau_e / lub.h * law.S
        self.f = [1.0, 0.0, 0.0]  # d f / d (f0, dv0, dv1) where the sub-steps have reached
        self.impulse = [0.0, 0.0, 0.0]  # d (the elastic force's integral [N s]) / d (f0, dv0, dv1)
        # The f where a modulus reaches 0 (eqs. 19, 21: mu_eff, and lam_eff in the pressure
        # term), floored there: the force's modulus and the rate's slope jump. A sub-step across
        # one is followed in two parts that meet there, each with its own side's slopes.
        kinks, melt = [], law.melt_threshold()
        if melt is not None and (self.elastic or law.effects.pressure):
            kinks.append(melt)
        if lub.lam_bar > 0.0 and law.effects.pressure:
            kinks.append(lub.lam / lub.lam_bar)
        self.kinks = tuple(sorted(kinks))

    def substep(self, f_a: float, f_b: float, dv_a: float, dv_b: float, u_a: float, u_b: float, dt: float) -> None:
        """Follow one accepted sub-step of dt [s] from f_a to f_b, dv from dv_a to dv_b, at the
        fractions u_a, u_b of the step (dv's weights on dv1 there); where f crosses a kink, in
        parts that end there (f taken linear in time across the sub-step to place it)."""
        for kink in self.kinks if f_b >= f_a else reversed(self.kinks):
            if (f_a - kink) * (f_b - kink) < 0.0:
                c = (kink - f_a) / (f_b - f_a)
                dv_c, u_c = dv_a + c * (dv_b - dv_a), u_a + c * (u_b - u_a)
                self._follow(f_a, kink, dv_a, dv_c, u_a, u_c, c * dt)
                f_a, dv_a, u_a, dt = kink, dv_c, u_c, (1.0 - c) * dt
        self._follow(f_a, f_b, dv_a, dv_b, u_a, u_b, dt)

    def _follow(self, f_a: float, f_b: float, dv_a: float, dv_b: float, u_a: float, u_b: float, dt: float) -> None:
        """One part of a sub-step that crosses no kink (:meth:`substep`)."""
        f_mid, dv_mid = 0.5 * (f_a + f_b), 0.5 * (dv_a + dv_b)
        g_dv, z = self.rate_dv * dv_mid, self.slope(f_mid) * dt
        stiffness = F_f = 0.0  # the elastic term's slopes (its viscous part: the step's, in closed form)
        if self.elastic and self.mu - self.mu_bar * f_mid > 0.0:
            stiffness, F_f = self.k * (self.mu - self.mu_bar * f_mid), -self.k * self.mu_bar * dv_mid
        if z > 700.0:  # (a runaway no sub-step this long follows: e^z overflows)
            self.f = [math.inf, math.inf, math.inf]
            return
        phi1, phi2, phi3 = _phis(z)
        e, a, half = 1.0 + z * phi1, dt * g_dv, dt * stiffness * 0.5
        # Per entry k, D = (0, 1 - u, u) at the sub-step's ends (d0, d1):
        #     integral = dt (phi1 df[k] + a (phi2 d0 + phi3 (d1 - d0)))
        #     impulse[k] += dt stiffness (d0 + d1) / 2 + F_f integral
        #     df[k] = e df[k] + a (phi1 d0 + phi2 (d1 - d0))
        # written out for the three entries (a loop over them, building each entry's D, took 7 %
        # of the map's pass, the kinetics' hottest lines). f0's entry is driven by nothing but
        # itself (D = 0).
        (df0, df1, df2), (impulse0, impulse1, impulse2) = self.f, self.impulse
        d0, d1 = 1.0 - u_a, 1.0 - u_b  # (entry 1's; entry 2's are u_a, u_b)
        self.impulse = [
            impulse0 + F_f * (dt * (phi1 * df0)),
            impulse1 + (half * (d0 + d1) + F_f * (dt * (phi1 * df1 + a * (phi2 * d0 + phi3 * (d1 - d0))))),
            impulse2 + (half * (u_a + u_b) + F_f * (dt * (phi1 * df2 + a * (phi2 * u_a + phi3 * (u_b - u_a)))))]
        self.f = [e * df0,
                  e * df1 + a * (phi1 * d0 + phi2 * (d1 - d0)),
                  e * df2 + a * (phi1 * u_a + phi2 * (u_b - u_a))]
