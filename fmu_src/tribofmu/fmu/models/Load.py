"""Load FMU: a normal-stress program n(t) for the friction's input n (negative in compression).

Programs (parameter ``program``): 0 constant n0; 1 ramp from n0 at t_start to n1 at t_end;
2 step from n0 to n1 at t_start; 3 sine n0 + amplitude sin(2 pi t / period + phase).
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, PARAMETER, OUTPUT
from tribofmu.fmu.parameters import parameter_cached
from tribofmu.physics.load import PROGRAM_NAMES, LoadProgram


def _program(value):
    return None if value in PROGRAM_NAMES else (
        f"must be 0 (constant), 1 (ramp), 2 (step) or 3 (sine), got {value}")


class Load(Fmi2Slave):
    description = "Normal stress program n(t): constant, ramp, step or sine"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        d = LoadProgram()
        self.declare("program", d.program, PARAMETER, "1",
                     "0 = constant, 1 = ramp, 2 = step, 3 = sine", check=_program)
        self.declare("n0", d.n0, PARAMETER, "Pa", "normal stress: constant value, value before a ramp "
                     "or step, mean of a sine (negative in compression)")
        self.declare("n1", d.n1, PARAMETER, "Pa", "ramp and step: normal stress after")
        self.declare("t_start", d.t_start, PARAMETER, "s", "ramp: start; step: time of the step")
        self.declare("t_end", d.t_end, PARAMETER, "s", "ramp: end (n reaches n1)")
        self.declare("amplitude", d.amplitude, PARAMETER, "Pa", "sine: amplitude")
        self.declare("period", d.period, PARAMETER, "s", "sine: period")
        self.declare("phase", d.phase, PARAMETER, "rad", "sine: phase at t = 0")
        self.declare("n", d.n0, OUTPUT, "Pa", "normal stress on the contact",
                     getter=lambda: self.program_().n(self.time))

    @parameter_cached
    def program_(self) -> LoadProgram:
        return LoadProgram(program=self.program, n0=self.n0, n1=self.n1, t_start=self.t_start, t_end=self.t_end,
                           amplitude=self.amplitude, period=self.period, phase=self.phase)

    def model_problems(self):
        return [] if "program" in self._bad else self.program_().problems()

    def advance(self, t, h):
        return None
