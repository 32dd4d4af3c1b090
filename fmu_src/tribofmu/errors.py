"""The exceptions tribofmu raises on purpose, so a caller catches one base class.

Each message is one line naming the culprit (file, key and value; FMU instance and call).
The categories keep their built-in bases, so ``except ValueError`` or ``except RuntimeError``
written against earlier versions still catches them:

- :class:`ScenarioError` (a ``ValueError``): a scenario file, override or setting is wrong;
  :class:`SweepError` the same for a sweep's grid, options or output directory;
- :class:`FMUError`: an FMU file is missing or unreadable, or an FMU refused a call
  (``master.instance.FMUFileError``, ``FMUCallError``; ``api.FMUSetupError``);
- :class:`NumericalError` (a ``RuntimeError``): a computation a study depends on failed
  (a simulation that fails is a result with a message, not an exception).
"""
from __future__ import annotations


class TriboFMUError(Exception):
    """Base of every error tribofmu raises on purpose; the message is one line."""


class ScenarioError(TriboFMUError, ValueError):
    """A scenario file or override is wrong; the message is one line naming file, key, value."""


class SweepError(ScenarioError):
    """A bad grid, setting or output directory, found before any work: one line, exit code 2."""


class FMUError(TriboFMUError):
    """An FMU file is missing or unreadable, or an FMU call returned an error status."""


class NumericalError(TriboFMUError, RuntimeError):
    """A computation a study needs failed numerically (e.g. the reference solution)."""
