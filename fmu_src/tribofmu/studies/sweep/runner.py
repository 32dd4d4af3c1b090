"""Where a sweep's points run: a plain loop in this process, or a Dask cluster.

On Dask, ``workers=None`` starts a ``distributed.LocalCluster`` with one single-threaded
worker process per core (pythonfmu FMUs hold the GIL), ``workers=N`` N of them, and
``scheduler="tcp://host:8786"`` uses an existing cluster, whose workers need tribofmu
installed but not the client's disk: the FMUs travel through Dask (:mod:`.worker`).
The points most expected to be long are submitted first, with the highest priority
(:func:`expected_cost`), so that one slow point does not run alone at the end while the
other workers idle.
"""
from __future__ import annotations

import contextlib
import hashlib
import logging
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

from ...errors import SweepError
from ...master.unzipped import NoUnzippedFMUsOnSysPath
from ...scene.scenario import Scenario
from .worker import STATUS_FAILED, STATUS_OK, pack_fmus, run_point, run_shipped_point

WORKER_START_TIMEOUT = 120.0  # s
SCHEDULER_TIMEOUT = 10.0  # s: an unreachable --scheduler is reported after this
Record = Callable[[int, dict], None]  # (point index, run_point's outcome)


def expected_cost(scenario: Scenario, algorithm: str | None, step: float | None, tol: float | None) -> float:
    """A point's expected run time, in arbitrary units: only the order of points matters.

    Fixed-step coupling: the number of steps. Adaptive: the steps follow the fastest motion
    (the drive or the block's natural frequency) over the span, more for tighter tolerances
    (cost ~ tol^-1/2); a power-law fluid near gamma = -1 is stiffer at dv = 0 (~1/(1+gamma)),
    the boundary lubricant much stiffer. On Fig. 4's omega sweep this gives omega = 10 45 %
    of the work; measured: 46 %.
    """
    sim = scenario.simulation
    span = scenario.stop_time
    if (algorithm or sim.algorithm) != "adaptive":
        return span / (step if step is not None else (sim.step or 1e-4))
    b = scenario.block
    fastest = max(scenario.drive.omega, math.sqrt(2.0 * b.K / b.M))  # rad/s
    tol = tol if tol is not None else (sim.tol or 1e-3)
    cost = span * fastest * math.sqrt(1e-3 / tol)
    if "Friction" in scenario.fmus:
        law = scenario.friction.law()
        if "gamma" in law.keys:
            cost /= max(1.0 + scenario.friction.gamma, 1e-3)
        if law.has_state:
            cost *= 100.0
    return cost


def longest_first(scenarios: list[Scenario], todo: list[int], algorithm, step, tol) -> list[int]:
    """``todo`` (point indices) ordered by decreasing expected cost; ties keep grid order."""
    return sorted(todo, key=lambda i: -expected_cost(scenarios[i], algorithm, step, tol))


@contextlib.contextmanager
def _recording(record: Record, total: int, enabled: bool, desc: str):
    """``record`` that also advances a progress bar counting the failed points."""
    from tqdm import tqdm
    failed = 0
    with tqdm(total=total, unit="point", desc=desc, disable=not enabled, file=sys.stderr,
              dynamic_ncols=True) as bar:
        def done(i: int, out: dict) -> None:
            nonlocal failed
            record(i, out)
            failed += out["status"] != STATUS_OK
            bar.set_postfix(failed=failed, refresh=False)
            bar.update()
        yield done


def run_plain(scenarios: list[Scenario], todo: list[int], fmu_dir: Path, settings: tuple, record: Record,
              progress: bool, desc: str) -> None:
    """Run the points one after the other in this process, in grid order."""
    with _recording(record, len(todo), progress, desc) as done:
        for i in todo:
            done(i, run_point(scenarios[i], str(fmu_dir), *settings))


