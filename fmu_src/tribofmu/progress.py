"""A progress bar on stderr for long runs: simulated time, steps and rejected steps.

Quiet when stderr is not a terminal (logs, pipes, tests) or when asked to be.
"""
from __future__ import annotations

import sys
import time


class RunBar:
    """A callback for ``api.simulate(progress=...)``; use as a context manager.

    The bar counts simulated seconds; its text shows accepted steps and rejected
    (rolled-back) steps. Redraws at most every 0.2 s, so a run of 10^5 steps pays nothing.
    """

    def __init__(self, desc: str, stop_time: float, enabled: bool | None = None, interval: float = 0.2):
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.interval = interval
        self._last = 0.0
        self._bar = None
        if self.enabled:
            from tqdm import tqdm
            self._bar = tqdm(total=stop_time, desc=desc, unit="s", file=sys.stderr, leave=False,
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} s "
                                        "[{elapsed}<{remaining}] {postfix}")

    def __call__(self, status) -> None:
        if self._bar is None:
            return
        now = time.perf_counter()
        if now - self._last < self.interval and status.t < status.stop_time:
            return
        self._last = now
        self._bar.n = min(status.t, status.stop_time)
        self._bar.set_postfix_str(f"{status.steps} steps, {status.rejected} rejected", refresh=False)
        self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> "RunBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
