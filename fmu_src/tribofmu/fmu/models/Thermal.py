"""Thermal FMU: lumped heat balance of the lubricant film, C dT/dt = q P - G (T - T_ambient).

The heating power is ``P + F dv`` held over the step: a master that knows the step's mean
friction power (the tribofmu master integrates it exactly) sets ``P`` and leaves ``F`` and
``dv`` at 0; a master that can only connect variables (an SSP master) connects the
friction force and the relative velocity to ``F`` and ``dv`` instead. Outputs: the film
temperature ``T`` (for the friction's input T) and the heat received and conducted away so
far, for energy bookkeeping.
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, INPUT, OUTPUT
from tribofmu.fmu.parameters import declare_parameter, declared, parameter_cached
from tribofmu.physics.thermal import START_T, ThermalParams, advance_thermal


class Thermal(Fmi2Slave):
    description = "Lumped heat balance of the lubricant film heated by friction"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for p in (*declared(ThermalParams), START_T):
            declare_parameter(self, p)
        self.declare("P", 0.0, INPUT, "W", "friction power over the step (a master's exact mean)")
        self.declare("F", 0.0, INPUT, "N", "friction force, for masters that connect variables")
        self.declare("dv", 0.0, INPUT, "m/s", "relative velocity V - v, for masters that connect variables")
        self.declare("T", 290.0, OUTPUT, "K", "film temperature")
        self.declare("Q", 0.0, OUTPUT, "J", "heat received by the film so far, q int (P + F dv) dt")
        self.declare("Q_lost", 0.0, OUTPUT, "J", "heat conducted to the surroundings so far")

    @parameter_cached
    def params(self) -> ThermalParams:
        return ThermalParams(**{p.name: getattr(self, p.name) for p in declared(ThermalParams)})

    def model_problems(self):
        return self.params().problems()

    def changed(self, name):
        if name == "T0":
            self.T = self.T0

    def initialize(self):
        self.T, self.Q, self.Q_lost = self.T0, 0.0, 0.0

    def advance(self, t, h):
        step = advance_thermal(self.T, self.P + self.F * self.dv, h, self.params())
        self.T = step.T
        self.Q += step.received
        self.Q_lost += step.lost
        return None