def run_dask(scenarios: list[Scenario], todo: list[int], fmu_dir: Path, settings: tuple, record: Record,
             progress: bool, desc: str, scheduler: str | None, workers: int | None, log,
             worker_log: Path | None = None) -> None:
    """Run the points on Dask, longest expected first; record each as it finishes.

    settings: (algorithm, step, tol, portrait_points, timeout), as :func:`run_point` takes them.
    worker_log: where a local cluster's workers and Dask's own messages go (default: a file
    in the temp folder); removed at the end when empty.
    """
    from distributed import Client, LocalCluster, as_completed

    cluster = client = None
    worker_log = Path(worker_log) if worker_log else Path(tempfile.gettempdir()) / f"tribofmu-dask-{os.getpid()}.log"
    with contextlib.suppress(OSError):
        worker_log.unlink()  # this run's messages only
    dask_messages = _dask_logs_to(worker_log)
    # Spawned workers inherit sys.path: an FMU loaded earlier in this process would leave its
    # trimmed tribofmu there, shadowing the installed package in the workers.
    clean = NoUnzippedFMUsOnSysPath().__enter__()
    children_stderr = _ChildrenStderr(worker_log if not scheduler else None)
    from distributed.deploy.spec import SpecCluster
    clusters_before = set(getattr(SpecCluster, "_instances", ()))
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT:g}s")
            except (OSError, TimeoutError, ValueError, TypeError) as exc:
                raise SweepError(f"--scheduler {scheduler}: cannot connect within {SCHEDULER_TIMEOUT:g} s "
                                 f"({' '.join(str(exc).split())[:120]})") from None
        else:
            n = workers or cores()
            n = max(1, min(n, len(todo)))
            log(f"starting a local Dask cluster: {n} worker process{'es' if n > 1 else ''}, 1 thread each")
            # everything on the loopback interface: no port (scheduler, dashboard) open to the network
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address="127.0.0.1:0",  # no clash on :8787
                                   silence_logs=logging.ERROR)
            client = Client(cluster)
            try:  # a worker that cannot start (import error) would otherwise leave us waiting forever
                client.wait_for_workers(n, timeout=WORKER_START_TIMEOUT)
            except TimeoutError:
                client.close()
                cluster.close()
                raise SweepError(f"the local Dask cluster's {n} workers did not start within "
                                 f"{WORKER_START_TIMEOUT:g} s (their output: {worker_log})") from None
    except BaseException:
        # interrupted while the cluster started, or it could not: shut down what is up,
        # a further Ctrl-C meanwhile only requested (no half-closed cluster at exit)
        with _interrupts_held():
            with contextlib.suppress(Exception):
                if client is not None:
                    client.close()
            # a cluster interrupted in its constructor is not ours yet, but Dask knows it
            started = set(getattr(SpecCluster, "_instances", ())) - clusters_before
            for each in ([cluster] if cluster is not None else []) + [c for c in started if c is not cluster]:
                with contextlib.suppress(Exception):
                    each.close()
            clean.__exit__(None, None, None)
            dask_messages.close()
            children_stderr.close()
        raise
    futures = {}
    try:
        needed = sorted({name for i in todo for name in scenarios[i].fmus})
        # One copy of the FMUs' bytes per worker, held by Dask, instead of a shared path.
        [fmus] = client.scatter([pack_fmus(fmu_dir, needed)], broadcast=True, hash=False)
        token = hashlib.sha1(f"{time.time()}{os.getpid()}".encode()).hexdigest()[:8]
        order = longest_first(scenarios, todo, *settings[:3])
        for rank, i in enumerate(order):
            fut = client.submit(run_shipped_point, scenarios[i], fmus, *settings,
                                key=f"tribofmu-point-{i}-{token}", pure=False, retries=0,
                                priority=len(order) - rank)
            futures[fut] = i
        with _recording(record, len(todo), progress, desc) as done:
            for fut in as_completed(futures):
                try:
                    out = fut.result()
                except Exception as exc:  # the worker died, the task could not be run
                    out = {"status": STATUS_FAILED, "message": " ".join(f"{type(exc).__name__}: {exc}".split()),
                           "metrics": {}, "wall_time": math.nan}
                done(futures[fut], out)
                fut.release()
    finally:
        with _interrupts_held():  # closing the cluster is not cut short by a second Ctrl-C
            for fut in futures:
                if not fut.done():
                    fut.cancel()
            client.close()
            if cluster is not None:
                cluster.close()
            clean.__exit__(None, None, None)
            dask_messages.close()
            children_stderr.close()


class _dask_logs_to:
    """Dask's log messages in this process (the scheduler's, the nannies') go to ``path``
    instead of stderr until :meth:`close`, which removes the file if nothing was written:
    when the terminal's Ctrl-C stops the workers before this process closes the cluster, the
    scheduler logs lost workers and data, which say nothing the one line does not."""

    def __init__(self, path: Path):
        self.path, self.logger = path, logging.getLogger("distributed")
        self.saved = list(self.logger.handlers)
        try:
            self.handler = logging.FileHandler(path, delay=True)
        except OSError:
            self.handler = None
            return
        self.handler.setFormatter(logging.Formatter("%(asctime)s - %(name)s - %(levelname)s - %(message)s"))
        self.logger.handlers = [self.handler]

    def close(self) -> None:
        if self.handler is None:
            return
        self.logger.handlers = self.saved
        self.handler.close()
        self.handler = None
        with contextlib.suppress(OSError):
            if self.path.stat().st_size == 0:
                self.path.unlink()


class _ChildrenStderr:
    """Until :meth:`close`, the processes this one starts (a local cluster's workers) write
    their stderr to ``path``, while this process's own messages (sys.stderr: the progress
    bar, the lines of the sweep) still reach the terminal: file descriptor 2 is ``path``
    and sys.stderr a copy of the original one. A Ctrl-C at the terminal signals the whole
    process group, and each worker would print its KeyboardInterrupt traceback under the
    one line that says what happened; this process shuts the cluster down itself, and the
    workers' output stays in ``path`` (removed when empty). path None: nothing changes."""

    def __init__(self, path: Path | None):
        self.saved = self.stream = None
        if path is None:
            return
        sys.stderr.flush()
        try:
            target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_CLOEXEC, 0o644)
        except OSError:
            return
        self.original, self.saved = sys.stderr, os.dup(2)
        os.set_inheritable(self.saved, False)
        self.stream = open(self.saved, "w", buffering=1, encoding=getattr(self.original, "encoding", None)
                           or "utf-8", errors="backslashreplace", closefd=False)
        os.dup2(target, 2)
        os.close(target)
        sys.stderr = self.stream

    def close(self) -> None:
        if self.saved is None:
            return
        with contextlib.suppress(Exception):
            self.stream.flush()
        os.dup2(self.saved, 2)
        os.close(self.saved)
        if sys.stderr is self.stream:
            sys.stderr = self.original
        self.saved = self.stream = None


@contextlib.contextmanager
def _interrupts_held():
    """Inside, Ctrl-C and SIGTERM are held (blocked) in this thread and taken afterwards."""
    import signal
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1
