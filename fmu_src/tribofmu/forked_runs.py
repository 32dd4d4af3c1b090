"""The runs of a checked call (:mod:`tribofmu.checked`), two at a time, each in a forked process.

A checked call runs one simulation at the per-step tolerances its sequence asks for, one after
another (Shampine's rule). The second run of a pair is always needed, and a chain's next run
(CHECK_RATIO tighter) often is: so while the sequence waits for one run, a second process
already runs the one the sequence asks for next if it goes on as a chain. A run it does not ask
for is stopped and what it wrote is removed. The sequence, its decisions and its result are the
sequential ones (each run is the same deterministic simulation, only started earlier); the wall
time is not: a pair costs its tighter run's time, not both runs'.

Each run is a child of this process made by ``fork``: the scene, the FMUs' unzipped copies and
the code are already in memory, so a run starts at once. A child ignores the stop signals (its
parent stops it, and a Ctrl-C reaches the parent), dies with its parent (Linux:
``PR_SET_PDEATHSIG``), writes its samples into the spool its parent made, its progress into a
pipe its parent forwards to the caller's callbacks, and its result (or the exception that ended
it) into a pickle in the parent's run folder, where everything it leaves is removed with it.

How many runs go at once: api.simulate's ``check_workers``, else ``TRIBOFMU_CHECK_WORKERS``,
else the usable cores on Linux (elsewhere 1: macOS's system libraries are not safe to use in a
forked child, Windows has no fork), in the main thread only (1 in any other), and never more
than MAX_WORKERS. 1, or a platform without ``fork``: every run in this process, one after
another (:class:`InlineRuns`). What runs ahead follows the sequence's own expectations
(:meth:`tribofmu.checked.CheckSequence.then`), and a fork that fails runs that run here.
"""
from __future__ import annotations

import gc
import math
import os
import pickle
import select
import signal
import struct
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from .errors import ArgumentError, TriboFMUError
from .progress import STOP_SIGNALS, check_interrupt
from .run_folder import run_folder, share_with_forked_child

WORKERS_VARIABLE = "TRIBOFMU_CHECK_WORKERS"
# a sequence can use two runs at once (the one it waits for and its chain's next); a third
# would be a guess two decisions ahead
MAX_WORKERS = 2
# how often a waiting parent reads its children's pipes and a deferred Ctrl-C [s]: a tenth of
# the progress bar's redraw interval, so the bar and a stop feel immediate
POLL_S = 0.02
# how often once the wanted run closed its pipe (it is exiting) until it is reaped [s]: its
# result is ready, and a whole POLL_S would be added to the call's wall time
EXIT_POLL_S = 0.001
# a child tells its progress at most this often [s] (the bar redraws every 0.2 s)
PROGRESS_EVERY_S = 0.1
# one message's bytes: a pipe write below PIPE_BUF (4096 on Linux, 512 by POSIX) is atomic
MESSAGE_MAX = 512
_HEADER = struct.Struct("<I")


def check_workers(asked: int | None = None) -> int:
    """How many runs of a checked call go at once (see the module docstring)."""
    where = "check_workers"
    if asked is None:
        text = os.environ.get(WORKERS_VARIABLE, "").strip()
        if not text:
            asked = MAX_WORKERS if sys.platform.startswith("linux") else 1
        else:
            where = WORKERS_VARIABLE
            try:
                asked = int(text)
            except ValueError:
                raise ArgumentError(f"{WORKERS_VARIABLE}={text[:40]!r} must be a whole number >= 1") from None
    if isinstance(asked, bool) or not isinstance(asked, int) or asked < 1:
        raise ArgumentError(f"{where} must be a whole number >= 1, got {asked!r}")
    if not hasattr(os, "fork") or threading.current_thread() is not threading.main_thread():
        return 1  # (a fork copies only the calling thread: from another, a lock it held stays held)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(asked, cores, MAX_WORKERS))


def cpu_seconds() -> float:
    """CPU time [s] of this process and of its children that ended (stopped ones included;
    where there is no ``resource`` module, as on Windows, which forks none, this process's)."""
    own = time.process_time()
    try:
        import resource
    except ImportError:
        return own
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + children.ru_utime + children.ru_stime


