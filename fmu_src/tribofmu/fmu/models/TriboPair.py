"""TriboPair FMU: the block and the friction law in one FMU, their loop closed inside.

The dv -> F -> dv loop is stiff and, at stick, set-valued: a master that exchanges F and dv
once per step (every mainstream co-simulation master) chatters at stick. This FMU runs the
tribofmu master's own implicit, error-controlled coupling (:mod:`tribofmu.coupling.pair`) on
the shipped physics inside its ``doStep``: as many internal steps as its ``tol`` needs within
the host's step, stick held exactly, rejected internal steps rolled back internally. A host
connects only the drive: ``V`` and, so that the pair follows V within the step instead of
holding it, the drive's acceleration ``a_drive``.

Parameters: those of BlockSpring and Friction (same names, units and checks) and ``tol``.
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, PARAMETER, INPUT, OUTPUT, positive
from tribofmu.fmu.parameters import (declare_block_outputs, declare_block_parameters, declare_friction_inputs,
                                     declare_friction_parameters, friction_law, parameter_cached)
from tribofmu.coupling.pair import PairModel, PairParameters

OUTPUTS = ("x", "v", "a", "F", "f", "dv", "stuck")


class TriboPair(Fmi2Slave):
    description = ("Block between two springs and its friction law, coupled implicitly inside the FMU "
                   "(exact stick, error-controlled internal steps)")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._model = None
        declare_block_parameters(self)
        declare_friction_parameters(self)
        self.declare("tol", 1e-3, PARAMETER, "1",
                     "relative tolerance of the internal coupling (as tribofmu simulate --tol)", check=positive)
        self.declare("V", 0.0, INPUT, "m/s", "upper block velocity at the start of the step")
        self.declare("a_drive", 0.0, INPUT, "m/s2",
                     "upper block acceleration at the start of the step: V + a_drive s is followed "
                     "within the step (0: V held)")
        declare_friction_inputs(self)
        declare_block_outputs(self)
        self.declare("F", 0.0, OUTPUT, "N", "friction force on the lower block at the end of the step")
        self.declare("f", 0.0, OUTPUT, "1", "excess volume of the lubricant (0 = solid-like)")
        self.declare("dv", 0.0, OUTPUT, "m/s", "relative velocity V - v at the end of the step")
        self.declare("stuck", 0.0, OUTPUT, "1",
                     "1 where the internal coupling held the blocks together over its last step, else 0")

    @parameter_cached
    def law(self):
        return friction_law(self)

    def changed(self, name):
        if name in ("x0", "v0"):
            self.x, self.v = self.x0, self.v0
        elif name == "f0":
            self.f = self.f0

    def model_problems(self):
        return [] if "regime" in self._bad else self.law().problems()

    def _parameters(self):
        # not the cached law: while a state is set, its parameters are in place but the cache
        # key (the parameter token) is renewed only afterwards
        return PairParameters(self.M, self.K, self.x0, self.v0, friction_law(self), self.f0, self.tol,
                              self.kinetics_tol)

    def initialize(self):
        self._model = PairModel(self._parameters(), self.time, self.V, self.a_drive, self.n, self.T)
        self._show(self._model.point)

    def _show(self, point):
        self.x, self.v, self.a, self.F, self.f = point.x, point.v, point.a, point.F, point.f
        self.dv, self.stuck = point.V - point.v, float(point.mode.stuck)

    @property
    def pair_state(self):
        """The coupled model's state as plain values (None before initialization); restored
        with the parameters in place (an FMU state sets them before this)."""
        return None if self._model is None else self._model.snapshot()

    @pair_state.setter
    def pair_state(self, snapshot):
        self._model = None if snapshot is None else PairModel.from_snapshot(self._parameters(), snapshot)

    internal_state_names = ("pair_state",)

    def advance(self, t, h):
        problems = self.law().input_problems(0.0, self.n, self.T)
        if problems:
            return "; ".join(problems)
        self._show(self._model.step(t, h, self.V, self.a_drive, self.n, self.T))
        return None
