"""Friction FMU: the friction law of one pair. Inputs dv, n, T; outputs F, f.

Dry, fluid or boundary friction (parameter ``regime``), with the boundary model's terms
switched by the Boolean parameters ``*_term`` and ``melting``. The FMU never learns the
block's mass: a stuck contact is the coupling algorithm's business (sgn(0) = 0 here).
"""
from dataclasses import fields

# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import (TriboSlave as Fmi2Slave, DefaultExperiment, PARAMETER, INPUT,
                                 OUTPUT, non_negative)
from tribofmu.physics.friction import (BOUNDARY, REGIME_NAMES, Effects, FrictionLaw,
                                       LubricantConstants)

LUBRICANT = {  # name: (unit, description)
    "phi0_star": ("J/m3", "phi0*: constant part of phi0, eq. (15)"),
    "lam": ("Pa", "lambda: bulk elastic modulus of the solid-like lubricant, eq. (20)"),
    "lam_bar": ("Pa", "lambda-bar: melting decrement of lambda, eq. (20)"),
    "mu_shear": ("Pa", "mu: shear modulus of the solid-like lubricant, eq. (19)"),
    "mu_shear_bar": ("Pa", "mu-bar: melting decrement of the shear modulus, eq. (19)"),
    "phi1": ("J/m3", "phi1: Landau expansion coefficient, eq. (13)"),
    "phi2": ("J/m3", "phi2: Landau expansion coefficient, eq. (13)"),
    "phi3": ("J/m3", "phi3: Landau expansion coefficient, eq. (13)"),
    "alpha": ("J/(K.m3)", "alpha: temperature coefficient of phi0, eq. (15)"),
    "h": ("m", "lubricant layer thickness, eq. (22)"),
    "tau_f": ("Pa.s", "relaxation time of the excess volume, eq. (21)"),
    "tau_e": ("s", "Maxwell time of internal stress relaxation, eq. (22)"),
}
EFFECTS = {  # FMU parameter name: (Effects field, description)
    "melting": ("melting", "boundary: f evolves by eq. (21) (false: f stays at f0)"),
    "pressure_term": ("pressure", "boundary: normal-stress terms of eqs. (15), (21)"),
    "temperature_term": ("temperature", "boundary: alpha T in eq. (15)"),
    "viscous_term": ("viscous", "boundary: viscous force m sgn(dv)|dv|^(gamma+1) in eq. (23)"),
    "elastic_term": ("elastic", "boundary: elastic force tau S in eq. (23)"),
}


def _regime(value):
    return None if value in REGIME_NAMES else f"must be 0 (dry), 1 (fluid) or 2 (boundary), got {value}"


def _gamma(value):
    return None if value > -1 else f"must be > -1 (force must vanish at rest), got {value}"


def _positive(value):
    return None if value > 0 else f"must be > 0, got {value}"


class Friction(Fmi2Slave):
    description = "Friction law of the seed paper: dry, fluid (power law) or boundary (Landau) friction"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._law = None
        self.dv_previous = None  # m/s, the input of the last step (None: none yet)
        self.declare("regime", 0, PARAMETER, "1", "friction regime: 0 = dry, 1 = fluid, 2 = boundary",
                     check=_regime)
        self.declare("mu_friction", 0.5, PARAMETER, "1", "dry friction coefficient, eq. (4)",
                     check=non_negative)
        self.declare("S", 1.0, PARAMETER, "m2", "contact area; dry load L = -n S", check=_positive)
        self.declare("m", 25.0, PARAMETER, "N.(s/m)^(gamma+1)",
                     "viscous coefficient m = k S / h^(gamma+1), eq. (12)", check=non_negative)
        self.declare("gamma", 0.0, PARAMETER, "1",
                     "power-law exponent: < 0 pseudoplastic, 0 Newtonian, > 0 dilatant", check=_gamma)
        defaults = LubricantConstants()
        for name, (unit, text) in LUBRICANT.items():
            check = non_negative if name in ("lam_bar", "mu_shear_bar") else (
                _positive if name in ("lam", "mu_shear", "h", "tau_f", "tau_e", "phi3") else None)
            self.declare(name, float(getattr(defaults, name)), PARAMETER, unit, text, check=check)
        for name, (_, text) in EFFECTS.items():
            self.declare(name, True, PARAMETER, "1", text)
        self.declare("f0", 0.0, PARAMETER, "1", "boundary: excess volume at the start")
        # 1e-5 is ten times below the master's default step tolerance on the force; tighter
        # only costs sub-steps (measured on fig6: same nRMS(v) at 1e-5 and 1e-6)
        self.declare("kinetics_tol", 1e-5, PARAMETER, "1",
                     "boundary: tolerance (absolute and relative) of eq. (21) inside a step",
                     check=_positive)
        self.declare("dv", 0.0, INPUT, "m/s", "relative velocity V - v of the rubbing surfaces")
        self.declare("n", -20.0, INPUT, "Pa", "normal stress on the contact (negative in compression)")
        self.declare("T", 290.0, INPUT, "K", "lubricant temperature")
        self.declare("F", 0.0, OUTPUT, "N", "friction force on the lower block", depends_on=("dv", "n"),
                     getter=lambda: self.law().force(self.dv, self.n, self.f))
        self.declare("f", 0.0, OUTPUT, "1", "excess volume of the lubricant (0 = solid-like)")

    def law(self) -> FrictionLaw:
        if self._law is None or self._law[0] != self._parameter_token:
            self._law = self._parameter_token, FrictionLaw(
                regime=self.regime, mu_friction=self.mu_friction, S=self.S, m=self.m, gamma=self.gamma,
                lubricant=LubricantConstants(**{f.name: getattr(self, f.name) for f in fields(LubricantConstants)}),
                effects=Effects(**{field: getattr(self, name) for name, (field, _) in EFFECTS.items()}))
        return self._law[1]

    def changed(self, name):
        if name == "f0":
            self.f = self.f0

    def model_problems(self):
        return [] if "regime" in self._bad else self.law().problems()

    def initialize(self):
        self.f = self.f0
        self.dv_previous = None

    internal_state_names = ("dv_previous",)

    def advance(self, t, h):
        law = self.law()
        problems = law.input_problems(self.dv, self.n, self.T)
        if problems:
            return "; ".join(problems)
        if law.regime == BOUNDARY:  # dry and fluid laws have no state: nothing to integrate
            self.f = law.advance_f(self.f, self.dv, self.n, self.T, h, rtol=self.kinetics_tol,
                                   atol=self.kinetics_tol, dv_start=self.dv_previous)
        self.dv_previous = self.dv
        return None
