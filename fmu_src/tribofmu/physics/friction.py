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
import sys
from dataclasses import dataclass, field
from typing import ClassVar

from .parameters import Parameter, above, at_least, parameter, problems_of


def sign(x: float) -> float:
    """sgn(x) with sgn(0) = 0: the single-valued choice; the set-valued stick force is the
    coupling algorithm's business, not the law's."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@dataclass(frozen=True)
class LubricantConstants:
    """Landau boundary-lubricant constants (paper ref. [19]); SI units. Eq. numbers: the seed paper's."""

    phi0_star: float = parameter(
        5.0, "J/m3", "phi0*: constant part of phi0, eq. (15)", symbol="φ0*",
        note="the paper prints a second `Φ0* = 5`; `Φ0* = 20 J/m³` enters only the free energy, not the dynamics")
    lam: float = parameter(2e11, "Pa", "lambda: bulk elastic modulus of the solid-like lubricant, eq. (20)",
                           above(0), symbol="λ")
    lam_bar: float = parameter(1e8, "Pa", "lambda-bar: melting decrement of lambda, eq. (20)", at_least(0),
                               symbol="λ̄")
    # mu: the shear modulus, not the friction coefficient
    mu_shear: float = parameter(
        4.1e11, "Pa", "mu: shear modulus of the solid-like lubricant, eq. (19)", above(0), symbol="μ",
        note="called `mu_shear` in code: the paper also uses `μ` for the dry friction coefficient")
    mu_shear_bar: float = parameter(4e11, "Pa", "mu-bar: melting decrement of the shear modulus, eq. (19)",
                                    at_least(0), symbol="μ̄")
    phi1: float = parameter(1100.0, "J/m3", "phi1: Landau expansion coefficient, eq. (13)", symbol="φ1")
    phi2: float = parameter(2700.0, "J/m3", "phi2: Landau expansion coefficient, eq. (13)", symbol="φ2")
    phi3: float = parameter(2070.0, "J/m3", "phi3: Landau expansion coefficient, eq. (13)", above(0),
                            symbol="φ3")
    alpha: float = parameter(0.45, "J/(K.m3)", "alpha: temperature coefficient of phi0, eq. (15)", symbol="α")
    h: float = parameter(1e-9, "m", "lubricant layer thickness, eq. (22)", above(0), symbol="h")
    tau_f: float = parameter(0.01, "Pa.s", "relaxation time of the excess volume, eq. (21)", above(0),
                             symbol="τ_f", note="relaxation time of `f` (as a viscosity)")
    tau_e: float = parameter(1e-8, "s", "Maxwell time of internal stress relaxation, eq. (22)", above(0),
                             symbol="τ_ε")


@dataclass(frozen=True)
class Effects:
    """Which terms of the boundary model are simulated (all on = the paper's model); each a
    Boolean parameter of the FMUs, named as ``fmu_name`` says."""

    melting: bool = parameter(True, "1", "boundary: f evolves by eq. (21) (false: f stays at f0)",
                              fmu_name="melting")
    pressure: bool = parameter(True, "1", "boundary: normal-stress terms of eqs. (15), (21)",
                               fmu_name="pressure_term")
    temperature: bool = parameter(True, "1", "boundary: alpha T in eq. (15)", fmu_name="temperature_term")
    viscous: bool = parameter(True, "1", "boundary: viscous force m sgn(dv)|dv|^(gamma+1) in eq. (23)",
                              fmu_name="viscous_term")
    elastic: bool = parameter(True, "1", "boundary: elastic force tau S in eq. (23)", fmu_name="elastic_term")


@dataclass(frozen=True)
class Conditions:
    """The friction's inputs besides dv, which a scene holds constant unless an FMU feeds them."""

    n: float = parameter(-20.0, "Pa", "normal stress on the contact (negative in compression)", symbol="n",
                         note="dry and mixed friction need n <= 0 (their input_problems)")
    T: float = parameter(290.0, "K", "lubricant temperature", symbol="T",
                         note="boundary friction needs T >= 0 K (its input_problems)")


# The lubricant's excess volume at the start (the state of a law with has_state).
START_F = Parameter("f0", 0.0, "1", "boundary: excess volume at the start", symbol="f0")


