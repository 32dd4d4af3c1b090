"""The fmpy side of the master: FMU instances (the one place that calls an FMU), the run loop
and its recorders, and the clean-up of unzipped FMUs. The coupling itself, with nothing of
FMI in it, is :mod:`tribofmu.coupling`."""
from .instance import FMUCallError, FMUFileError, FMUInstance
from .run import GridRecorder, PointList, RunLimits, RunOutcome, run

__all__ = ["FMUCallError", "FMUFileError", "FMUInstance", "GridRecorder", "PointList", "RunLimits",
           "RunOutcome", "run"]
