"""The FMI names the tribofmu FMUs use, from pythonfmu (FMI 2.0) or pythonfmu3 (FMI 3.0) as
:data:`.fmi_version.FMI_VERSION` says, and the constants of the FMI state machine; the one
module that imports either library."""
from __future__ import annotations

from .. import __version__
from .fmi_version import FMI_VERSION

# one library or the other, as the build wrote fmi_version.py: a host of FMI 2.0 FMUs needs no pythonfmu3
if FMI_VERSION == 3:
    from pythonfmu3 import Boolean, Fmi3Causality as Causality, Fmi3Slave as _PythonFMUSlave
    from pythonfmu3 import Fmi3Variability as Variability, Float64 as Real, Int32 as Integer
    from pythonfmu3 import String, UInt64
    from pythonfmu3.default_experiment import DefaultExperiment
    from pythonfmu3.enums import Fmi3Initial as Initial, Fmi3Status as Status
    from pythonfmu3.fmi3slave import Fmi3StepResult
else:
    from pythonfmu import Boolean, Fmi2Causality as Causality, Fmi2Slave as _PythonFMUSlave
    from pythonfmu import Fmi2Variability as Variability, Integer, Real, String
    UInt64 = None  # FMI 2.0 has no such type
    from pythonfmu.default_experiment import DefaultExperiment
    from pythonfmu.enums import Fmi2Initial as Initial, Fmi2Status as Status

PARAMETER, INPUT, OUTPUT = Causality.parameter, Causality.input, Causality.output

AUTHOR = "tribofmu developers"
LICENSE = "MIT"
VERSION = __version__  # the package's; a built FMU carries its own copy of the package's __init__.py

_KINDS = {float: Real, int: Integer, bool: Boolean}
_PREFIX = f"fmi{FMI_VERSION}"
# The FMI names of the typed calls, for messages: Python type of the variable -> suffix.
_TYPE_NAMES = {Real: "Float64" if FMI_VERSION == 3 else "Real",
               Integer: "Int32" if FMI_VERSION == 3 else "Integer", Boolean: "Boolean",
               String: "String", UInt64: "UInt64"}
_STATE = "FMUState" if FMI_VERSION == 3 else "FMUstate"

# The log category of a refusal: the FMUs' native loader (tribofmu.native, between the host and
# pythonfmu's binary) returns the status of such a message as the status of the call, so a
# refused setter, getter, initialization or FMU state answers fmi2Error/fmi3Error there. The
# loader hands the message on under the usual logStatusError category.
CALL_STATUS_CATEGORY = "tribofmuCallStatus"

# The FMI states a co-simulation instance passes through (error is a flag beside them).
INSTANTIATED, INITIALIZATION, STEP, TERMINATED = (
    "instantiated", "initialization mode", "step mode", "terminated")
