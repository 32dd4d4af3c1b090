"""Drive FMU: the upper block moved as X = A cos(omega t), V = -A omega sin(omega t) (eqs. 1-2)."""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, OUTPUT
from tribofmu.fmu.parameters import declare_parameter, declared
from tribofmu.physics.drive import DriveParams, drive


class Drive(Fmi2Slave):
    description = "Harmonic drive of the upper block"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for p in declared(DriveParams):
            declare_parameter(self, p)
        self._motion_at = (None, (0.0, 0.0, 0.0))  # ((time, A, omega), (X, V, a)) last computed
        self.declare("X", 0.0, OUTPUT, "m", "upper block position", getter=lambda: self.motion()[0])
        self.declare("V", 0.0, OUTPUT, "m/s", "upper block velocity", getter=lambda: self.motion()[1])
        self.declare("a", 0.0, OUTPUT, "m/s2", "upper block acceleration", getter=lambda: self.motion()[2])

    def motion(self):
        """X [m], V [m/s], a [m/s2] now, computed once for the three outputs (each step computes them all)."""
        key = (self.time, self.A, self.omega)
        if self._motion_at[0] != key:
            self._motion_at = (key, drive(*key))
        return self._motion_at[1]

    def advance(self, t, h):
        return None
