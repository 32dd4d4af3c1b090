"""Load FMU: a normal-stress program n(t) for the friction's input n (negative in compression).

Programs (parameter ``program``): 0 constant n0; 1 ramp from n0 at t_start to n1 at t_end;
2 step from n0 to n1 at t_start; 3 sine n0 + amplitude sin(2 pi t / period + phase).
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, OUTPUT
from tribofmu.fmu.parameters import declare_parameter, declared, parameter_cached
from tribofmu.physics.load import LoadProgram


class Load(Fmi2Slave):
    description = "Normal stress program n(t): constant, ramp, step or sine"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for p in declared(LoadProgram):
            declare_parameter(self, p)
        self.declare("n", LoadProgram.n0, OUTPUT, "Pa", "normal stress on the contact",
                     getter=lambda: self.program_().n(self.time))

    @parameter_cached
    def program_(self) -> LoadProgram:
        return LoadProgram(**{p.name: getattr(self, p.name) for p in declared(LoadProgram)})

    def model_problems(self):
        return [] if "program" in self._bad else self.program_().problems()

    def advance(self, t, h):
        return None