class InlineRuns:
    """Every run in this process, one after another (one worker)."""

    workers = 1

    def __init__(self, run_once: Callable[..., Any], make_spool: Callable[[], Any]):
        self.run_once, self.make_spool = run_once, make_spool
        self.stopped = 0  # runs started and not asked for (none here)

    def take(self, step_tol: float, max_wall: float | None, then: float | None = None, here: bool = False):
        """The run at ``step_tol`` and its spool (then: ignored, nothing runs ahead; here: the
        call's first run, which vouches for itself, aims at the window: run_once's ``aim``)."""
        spool = self.make_spool()
        try:
            result = self.run_once(step_tol=step_tol, max_wall=max_wall, sink=spool, **({"aim": True} if here else {}))
        except BaseException:
            if spool is not None:
                spool.close()
            raise
        return result, spool

    def close(self) -> None:
        pass


@dataclass(eq=False)
class _Child:
    step_tol: float
    pid: int
    pipe: int  # read end of the child's messages
    result_path: Path
    spool: Any
    buffer: bytearray = field(default_factory=bytearray)
    progress: Any = None  # the last RunProgress told
    notices: list = field(default_factory=list)  # told while nobody waited for this run
    status: int | None = None  # the wait status, once it ended


class ForkedRuns:
    """Runs in forked children, ``workers`` at once (see the module docstring).

    progress and notice: the caller's callbacks, told the progress and notices of the run the
    sequence waits for."""

    def __init__(self, run_once: Callable[..., Any], make_spool: Callable[[], Any], workers: int,
                 progress: Callable[[Any], None] | None = None, notice: Callable[[str], None] | None = None,
                 prepare: Callable[[], None] | None = None):
        self.run_once, self.make_spool, self.workers = run_once, make_spool, workers
        self.progress, self.notice = progress, notice
        self.children: list[_Child] = []
        self.stopped = 0  # runs started ahead and not asked for
        self._folder = run_folder()
        # what every child would do first (unzip the FMUs): done once, here, before the first fork
        # (not before a first run in this process, which does it itself: a call whose one run
        # vouches forks nothing)
        self._prepare = prepare

    def take(self, step_tol: float, max_wall: float | None, then: float | None = None, here: bool = False):
        """The run at ``step_tol`` (started now, or already running) and its spool; while it runs,
        a free worker starts ``then``, the run the sequence asks for next if it goes on as a
        chain. Runs the sequence has passed by are stopped. here: the run at ``step_tol`` is
        most likely the last (one that vouches for itself): where nothing runs yet, it runs in
        this process and only ``then`` in a child (a fork for it would only cost), and aims at
        the window (run_once's ``aim``: coupling/lead_in.py)."""
        for child in [c for c in self.children if not _same(c.step_tol, step_tol) and not _same(c.step_tol, then)]:
            self._stop(child)
        if then is None and not self.children:  # nothing to run beside it: a fork would only cost
            return InlineRuns(self.run_once, self.make_spool).take(step_tol, max_wall, here=here)
        if here and then is not None and not self.children:
            return self._here_then_ahead(step_tol, then, max_wall)
        wanted = self._find(step_tol) or self._start(step_tol, max_wall)
        if wanted is None:  # no process to be had (fork failed): this one runs here, nothing ahead
            return InlineRuns(self.run_once, self.make_spool).take(step_tol, max_wall)
        if then is not None and self._find(then) is None and len(self.children) < self.workers:
            self._start(then, max_wall)
        if wanted.progress is not None and self.progress is not None:
            self.progress(wanted.progress)  # where it got to while nobody waited for it
        for text in wanted.notices:
            self._tell_notice(text)
        wanted.notices.clear()
        while wanted.status is None:
            self._poll(wanted)
        self.children.remove(wanted)
        return self._collect(wanted), wanted.spool

    def close(self) -> None:
        """Stop every run still going (the sequence ended, or was stopped)."""
        for child in list(self.children):
            self._stop(child)

    # -- the parent's side ---------------------------------------------------------------------
    def _find(self, step_tol: float | None) -> _Child | None:
        return next((c for c in self.children if _same(c.step_tol, step_tol)), None)

    def _here_then_ahead(self, step_tol: float, then: float, max_wall: float | None):
        """The run at step_tol in this process, and the one at ``then`` started in a child once
        this one has run PROGRESS_EVERY_S (its first progress report's interval) with more than
        half of it still to go: the run ahead can gain no more than what remains of this one,
        and a fork costs the parent its copied pages while the child lives and the kernel's
        teardown of them when it is stopped (Fig. 2's call, 0.12 s: 18 % more wall time with its
        run ahead started at once, 2026-11-27). Once the run here tightens its tolerance for its
        window (its progress says so: coupling/lead_in.py), it is planned to meet tol, and as for
        a pair so planned nothing runs ahead of it (CheckSequence.then): the run ahead is
        stopped, or never started. A run whose lead-in measures its window's reach (the window
        opens 2.5 drive periods or more after the start) starts the run ahead only once a mark
        finds that no tightening can meet the budget (RunProgress.window_reachable False), with
        more than half of it still to go: most such runs end the call, and a run ahead of one
        that does is CPU spent for nothing (Fig. 6's CLI call with two workers: CPU 1.90 -> 1.42
        s, its wall time the same, medians of 11 interleaved calls; boundary friction at gamma =
        1, two runs: CPU 6.9 -> 6.2 s, wall 5.2 -> 5.0 s, medians of 5; 2026-11-28)."""
        told = self.progress
        started = [False]
        self._prepare = None  # (the run here opens the FMUs, before the child is forked)

        def progress(report) -> None:
            if report.step_tol is not None and report.step_tol < step_tol:
                started[0] = True
                for child in list(self.children):
                    self._stop(child)
            due = (report.window_reachable is False) if report.aims_at_window \
                else report.wall_time >= PROGRESS_EVERY_S
            if not started[0] and due:
                started[0] = True  # (decided once)
                if report.fraction <= 0.5:
                    self._start(then, max_wall)
            if told is not None:
                told(report)

        spool = self.make_spool()
        try:
            result = self.run_once(step_tol=step_tol, max_wall=max_wall, sink=spool, progress=progress, aim=True)
        except BaseException:
            if spool is not None:
                spool.close()
            raise
        return result, spool

    def _start(self, step_tol: float, max_wall: float | None) -> _Child | None:
        """The run at step_tol started in a forked child (None: the fork failed, as when the
        user's process limit is reached; nothing is left behind)."""
        prepare, self._prepare = self._prepare, None
        if prepare is not None:
            prepare()
        spool = self.make_spool()
        result_path = self._folder / f"run-{os.getpid()}-{len(self.children)}-{time.monotonic_ns()}.pickle"
        read_end, write_end = os.pipe()
        parent = os.getpid()
        for stream in (sys.stdout, sys.stderr):  # nothing buffered here is written twice
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        # The child's garbage collector would touch every object the parent holds, and each page
        # it touches is copied: frozen, they are not collected there (the parent's take them
        # back at once). Fig. 2's call: 0.29 -> 0.19 s, 0.37 -> 0.23 s in a caller holding 2 million
        # objects (a forked run took 0.195 s where the same run in the call's process took 0.14).
        gc.freeze()
        pid = -1
        try:
            pid = os.fork()
        except OSError:
            for end in (read_end, write_end):
                os.close(end)
            if spool is not None:
                spool.close()
            return None
        finally:
            if pid != 0:
                gc.unfreeze()
        if pid == 0:  # the child: never returns
            os.close(read_end)
            _child_main(self.run_once, step_tol, max_wall, spool, write_end, result_path, parent)
        os.close(write_end)
        os.set_blocking(read_end, False)
        child = _Child(step_tol, pid, read_end, result_path, spool)
        self.children.append(child)
        return child

    def _poll(self, wanted: _Child) -> None:
        """Wait up to POLL_S for messages; read them, reap children that ended, and honour a
        deferred Ctrl-C (the progress bar's)."""
        pipes = [c.pipe for c in self.children if c.pipe >= 0]
        # (the wanted run's pipe at its end: the child is exiting, to be reaped within moments)
        wait = POLL_S if wanted.pipe >= 0 else EXIT_POLL_S
        readable = select.select(pipes, [], [], wait)[0] if pipes else time.sleep(wait) or []
        for child in list(self.children):
            if child.pipe in readable:
                self._read(child, wanted)
            if child.status is None:
                pid, status = os.waitpid(child.pid, os.WNOHANG)
                if pid:
                    child.status = status
                    self._read(child, wanted)  # what it said last
        check_interrupt()

    def _read(self, child: _Child, wanted: _Child) -> None:
        while child.pipe >= 0:
            try:
                data = os.read(child.pipe, 65536)
            except BlockingIOError:
                break
            if not data:  # the child closed its end
                os.close(child.pipe)
                child.pipe = -1
                break
            child.buffer += data
        while len(child.buffer) >= _HEADER.size:
            (size,) = _HEADER.unpack_from(child.buffer)
            if len(child.buffer) < _HEADER.size + size:
                break
            kind, value = pickle.loads(bytes(child.buffer[_HEADER.size:_HEADER.size + size]))
            del child.buffer[:_HEADER.size + size]
            if kind == "progress":
                child.progress = value
                if child is wanted and self.progress is not None:
                    self.progress(value)
            elif child is wanted:
                self._tell_notice(value)
            else:
                child.notices.append(value)

    def _tell_notice(self, text: str) -> None:
        if self.notice is not None:
            self.notice(text)

    def _collect(self, child: _Child):
        """The child's result, or its exception raised here."""
        try:
            with open(child.result_path, "rb") as fh:
                kind, value = pickle.load(fh)
        except (OSError, EOFError, pickle.UnpicklingError):
            why = (f"killed by signal {os.WTERMSIG(child.status)}" if os.WIFSIGNALED(child.status)
                   else f"exit status {os.waitstatus_to_exitcode(child.status)}")
            kind, value = "error", TriboFMUError(
                f"the run at per-step tolerance {child.step_tol:g} ended without a result ({why})")
        finally:
            self._forget(child)
        if kind == "error":
            raise value
        return value

    def _stop(self, child: _Child) -> None:
        """Kill (if it still runs) and reap a run not asked for; remove what it wrote."""
        if child.status is None:
            try:
                os.kill(child.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            child.status = os.waitpid(child.pid, 0)[1]
        self.stopped += 1  # (also one that had ended: its work was not asked for)
        if child.spool is not None:
            child.spool.close()
        self._forget(child)
        if child in self.children:
            self.children.remove(child)

    def _forget(self, child: _Child) -> None:
        if child.pipe >= 0:
            os.close(child.pipe)
            child.pipe = -1
        for path in (child.result_path, child.result_path.with_suffix(".partial")):
            try:
                os.unlink(path)
            except OSError:
                pass


def _same(a: float | None, b: float | None) -> bool:
    return a is not None and b is not None and math.isclose(a, b, rel_tol=1e-12)


# -- the child's side -------------------------------------------------------------------------
def _child_main(run_once, step_tol, max_wall, spool, write_end, result_path: Path, parent: int) -> None:
    """Run, write the outcome, and leave without running the parent's exit handlers (they
    would remove the parent's run folder and finalize FMUs the parent may hold)."""
    code = 0
    try:
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
        _die_with_parent(parent)
        share_with_forked_child()
        from .master.fmu_files import share_extractions_with_forked_child  # (the master, loaded by then)
        share_extractions_with_forked_child()
        teller = _Teller(write_end)
        try:
            result = run_once(step_tol=step_tol, max_wall=max_wall, sink=spool, progress=teller.progress,
                              notice=teller.notice)
            if spool is not None:
                spool.finish()
            outcome = ("result", result)
        except BaseException as exc:  # an FMU error, a bad state: the parent raises it
            outcome = ("error", exc)
        code = _write_outcome(outcome, result_path)
    except BaseException:
        code = 1
    finally:
        os._exit(code)


def _write_outcome(outcome, result_path: Path) -> int:
    partial = result_path.with_suffix(".partial")
    try:
        data = pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
        pickle.loads(data)  # what the parent will do: an exception may pickle and not come back
    except Exception as exc:  # an exception that does not pickle: its words do
        text = f"{type(outcome[1]).__name__}: {outcome[1]}" if outcome[0] == "error" else str(exc)
        data = pickle.dumps(("error", TriboFMUError(text)), protocol=pickle.HIGHEST_PROTOCOL)
    with open(partial, "wb") as fh:
        fh.write(data)
    os.replace(partial, result_path)  # the parent reads a whole pickle or none
    return 0


def _die_with_parent(parent: int) -> None:
    """Linux: SIGKILL this child when its parent dies (a parent killed by SIGKILL cannot stop it)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # it died before the line above
        os._exit(1)


class _Teller:
    """The child's progress and notice callbacks: small messages down the pipe, never blocking
    (a message that does not fit is dropped: the next progress tells more)."""

    def __init__(self, write_end: int):
        self.fd = write_end
        os.set_blocking(write_end, False)
        self.last = -math.inf

    def progress(self, status) -> None:
        now = time.monotonic()
        if now - self.last >= PROGRESS_EVERY_S or status.t >= status.stop_time:
            self.last = now
            self._send(("progress", status))

    def notice(self, text: str) -> None:
        self._send(("notice", str(text)[:300]))

    def _send(self, message) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        if len(data) + _HEADER.size > MESSAGE_MAX:
            return
        try:
            os.write(self.fd, _HEADER.pack(len(data)) + data)
        except (BlockingIOError, BrokenPipeError):
            pass
