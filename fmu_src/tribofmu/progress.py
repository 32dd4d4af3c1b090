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


# A further run of a checked call (at half the per-step tolerance of the last) takes about as
# long as the last: 0.78-1.14x on boundary_heating, fig2_dry, fig6_boundary and mixed_stribeck
# (stats.json "check" of tribofmu simulate, 2026-11-26); the projection counts 1.15x.
FURTHER_RUN_COST = 1.15
# The check's last planned run is followed by another about this often (fig6_boundary and
# mixed_stribeck took a third run, boundary_heating and fig2_dry did not, same measurement):
# the projection counts that share of a further run, so the bar keeps room for it.
EXTRA_RUN_CHANCE = 0.5
# Until the run has this much wall time [s] behind it, its pace says little: the bar counts
# simulated time instead.
PACE_AFTER_S = 0.5
# The bar's share left for a run the check may still ask for, until the call ends
HELD_BACK = 0.02

_active: list["RunBar"] = []  # the bars entered (the innermost is told of the call's runs)


def run_started(run: int, runs: int) -> None:
    """A call of several runs (an adaptive run's check, :mod:`tribofmu.checked`) starts its
    run ``run`` of the ``runs`` planned so far: the bar entered, if any, says so."""
    if _active:
        _active[-1].start_run(run, runs)


class RunBar:
    """A progress callback for ``api.simulate(progress=...)``; use as a context manager.

    One bar over the whole call: a checked adaptive call makes several runs (run k of n,
    n as planned so far, from :func:`run_started`), and the bar neither starts again with
    each run nor ever runs backwards. Its fraction is the wall time spent over the wall time
    spent plus the projected rest: the rest of this run at its present pace and each run
    still planned at :data:`FURTHER_RUN_COST` times this run's, and :data:`EXTRA_RUN_CHANCE` of
    one more (before a run's pace is known, the simulated time over the runs planned). When the
    check adds a run, the rest of the bar is mapped onto the rest of the new plan, so the bar
    goes on from where it is; the last :data:`HELD_BACK` waits for the call's end.
    The text shows the run, its simulated time, accepted and rejected steps, and the
    projected time left. Redraws at most every ``interval`` seconds, so a run of 10^5 steps
    pays nothing for it. Inside the ``with`` block a Ctrl-C is deferred to the next
    communication point (see the module docstring).
    """

    def __init__(self, desc: str, stop_time: float, enabled: bool | None = None, interval: float = 0.2,
                 stream=None):
        stream = stream if stream is not None else sys.stderr
        self._stream = stream
        self.enabled = stream.isatty() if enabled is None else enabled
        self.interval = interval
        self.stop_time = stop_time
        self.run, self.runs = 1, 1  # run k of n planned so far
        self._done_wall = 0.0  # wall time of the call's finished runs [s]
        self._run_wall = 0.0  # this run's wall time so far [s]
        self._run_projected = None  # this run's projected wall time [s] (None: pace not known yet)
        self.fraction = 0.0  # of the whole call, as shown: never decreases
        self._from = (0.0, 0.0)  # (shown, estimated) when the plan last grew: the rest maps onto the rest
        self._last = 0.0
        self._bar = None
        if self.enabled:
            from tqdm import tqdm  # 29 ms at start-up (-X importtime, min of 5, 2026-11-26 23:59 UTC),
            # only for a bar on a terminal: not for --help, 'scenes', tests, pipes or the API
            self._bar = tqdm(total=1.0, desc=desc, file=stream, leave=False,
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} [{elapsed}]")

    def start_run(self, run: int, runs: int) -> None:
        """Run ``run`` of ``runs`` (planned so far) of the call starts."""
        if run > self.run:
            self._done_wall += self._run_wall
            # until its own pace is measured, the new run is projected as the last one's next
            # run was: the estimate goes on across the boundary without a jump
            last = self._run_projected
            self._run_wall, self._run_projected = 0.0, None if last is None else FURTHER_RUN_COST * last
        if max(runs, run) > self.runs:  # the plan grew: what is left of the bar covers what is left
            self._from = (self.fraction, None)
        self.run, self.runs = run, max(runs, run)

    def remaining(self) -> float | None:
        """Projected wall time [s] until the whole call ends (None: no pace measured yet)."""
        if self._run_projected is None:
            return None
        further = self.runs - self.run + (EXTRA_RUN_CHANCE if self.runs > 1 else 0.0)
        return max(self._run_projected - self._run_wall, 0.0) + further * FURTHER_RUN_COST * self._run_projected

    def _estimate(self, t: float) -> float:
        rest = self.remaining()
        if rest is None:  # no pace yet: simulated time over the runs planned
            share = min(max(t / self.stop_time, 0.0), 1.0) if self.stop_time > 0 else 0.0
            return (self.run - 1 + share) / self.runs
        spent = self._done_wall + self._run_wall
        return spent / (spent + rest) if spent + rest > 0 else 0.0

    def __call__(self, status) -> None:
        check_interrupt()
        wall = getattr(status, "wall_time", None)
        if wall is not None:
            self._run_wall = wall
            if wall >= PACE_AFTER_S and 0 < status.t < status.stop_time:
                self._run_projected = wall * status.stop_time / status.t
        estimate = self._estimate(status.t)
        shown, start = self._from
        if start is None:  # the first estimate since the plan grew
            start = estimate
            self._from = (shown, start)
        mapped = shown + (1.0 - shown) * max(estimate - start, 0.0) / (1.0 - start) if start < 1.0 else shown
        self.fraction = max(self.fraction, min(mapped, 1.0 - HELD_BACK))
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._last < self.interval and status.t < status.stop_time:
            return
        self._last = now
        self._bar.n = self.fraction
        # the run ends on the whole nanosecond nearest the stop, which may lie past the
        # scene's float stop time: clamp the time shown to it
        t = min(status.t, status.stop_time)
        run = f"run {self.run} of {self.runs}, " if self.runs > 1 else ""
        rest = self.remaining()
        left = f", about {_duration(rest)} left" if rest is not None else ""
        self._bar.set_postfix_str(f"{run}t = {t:.4g}/{status.stop_time:.4g} s, {status.steps} steps, "
                                  f"{status.rejected} rejected{left}", refresh=False)
        self._bar.refresh()

    def notice(self, text: str) -> None:
        """A one-line message on the bar's stream (above the bar, which stays); inside a call
        of several runs it adds the run and the whole call's projected time."""
        rest = self.remaining()
        if self.runs > 1 and rest is not None:
            text += (f" (run {self.run} of {self.runs} planned so far; the whole call about "
                     f"{_duration(self._done_wall + self._run_wall + rest)})")
        line = f"tribofmu: {text}"
        if self._bar is not None:
            self._bar.write(line, file=self._stream)
        else:
            print(line, file=self._stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        if self in _active:
            _active.remove(self)

    def __enter__(self) -> "RunBar":
        _active.append(self)
        self._deferred = deferred_interrupts()
        self._deferred.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.close()
        self._deferred.__exit__(*exc)  # asked to stop during the last step: stop now


def _duration(seconds: float) -> str:
    from .master.run import _duration as duration  # the master's own wording ("7.8 min")
    return duration(seconds)
