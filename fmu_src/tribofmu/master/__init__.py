"""The fmpy-based co-simulation master: slaves, coupled system, coupling algorithms, run loop."""
from .algorithms import ALGORITHMS, CouplingAlgorithm, Scales, make_algorithm
from .interpolation import NS, sample
from .run import GridRecorder, PointList, RunLimits, RunOutcome, run
from .instance import FMUCallError, FMUFileError, FMUInstance
from .system import CoupledSystem, Point

__all__ = ["ALGORITHMS", "CouplingAlgorithm", "Scales", "make_algorithm", "RunOutcome", "run",
           "sample", "FMUCallError", "FMUFileError", "FMUInstance", "CoupledSystem", "Point"]
