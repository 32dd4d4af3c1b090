"""BlockSpring FMU: the lower block between two springs, M x'' + 2 K x = F (eq. 3).

Input F is the friction force; F_rate (default 0) lets a master that can give the force's
slope over the step do so (first-order hold), external masters leave it at 0. Input V, the
upper block's velocity, only serves the output dv = V - v, so that SSP connections (which
cannot subtract) can feed the friction FMU.
"""
# The model class derives from the name Fmi2Slave (the FMI 3.0 build renames it Fmi3Slave,
# the text pythonfmu3 looks for); everything FMI-specific comes from base.
from tribofmu.fmu.base import TriboModel as Fmi2Slave, DefaultExperiment, INPUT, OUTPUT
from tribofmu.fmu.parameters import declare_block_outputs, declare_block_parameters
from tribofmu.physics.block import BlockState, acceleration, advance_block


class BlockSpring(Fmi2Slave):
    description = "Block of mass M between two springs of stiffness K, driven by a force F"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        declare_block_parameters(self)
        self.declare("F", 0.0, INPUT, "N", "force on the block (friction) at the start of the step")
        self.declare("F_rate", 0.0, INPUT, "N/s", "slope of F over the step (0: F held constant)")
        self.declare("V", 0.0, INPUT, "m/s", "upper block velocity, only used for the output dv")
        declare_block_outputs(self)
        self.declare("dv", 0.0, OUTPUT, "m/s", "relative velocity V - v", depends_on=("V",),
                     getter=lambda: self.V - self.v)

    def changed(self, name):
        if name in ("x0", "v0"):
            self.x, self.v = self.x0, self.v0

    def initialize(self):
        self.x, self.v = self.x0, self.v0
        self.a = acceleration(BlockState(self.x, self.v), self.F, self.M, self.K)

    def advance(self, t, h):
        state = advance_block(BlockState(self.x, self.v), self.F, self.F_rate, h, self.M, self.K)
        self.x, self.v = state.x, state.v
        self.a = acceleration(state, self.F + self.F_rate * h, self.M, self.K)
        return None