@dataclass(frozen=True)
class FrictionLaw:
    """One friction pair's law and its parameters; a subclass per law (:mod:`.laws`).

    The parameters every law carries (each law reads those in its ``keys``) are declared
    below (:func:`~tribofmu.physics.parameters.parameter`: unit, range, description), with
    the lubricant's constants and the boundary model's switches. A law adds its own fields,
    declared the same way; the keys it reads include them.
    """

    # -- what the law is (class attributes of each law) ----------------------------------
    name: ClassVar[str] = ""  # the scene's friction.regime
    code: ClassVar[int] = -1  # the FMU's integer parameter regime (fixed forever: hosts store it)
    label: ClassVar[str] = ""  # display name, e.g. "dry friction"
    keys: ClassVar[frozenset[str]] = frozenset()  # the friction.* scene keys it reads
    sticks: ClassVar[bool] = False  # set-valued at dv = 0: holds the blocks up to static_limit
    has_state: ClassVar[bool] = False  # carries the lubricant's excess volume f (advance moves it)
    # a law with state that gives each step's own map (step_sensitivities): the coupling's carry
    # follows its steps by it (coupling/variational.py), and its runs need no second to verify them
    gives_step_map: ClassVar[bool] = False
    constant_slip_force: ClassVar[bool] = False  # slip force fixed by the load alone (closed-form slip)
    # How a figure states the load: "L" [N], "n" [Pa], or None: the law does not read n.
    load_shown_as: ClassVar[str | None] = None
    reads_temperature: ClassVar[bool] = False  # the force or state depends on T

    # The parameters every law carries (a law adds its own as fields declared the same way;
    # the FMUs and scenes carry every law's).
    mu_friction: float = parameter(0.5, "1", "dry friction coefficient, eq. (4); mixed: the kinetic one",
                                   at_least(0), symbol="μ")
    S: float = parameter(1.0, "m2", "contact area; dry load L = -n S", above(0), symbol="S")
    m: float = parameter(25.0, "N.(s/m)^(gamma+1)",
                         "viscous coefficient m = k S / h^(gamma+1), eq. (12); mixed: m dv, N.s/m",
                         at_least(0), symbol="m")
    gamma: float = parameter(0.0, "1", "power-law exponent: < 0 pseudoplastic, 0 Newtonian, > 0 dilatant",
                             above(-1, "force must vanish at rest"), symbol="γ")
    lubricant: LubricantConstants = field(default_factory=LubricantConstants)
    effects: Effects = field(default_factory=Effects)

    # -- validation -------------------------------------------------------------------
    def problems(self) -> list[str]:
        """Every parameter that is out of range, as ``name must be ..., got value``: the
        declared ranges of the law's and the lubricant's parameters."""
        return problems_of(self) + problems_of(self.lubricant)

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

    @property
    def slope_bounded(self) -> bool:
        """Whether the slip force's slope dF/d(dv) stays bounded as dv -> 0 (the force is
        Lipschitz in dv on each slip branch): the power-law term's exponent gamma + 1 is at
        least 1. A shear-thinning term (gamma < 0) has an infinite slope at rest, where an
        error's growth or decay cannot be linearised (coupling/estimate.py)."""
        return not self.has_power_law_term or self.gamma >= 0.0

    @property
    def shear_thinning(self) -> bool:
        """Whether the power-law term thins with shear (-1 < gamma < 0): a force continuous
        through dv = 0 whose slope is infinite there (it all but jumps as gamma -> -1), the
        only unbounded slope a law without its own :attr:`slope_bounded` can have."""
        return self.has_power_law_term and self.gamma < 0.0

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

    def state_jacobian(self, dv: float, f: float, n: float, T: float) -> tuple[float, float, float, float]:
        """The slopes of the force F = :meth:`force` and of the state's rate g =
        :meth:`kinetics_rate` at (dv [m/s], f [1]) with n [Pa], T [K] held: (dF/d(dv) [N s/m],
        dF/df [N], dg/d(dv) [1/m], dg/df [1/s]), the variational equations' coefficients (the
        carried error estimate of coupling/estimate.py). Here by central differences, each
        step the cube root of the machine epsilon (where the truncation, ~step^2, meets the
        round-off, ~eps/step) relative to |dv| and to max(|f|, 1) (f is of order one); at dv = 0,
        where no relative step exists, that many m/s (a slope infinite at rest, a shear-thinning
        term's, is then the chord's: ask off rest). A law may override it with its exact
        derivatives. Where the force has a kink (a floored modulus) the differences straddle
        it: the mean of its two slopes."""
        rel = sys.float_info.epsilon ** (1.0 / 3.0)
        ddv = rel * abs(dv) or rel
        df = rel * max(abs(f), 1.0)
        lo_dv, hi_dv, lo_f, hi_f = dv - ddv, dv + ddv, f - df, f + df
        F_dv = (self.force(hi_dv, n, f) - self.force(lo_dv, n, f)) / (hi_dv - lo_dv)
        F_f = (self.force(dv, n, hi_f) - self.force(dv, n, lo_f)) / (hi_f - lo_f)
        g_dv = (self.kinetics_rate(f, hi_dv, n, T) - self.kinetics_rate(f, lo_dv, n, T)) / (hi_dv - lo_dv)
        g_f = (self.kinetics_rate(hi_f, dv, n, T) - self.kinetics_rate(lo_f, dv, n, T)) / (hi_f - lo_f)
        return F_dv, F_f, g_dv, g_f

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
