"""Energy audit of a co-simulation run, from its communication points.

Over each communication step [t0, t0 + h] the block felt the force ``F_start + F_rate s``
(s in [0, h], recorded on the step's end point); the drive and block velocities are the
cubic Hermite interpolants the results are sampled with (V with the drive's accelerations,
v with :func:`velocity_slopes`). A linear force times a cubic velocity is a quartic, which
3-point Gauss-Legendre quadrature integrates exactly: the integrals below are exact for the
trajectory the run delivers, so what is left in the balance is the run's own error.

    W  = int F V dt             work the drive does through the friction
    D  = int F (V - v) dt       heat dissipated in the contact
    dE = (M v^2 / 2 + K x^2)(end) - (start)   block energy (two springs of stiffness K)
    residual = W - D - dE       = int F v dt - dE: 0 for an exact run

Units: J. ``residual_rel`` is the residual relative to |D| (or to the
largest block energy reached if that is larger: a contact that never slips dissipates
nothing, and its D is round-off).
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ..coupling.interpolation import NS, hermite, velocity_slopes
from ..coupling.quadrature import GAUSS_NODES, GAUSS_WEIGHTS

_GL_S = np.array(GAUSS_NODES)
_GL_W = np.array(GAUSS_WEIGHTS)


def step_integrals(points: Sequence[Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per communication step: h [s], int F V dt [J], int F v dt [J] (arrays of n-1)."""
    n = len(points) - 1
    if n < 1:
        z = np.zeros(0)
        return z, z, z
    t = np.array([p.t_ns for p in points], dtype=np.int64)
    h = np.diff(t) / NS
    get = lambda k: np.array([getattr(p, k) for p in points])
    V, aX, v = get("V"), get("aX"), get("v")
    F0, rate = get("F_start")[1:], get("F_rate")[1:]
    slopes = np.array([velocity_slopes(p0, p1) for p0, p1 in zip(points, points[1:])])
    s = _GL_S[:, None]
    force = F0 + rate * (s * h)
    V_s = hermite(V[:-1], V[1:], aX[:-1], aX[1:], h, s)
    v_s = hermite(v[:-1], v[1:], slopes[:, 0], slopes[:, 1], h, s)
    WV = h * (_GL_W[:, None] * force * V_s).sum(axis=0)
    Wv = h * (_GL_W[:, None] * force * v_s).sum(axis=0)
    return h, WV, Wv


class EnergyAudit:
    """The audit accumulated over a run's points, chunk by chunk, so a long run need not
    keep them all: each chunk given to :meth:`add` starts with the last point of the one
    before. Per step it keeps three numbers (h, the step's dissipation, its largest |F|)."""

    def __init__(self, scenario):
        self.M, self.K = scenario.block.M, scenario.block.K
        self.thermal_q = scenario.thermal.q if "Thermal" in scenario.fmus else None
        self.first = self.last = None
        self.W = 0.0
        self.E_max = self.v_scale = self.T_max = 0.0
        self._h, self._D, self._F = [], [], []

    def energy(self, p) -> float:
        """Kinetic plus spring energy [J] of the block at point p."""
        return 0.5 * self.M * p.v ** 2 + self.K * p.x ** 2

    def add(self, points: Sequence[Any]) -> "EnergyAudit":
        if not points:
            return self
        if self.first is None:
            self.first = points[0]
        self.last = points[-1]
        self.E_max = max(self.E_max, max(self.energy(p) for p in points))
        self.v_scale = max(self.v_scale, max(max(abs(p.V), abs(p.v)) for p in points))
        self.T_max = max(self.T_max, max(p.T for p in points)) if self.thermal_q is not None else 0.0
        if len(points) < 2:
            return self
        h, WV, Wv = step_integrals(points)
        self.W += float(WV.sum())
        self._h.append(h)
        self._D.append(WV - Wv)
        self._F.append(np.array([max(abs(p0.F), abs(p1.F_start), abs(p1.F_start + p1.F_rate * hh))
                                 for p0, p1, hh in zip(points, points[1:], h)]))
        return self

    def result(self) -> dict[str, Any]:
        """Work, dissipation and block energy balance of a run (see the module doc); J.

        negative_dissipation_steps counts steps whose dissipation is below minus a
        round-off allowance (1e-8 of |F| times the velocity scale times h, or 1e-8 of the
        run's mean dissipation over the step if larger): friction that feeds energy into
        the system, which only a numerical error can do.
        """
        if not self._h:
            return {"W": 0.0, "D": 0.0, "dE": 0.0, "residual": 0.0, "residual_rel": 0.0,
                    "negative_dissipation_steps": 0, "steps": 0}
        h, D_step, F_abs = (np.concatenate(a) for a in (self._h, self._D, self._F))
        W, D = self.W, float(D_step.sum())
        dE = self.energy(self.last) - self.energy(self.first)
        residual = W - D - dE
        v_scale = max(self.v_scale, 1e-300)
        # round-off of the quadrature, and the interpolants' O(h^3) slivers where F and V - v
        # change sign a hair apart: 1e-8 of the run's mean dissipation rate
        span = max(float(h.sum()), 1e-300)
        allowance = np.maximum(1e-8 * F_abs * v_scale * h, 1e-8 * abs(D) / span * h)
        negative = int(np.count_nonzero(D_step < -allowance))
        denom = max(abs(D), self.E_max)  # D alone is round-off where the contact never slips
        return {"W": W, "D": D, "dE": float(dE), "residual": float(residual),
                "residual_rel": float(residual / denom) if denom > 0 else 0.0,
                "negative_dissipation_steps": negative,
                "most_negative_step_dissipation": float(min(0.0, D_step.min())),
                "steps": int(len(h))}

    def heat(self) -> dict[str, Any]:
        """The heat the Thermal FMU received against the friction dissipation of the run.

        Q [J]: the Thermal FMU's own count of the heat it received (its output Q at the
        last point); D [J]: the audit's dissipation int F (V - v) dt; q [1]: the share of
        the friction power that heats the film. relative_mismatch = (Q - q D) / (q D).
        Empty when the scene has no Thermal FMU.
        """
        if self.thermal_q is None or not self._h:
            return {}
        D = float(sum(d.sum() for d in self._D))
        q = self.thermal_q
        Q = float(self.last.Q - self.first.Q)
        expected = q * D
        return {"Q": Q, "D": D, "q": q, "mismatch": Q - expected,
                "relative_mismatch": (Q - expected) / abs(expected) if expected != 0 else 0.0,
                "T_start": float(self.first.T), "T_end": float(self.last.T), "T_max": float(self.T_max)}


def energy_audit(points: Sequence[Any], scenario) -> dict[str, Any]:
    """:meth:`EnergyAudit.result` of a list of points."""
    return EnergyAudit(scenario).add(points).result()


def heat_audit(points: Sequence[Any], scenario) -> dict[str, Any]:
    """:meth:`EnergyAudit.heat` of a list of points."""
    return EnergyAudit(scenario).add(points).heat()
