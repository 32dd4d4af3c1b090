"""Every exception tribofmu raises on purpose, in one module under one root, so a caller
catches one base class (:class:`TriboFMUError`); the modules that raise them re-export them
under their old names.

Each message is one line naming the culprit (file, key and value; FMU instance and call).
The categories keep their built-in bases, so ``except ValueError`` or ``except RuntimeError``
written against earlier versions still catches them:

- :class:`ScenarioError` (a ``ValueError``): a scenario file, override or setting is wrong;
  :class:`SweepError` the same for a sweep's grid, options or output directory;
- :class:`UsageError`: bad input from the command line or to an API call
  that is not a scenario's (an option, a folder); exit code 2; :class:`ArgumentError` an
  API argument of the wrong type or out of range;
- :class:`FMUError`: an FMU file is missing or unreadable (:class:`FMUFileError`), an FMU
  refused a call (:class:`FMUCallError`), the FMUs of a run could not be set up
  (:class:`FMUSetupError`), the FMU cache cannot be used (:class:`FMUCacheError`);
- :class:`NumericalError` (a ``RuntimeError``): a computation a study depends on failed
  (a simulation that fails is a result with a message, not an exception);
  :class:`RunawayError` a run's pace projects past its wall-time limit (caught by the run
  loop, which ends the run with a message), :class:`SolveOutOfTime` a monolithic solve past
  its wall-time limit (caught by the solver, which returns a failed result),
  :class:`PointTimeout` a sweep point past its time limit.
"""
from __future__ import annotations

from typing import Sequence


# An error line a person reads: at most this many characters. A longer message (a 990 kB
# string or a 200,000-element array echoed as the culprit) has its long words cut, then its
# middle, keeping the start (what is wrong) and the end (what to do).
MAX_MESSAGE = 300
LONG_WORD = 200  # characters: a word this long is a value, cut to its start and length
SHORT_WORD = 40  # a word (a path) longer than this is cut to its start and end when the line is too long


def readable(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` cut to at most ``limit`` characters (unchanged when it fits): its longest
    words first (a value keeps its start and its length, a path its start and its file
    name), then, if still too long, its middle."""
    if len(text) <= limit:
        return text
    words = text.split(" ")
    length = len(text)
    for short in (SHORT_WORD, SHORT_WORD // 2):  # a second, closer cut before the middle goes
        for i in sorted(range(len(words)), key=lambda i: -len(words[i])):
            word = words[i]
            if len(word) <= short or length <= limit:
                break
            tail = short - short // 4 - 3
            if "/" in word[-LONG_WORD:]:  # a path: its file name whole
                tail = max(tail, len(word) - word.rindex("/", 0, len(word) - 1))
            cut = (f"{word[:30]}...({len(word)} characters)" if len(word) > LONG_WORD
                   else f"{word[:short // 4]}...{word[-tail:]}")
            if len(cut) < len(word):
                words[i] = cut
                length -= len(word) - len(cut)
    text = " ".join(words)
    if len(text) <= limit:
        return text
    tail = limit // 4
    head = limit - tail - len(f" [...{len(text)} characters...] ")
    return f"{text[:head]} [...{len(text) - head - tail} characters...] {text[-tail:]}"


class TriboFMUError(Exception):
    """Base of every error tribofmu raises on purpose; the message is one line, at most
    :data:`MAX_MESSAGE` characters (:func:`readable`)."""

    def __init__(self, *args):
        if args and isinstance(args[0], str):
            args = (readable(args[0]), *args[1:])
        super().__init__(*args)


class ScenarioError(TriboFMUError, ValueError):
    """A scenario file or override is wrong; the message is one line naming file, key, value."""


class SweepError(ScenarioError):
    """A bad grid, setting or output directory, found before any work: one line, exit code 2."""


class FMUError(TriboFMUError):
    """An FMU file is missing or unreadable, or an FMU call returned an error status."""


class NumericalError(TriboFMUError, RuntimeError):
    """A computation a study needs failed numerically (e.g. the reference solution)."""


class UsageError(TriboFMUError):
    """Bad input from the command line (or an API argument that is no scenario's): reported as
    one line, exit code 2."""


class ArgumentError(UsageError, ValueError, TypeError):
    """An argument of a public API call of the wrong type or out of range, found before any
    work: one line naming the call, the argument and its value. Also a ValueError and a
    TypeError, what such an argument raised from deeper down before."""


# -- FMUs -------------------------------------------------------------------------------------
STATUS_NAMES = ("fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal", "fmi2Pending")


class FMUCallError(FMUError, RuntimeError):
    """An FMU call returned a status worse than fmi2Warning (fmi3Warning); the status codes
    0-4 mean the same in FMI 2.0 and 3.0."""

    def __init__(self, instance: str, call: str, status: int, messages: Sequence[str] = ()):
        self.instance, self.call, self.status, self.messages = instance, call, status, list(messages)
        label = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else f"status {status}"
        if call.startswith("fmi3"):
            label = label.replace("fmi2", "fmi3")
        detail = f": {'; '.join(self.messages)}" if self.messages else ""
        super().__init__(f"{instance}: {call} returned {label}{detail}")

    def __reduce__(self):  # pickled as its parts (a forked run hands it to its parent)
        return type(self), (self.instance, self.call, self.status, self.messages)

    @property
    def discarded(self) -> bool:
        """True if the FMU refused the step but stays usable (a smaller step may work)."""
        return self.status == 2


class FMUFileError(FMUError, FileNotFoundError):
    """An FMU file is missing or unreadable (``filename``, when set, names it)."""

    def __str__(self) -> str:  # the message, also once filename is set (OSError would reformat it)
        return str(self.args[0]) if self.args else super().__str__()


class FMUSetupError(FMUError, RuntimeError):
    """One or more FMUs could not be loaded or initialized; the message names each instance."""


class FMUCacheError(FMUError):
    """The FMU cache cannot be used (not ours, a link, not writable, disk full)."""


# -- runs -------------------------------------------------------------------------------------
class RunawayError(NumericalError):
    """Raised inside the run loop when the pace projects past the wall-time limit."""


class SolveOutOfTime(NumericalError):
    """Raised from inside scipy's right-hand side to stop a monolithic solve past its wall-time
    limit (caught by :func:`tribofmu.studies.reference.monolithic.solve_monolithic`)."""


class PointTimeout(TriboFMUError):
    """A sweep point ran longer than the sweep's per-point time limit."""
