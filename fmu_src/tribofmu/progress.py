"""Progress and interruption of long runs.

:class:`RunBar` is a progress callback for ``api.simulate(progress=...)``: a bar on stderr
with simulated time, accepted and rejected steps, quiet when stderr is not a terminal
(logs, pipes, tests) or when asked to be.

Ctrl-C and SIGTERM during a run: the FMUs run Python code in this same interpreter, and
pythonfmu turns any exception raised inside that code (a KeyboardInterrupt included) into
``fmi2Fatal``, which loses the instance and reads as a numerical failure. So while a run is
in progress the signal handler installed by :func:`install_signal_handlers` only records
the request, and the progress callback (called by the master between steps, outside any
FMU) raises :class:`KeyboardInterrupt` there. Outside a run the handler raises at once.
"""
from __future__ import annotations

import contextlib
import signal
import sys
import time

_state = {"running": 0, "requested": False, "own_process": False}
# Ctrl-C, kill, and a closed terminal or ssh session: each a clean stop (temp files removed)
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


def _handler(signum, _frame):
    if _state["running"] and not _state["requested"]:
        _state["requested"] = True  # stop at the next communication point
        return
    _state["requested"] = False
    raise KeyboardInterrupt  # outside a run, or a second signal: stop now


def install_signal_handlers(own_process: bool = False) -> None:
    """Ctrl-C (SIGINT) and SIGTERM stop cleanly; call from the main thread. own_process: the
    caller is the process's entry point (the ``tribofmu`` command), so :func:`work_done` may
    take the signals for the rest of the process's life."""
    _state["own_process"] = _state["own_process"] or own_process
    for sig in STOP_SIGNALS:
        try:
            if sig not in (signal.SIGINT, signal.SIGTERM) and signal.getsignal(sig) == signal.SIG_IGN:
                continue  # started under nohup: the run is to outlive its terminal
            signal.signal(sig, _handler)
        except ValueError:  # not the main thread: leave signals to the host
            return


def work_done() -> None:
    """The command's result is complete (written, or its failure said): from here on a Ctrl-C
    or SIGTERM can neither lose nor change anything, so it is ignored. Without this, one that
    arrives during the teardown (Dask's atexit handlers, which then print a traceback, or the
    interpreter's finalization, which restores the default handlers and dies by SIGINT with
    nothing said) replaces the exit status of the finished work. Only in the ``tribofmu``
    process itself: a host that calls ``cli.main`` keeps its own signal handling."""
    if not _state["own_process"]:
        return
    for sig in STOP_SIGNALS:
        try:
            signal.signal(sig, signal.SIG_IGN)
        except ValueError:  # not the main thread
            return


def check_interrupt() -> None:
    """Raise KeyboardInterrupt if a stop was requested during the run (call between steps)."""
    if _state["requested"]:
        _state["requested"] = False
        raise KeyboardInterrupt


@contextlib.contextmanager
def deferred_interrupts():
    """Inside: a first Ctrl-C/SIGTERM only requests a stop, which :func:`check_interrupt`
    (called between steps or runs) turns into KeyboardInterrupt; a second one stops at once.
    On leaving normally, a pending request raises KeyboardInterrupt."""
    _state["running"] += 1
    try:
        yield
    finally:
        _state["running"] -= 1
    check_interrupt()


class RunBar:
    """A progress callback for ``api.simulate(progress=...)``; use as a context manager.

    The bar counts simulated seconds; its text shows accepted steps and rejected
    (rolled-back) steps. Redraws at most every ``interval`` seconds, so a run of 10^5
    steps pays nothing for it. Inside the ``with`` block a Ctrl-C is deferred to the next
    communication point (see the module docstring).
    """

    def __init__(self, desc: str, stop_time: float, enabled: bool | None = None, interval: float = 0.2,
                 stream=None):
        stream = stream if stream is not None else sys.stderr
        self._stream = stream
        self.enabled = stream.isatty() if enabled is None else enabled
        self.interval = interval
        self._last = 0.0
        self._bar = None
        if self.enabled:
            from tqdm import tqdm  # 29 ms at start-up (-X importtime, min of 5, 2026-11-26 23:59 UTC),
            # only for a bar on a terminal: not for --help, 'scenes', tests, pipes or the API
            self._bar = tqdm(total=stop_time, desc=desc, unit="s", file=stream, leave=False,
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} s "
                                        "[{elapsed}<{remaining}] {postfix}")

    def __call__(self, status) -> None:
        check_interrupt()
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._last < self.interval and status.t < status.stop_time:
            return
        self._last = now
        # the run ends on the whole nanosecond nearest the stop, which may lie past the
        # bar's float total: clamp to it (tqdm warns "clamping frac" at a fraction > 1)
        self._bar.n = min(status.t, status.stop_time, self._bar.total)
        self._bar.set_postfix_str(f"{status.steps} steps, {status.rejected} rejected", refresh=False)
        self._bar.refresh()

    def notice(self, text: str) -> None:
        """A one-line message on the bar's stream (above the bar, which stays)."""
        line = f"tribofmu: {text}"
        if self._bar is not None:
            self._bar.write(line, file=self._stream)
        else:
            print(line, file=self._stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> "RunBar":
        self._deferred = deferred_interrupts()
        self._deferred.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.close()
        self._deferred.__exit__(*exc)  # asked to stop during the last step: stop now
