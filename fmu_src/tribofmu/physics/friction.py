"""What every friction law is: the contract :class:`FrictionLaw` the laws of
:mod:`tribofmu.physics.laws` fulfil (dry, fluid, boundary, mixed), and what they share.

A law is resolved once from its name or FMU code (:func:`tribofmu.physics.laws.make_law`); the
rest of the project asks the law object (does it stick, its static limit, its keys, its
state) and never compares regime codes. Pure physics, no FMI. Units are SI throughout:
dv [m/s] relative velocity ``V - v``; n [Pa] normal stress (negative in compression);
T [K] lubricant temperature; F [N] friction force on the lower block; f [1] excess volume.

Equation numbers refer to the seed paper (see docs/model.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import ClassVar


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
    """One friction pair's law and its parameters; a subclass per law (:mod:`.laws`).

    The parameters every law carries (each law reads those in its ``keys``):
    mu_friction [1] friction coefficient (dry; the kinetic one of mixed friction); S [m^2]
    contact area (load ``L = -n S``); m and gamma [1] the power-law fluid
    ``m sgn(dv)|dv|^(gamma+1)``, eq. (11)-(12), m in N (s/m)^(gamma+1); the lubricant's
    constants and the boundary model's switches. A law adds its own fields.
    """

    # -- what the law is (class attributes of each law) ----------------------------------
    name: ClassVar[str] = ""  # the scene's friction.regime
    code: ClassVar[int] = -1  # the FMU's integer parameter regime (fixed forever: hosts store it)
    label: ClassVar[str] = ""  # display name, e.g. "dry friction"
    keys: ClassVar[frozenset[str]] = frozenset()  # the friction.* scene keys it reads
    sticks: ClassVar[bool] = False  # set-valued at dv = 0: holds the blocks up to static_limit
    has_state: ClassVar[bool] = False  # carries the lubricant's excess volume f (advance moves it)
    constant_slip_force: ClassVar[bool] = False  # slip force fixed by the load alone (closed-form slip)
    # How a figure states the load: "L" [N], "n" [Pa], or None: the law does not read n.
    load_shown_as: ClassVar[str | None] = None
    reads_temperature: ClassVar[bool] = False  # the force or state depends on T
    # Extra FMU parameters of this law: name -> (unit, description, check); defaults are the
    # law's own field defaults. Shared ones (mu_friction, S, m, gamma, ...) are declared once.
    fmu_parameters: ClassVar[dict] = {}

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
        """Out-of-range inputs for this law (the base: not finite)."""
        return [f"{name} must be finite, got {value}"
                for name, value in (("dv", dv), ("n", n), ("T", T)) if not math.isfinite(value)]

    # -- force ----------------------------------------------------------------------
    def force(self, dv: float, n: float, f: float = 0.0) -> float:
        """Friction force F [N] on the lower block at relative velocity dv [m/s], normal stress
        n [Pa] and excess volume f [1] (single-valued: sgn(0) = 0)."""
        raise NotImplementedError

    def mean_force(self, dv_start: float, dv: float, n: float, f: float = 0.0) -> float:
        """Mean friction force [N] over a step in which dv moves linearly from dv_start to dv
        [m/s] with f held.

        The coupling compares it with the force ramp the block felt: a force that peaks
        inside a step (a lubricant re-solidifying as dv passes 0) shows there, not at the
        step's ends."""
        if dv == dv_start:
            return self.force(dv, n, f)
        return self.path_mean_force(dv_start, dv, n, f)

    def path_mean_force(self, dv_start: float, dv: float, n: float, f: float) -> float:
        """:meth:`mean_force` over a path of non-zero width (dv != dv_start) [N]."""
        raise NotImplementedError

    def load(self, n: float) -> float:
        """The load L = -n S [N] of normal stress n [Pa]."""
        return -n * self.S

    def viscous_force(self, dv: float) -> float:
        """Power-law fluid force ``m sgn(dv) |dv|^(gamma+1)`` [N], eq. (11)."""
        try:
            return self.m * sign(dv) * abs(dv) ** (self.gamma + 1.0)
        except OverflowError:  # not finite: for the FMU to refuse, naming F
            return self.m * sign(dv) * math.inf

    @property
    def has_power_law_term(self) -> bool:
        """Whether the power-law term ``m sgn(dv)|dv|^(gamma+1)`` is part of the force."""
        return False

    # -- stick (laws with sticks = True) ------------------------------------------------
    def static_limit(self, n: float) -> float:
        """The largest force [N] the contact holds at dv = 0 under normal stress n [Pa]
        (0: the law does not stick)."""
        return 0.0

    def slip_force(self, dv: float, n: float, direction: float) -> float:
        """The force [N] on the slip branch of direction (+1 or -1, the sign of dv while
        slipping): at dv = 0 it is the branch's limit, not sgn(0) = 0. A direction in
        between (tanh of a regularisation) blends the branches."""
        return self.force(dv, n)

    def regularised_force(self, dv: float, n: float, f: float, width: float) -> float:
        """The force with the jump at dv = 0 smoothed over width [m/s] (sgn -> tanh), for a
        monolithic ODE solver; a law without a jump is returned as it is."""
        if self.sticks:
            return self.slip_force(dv, n, math.tanh(dv / width))
        return self.force(dv, n, f)

    # -- state --------------------------------------------------------------------------
    def melt_threshold(self) -> float | None:
        """The f [1] above which the lubricant is molten (None: no lubricant that melts)."""
        return None

    def melt_margin(self, f: float) -> float:
        """threshold - f [1]: > 0 while the lubricant is solid-like, <= 0 once molten; 1 for a
        law without a lubricant that melts: a phase change is a sign change, for a master to
        locate."""
        threshold = self.melt_threshold()
        return 1.0 if threshold is None else threshold - f

    def kinetics_rate(self, f: float, dv: float, n: float, T: float) -> float:
        """df/dt [1/s] of the law's state (0 for a law without one)."""
        return 0.0

    def advance_f(self, f: float, dv: float, n: float, T: float, h: float,
                  rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None) -> float:
        """f(t+h) of :meth:`advance`."""
        return self.advance(f, dv, n, T, h, rtol, atol, dv_start)[0]

    def advance(self, f: float, dv: float, n: float, T: float, h: float,
                rtol: float = 1e-6, atol: float = 1e-6, dv_start: float | None = None) -> tuple[float, float]:
        """Advance the law's state f over a step h [s] with n, T held; returns f(t+h) and the
        mean friction force [N] over the step. dv [m/s] is held over the step, or, given
        dv_start, moves linearly from dv_start to dv. A law without state: f unchanged."""
        return f, self.mean_force(dv if dv_start is None else dv_start, dv, n, f)

    # -- display --------------------------------------------------------------------------
    def plot_items(self, fmt) -> list[str]:
        """The law's parameters as ``symbol = value`` items for a figure's caption, each number
        written by fmt (float -> str)."""
        return []


def power_mean(dv_start: float, dv: float, exponent: float) -> float:
    """Mean of sgn(x)|x|^exponent as x moves linearly from dv_start to dv (dv != dv_start),
    exact from its antiderivative."""
    p = exponent + 1.0
    try:
        return (abs(dv) ** p - abs(dv_start) ** p) / (p * (dv - dv_start))
    except OverflowError:  # as the force itself: not finite, for the FMU to refuse
        return math.copysign(math.inf, dv + dv_start)
