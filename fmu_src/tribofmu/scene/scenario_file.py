"""Reading a scenario file within limits, before TOML sees it: a regular file (not a FIFO or
device), at most MAX_SCENARIO_BYTES of UTF-8, keys and nesting not too deep. Every problem is
one :class:`~tribofmu.errors.ScenarioError` line naming the file."""
from __future__ import annotations

import math
import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from ..errors import ScenarioError

# Limits of what a scenario file may be: far above any real scene (the paper's are < 2 KB,
# keys two levels deep), low enough that reading and parsing stay within a second and a
# few MB. tomllib's time grows with the square of the dotted-key depth times the number of
# tables (a 391 KB file of deep dotted tables took minutes): the depth is checked on the
# text first, and so is the nesting of arrays and inline tables (tomllib recurses on it).
MAX_SCENARIO_BYTES = 1_000_000
MAX_KEY_DEPTH = 8  # dots in one key or table header
MAX_NESTING = 16  # arrays and inline tables inside each other

def read_scenario_text(path: Path) -> str:
    """The file's text: a regular file, at most MAX_SCENARIO_BYTES, UTF-8 (ScenarioError otherwise).

    Opened without blocking and checked before reading, so a FIFO or /dev/zero is refused
    instead of waited on or read without end."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read scenario file ({exc.strerror or exc})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = ("a folder" if stat.S_ISDIR(info.st_mode) else "a FIFO" if stat.S_ISFIFO(info.st_mode)
                    else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
                    else "a socket" if stat.S_ISSOCK(info.st_mode) else "not a regular file")
            raise ScenarioError(f"{path}: a scenario must be a regular file, this is {kind}")
        if info.st_size > MAX_SCENARIO_BYTES:
            raise ScenarioError(f"{path}: {info.st_size} bytes; a scenario file may have at most "
                                f"{MAX_SCENARIO_BYTES} bytes")
        chunks, size = [], 0
        while size <= MAX_SCENARIO_BYTES:
            chunk = os.read(fd, 65536)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        data = b"".join(chunks)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read scenario file ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    if len(data) > MAX_SCENARIO_BYTES:  # grew while read
        raise ScenarioError(f"{path}: a scenario file may have at most {MAX_SCENARIO_BYTES} bytes")
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ScenarioError(f"{path}: is UTF-16; a scenario must be UTF-8 (save it as UTF-8)")
    if b"\0" in data:
        line = data[:data.index(b"\0")].count(b"\n") + 1
        raise ScenarioError(f"{path}: a NUL byte on line {line} (UTF-16 without a byte-order mark?); "
                            f"a scenario must be UTF-8 text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ScenarioError(f"{path}: not UTF-8 (byte 0x{data[exc.start]:02x} on line {line}); "
                            f"a scenario must be UTF-8 text") from None


def _text_problem(text: str) -> str | None:
    """What makes the text too deep to parse, on a quick scan outside strings and comments."""
    depth = dots = 0
    line = 1
    quote = None  # the open string's quote character
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        if quote:
            if ch == "\\" and quote == '"':
                i += 2
                continue
            if ch == quote:
                quote = None
            elif ch == "\n":
                line += 1
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end
            continue
        elif ch == "\n":
            line += 1
            dots = 0
        elif ch in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return f"line {line}: arrays or tables nested more than {MAX_NESTING} deep"
        elif ch in "]}":
            depth = max(depth - 1, 0)
        elif ch == "." and not (i and text[i - 1].isdigit() and i + 1 < n and text[i + 1].isdigit()):
            dots += 1
            if dots > MAX_KEY_DEPTH:
                return f"line {line}: a key or table nested more than {MAX_KEY_DEPTH} levels deep"
        i += 1
    return None


def one_toml_value(text: str, what: str) -> Any:
    """``text`` read as one TOML value (``80``, ``1e-3``, ``true``, ``[5, 6.5]``, ``"a b"``), or
    as a bare word (``boundary``) when it is no TOML at all; anything more (a second line of
    TOML after the value: ``30\nx=1``, whose rest would be silently dropped) or a bare word
    with control characters is refused, naming ``what`` (e.g. ``--set drive.omega``)."""
    try:
        parsed = tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        parsed = None
    if parsed is not None and list(parsed) == ["v"]:
        return parsed["v"]
    if parsed is None and text.isprintable():
        return text  # a bare word, e.g. friction.regime=boundary
    raise ScenarioError(f"{what}: {_short(text)} is not one value (a number, true/false, a string, "
                        f"[an, array] or a bare word on one line)")


def _short(text: str, limit: int = 60) -> str:
    """A culprit quoted in a one-line message: control characters escaped, long text cut."""
    text = text.encode("unicode_escape").decode("ascii")
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


# Numbers: finite, and zero or of a magnitude in [1e-100, 1e100] (an integer beyond 2**53 is
# not a float exactly; 1e-300 rad/s makes a period that overflows the nanosecond clock).
NUMBER_RANGE = (1e-100, 1e100)


def _number(value: Any, key: str, source: str) -> float:
    """A TOML number as a finite float in :data:`NUMBER_RANGE` (or zero)."""
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    low, high = NUMBER_RANGE
    if not math.isfinite(number) or (number != 0 and not low <= abs(number) <= high):
        shown = _short(str(value), 30)
        raise ScenarioError(f"{source}: {key} must be a finite number of magnitude "
                            f"{low:g}..{high:g} (or 0), got {shown}")
    return number
