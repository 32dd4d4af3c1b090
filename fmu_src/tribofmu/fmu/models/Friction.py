"""Friction FMU: the friction law of one pair. Inputs dv, n, T; outputs F, f.

Any law of :mod:`tribofmu.physics.laws` (parameter ``regime``, its code), with the boundary model's terms
switched by the Boolean parameters ``*_term`` and ``melting``. The FMU never learns the
block's mass: a stuck contact is the coupling algorithm's business (sgn(0) = 0 here).
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, INPUT, OUTPUT
from tribofmu.fmu.parameters import declare_friction_inputs, declare_friction_parameters, friction_law, parameter_cached
from tribofmu.physics.friction import FrictionLaw

class Friction(Fmi2Slave):
    description = ("Friction law of the seed paper: dry, fluid (power law) or boundary (Landau) friction, "
                   "or mixed (Stribeck) friction")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.dv_previous = None  # m/s, the input of the last step (None: none yet)
        declare_friction_parameters(self)
        self.declare("dv", 0.0, INPUT, "m/s", "relative velocity V - v of the rubbing surfaces")
        declare_friction_inputs(self)
        self.declare("F", 0.0, OUTPUT, "N", "friction force on the lower block", depends_on=("dv", "n"),
                     getter=lambda: self.law().force(self.dv, self.n, self.f))
        self.declare("f", 0.0, OUTPUT, "1", "excess volume of the lubricant (0 = solid-like)")
        self.declare("melt_margin", 1.0, OUTPUT, "1",
                     "boundary friction: mu/mu_bar - f, > 0 while the lubricant is solid-like (its "
                     "elastic stress acts), <= 0 once molten; a sign change inside a step is a phase "
                     "change for a master to locate; 1 for laws without a lubricant",
                     getter=lambda: self.law().melt_margin(self.f))
        self.declare("F_mean", 0.0, OUTPUT, "N",
                     "mean friction force over the last step, dv moving linearly from the previous "
                     "step's input to this one (a force peaking inside the step shows here)")

    @parameter_cached
    def law(self) -> FrictionLaw:
        return friction_law(self)

    def changed(self, name):
        if name == "f0":
            self.f = self.f0

    def model_problems(self):
        return [] if "regime" in self._bad else self.law().problems()

    def initialize(self):
        self.f = self.f0
        self.F_mean = 0.0
        self.dv_previous = None

    internal_state_names = ("dv_previous",)

    def advance(self, t, h):
        law = self.law()
        problems = law.input_problems(self.dv, self.n, self.T)
        if problems:
            return "; ".join(problems)
        # (a law without state gives f unchanged and the mean force)
        self.f, self.F_mean = law.advance(self.f, self.dv, self.n, self.T, h, rtol=self.kinetics_tol,
                                          atol=self.kinetics_tol, dv_start=self.dv_previous)
        self.dv_previous = self.dv
        return None
