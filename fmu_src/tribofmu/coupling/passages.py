"""Passages near a runaway that a run did not take: where a linearised carry cannot vouch.

The lubricant and the block form a loop: f rising softens the film (its modulus mu - mub f
falls), the block slips faster, dv grows and drives f up again. The carry's variational
equations (coupling/estimate.py) hold that loop as the block of their matrix acting on (ev, ef),

    J = [[-c, p], [q, r]],

and where p q outweighs c (-r) the loop is unstable: its larger eigenvalue (:func:`loop_growth`)
is positive, and an error grows. Where the run goes on to melt, the growth is the melt's
timing, which the carry follows. Where the run turns back instead (the loop stable again, the
film still solid), it passed near a runaway it did not take: a state a little further up in f
would have melted, and the whole rest of the run would differ by the size of the motion.
Which way that passage goes is decided by how far the run's f came into the unstable region
against its own error there, which the linearisation does not measure: the carry, grown and
then decayed again along the run as computed, reads 1e-3 to 1e-2 of the true error of a
run that turned back where the exact motion melted (hot dilatant films, ``bench_trust.py
--extra``: true 0.12 and 0.47 of max|v|, reported 4e-3, at per-step tolerances 1e-2 to 1e-4).

So each such passage that turns back is measured: the rise of f while the loop was unstable
(from where it turned unstable to its highest), against the largest carried error of f in
it times the margin every estimate is given (CheckSettings.estimate_safety). Where that
error reaches the rise, the run's own error could have carried it over (:attr:`ratio` >= 1):
the run cannot vouch, and a call does not end on it (checked.py). Measured over the trust
points' boundary runs (Fig. 6's rig, other gamma, omega, n, T, A, M, K; per-step 1e-2 to
1e-4, ``bench_trust.py --one-run``, 2026-11-27): every melting rig turns back once near its
first melt, with a growth of e^4.0-4.6 there, and the ratio falls with the tolerance (0.53-2.5
at per-step 1e-2, 0.50-0.75 at 3e-3, 0.20-0.50 at 1e-3, at most 0.12 at 3e-4), all of those runs
on the exact motion's side; the two hot films' runs that turned back where the exact motion
melted read 1.5-3.5 and 1.3-4.9 (per-step 1e-2 to 3e-4, and 1e-4). A passage in which f did
not rise (the film re-solidifying, its loop briefly unstable as its modulus returns) is no
approach to a melt.

Standard library only: this module ships in the TriboPair FMU.
"""
from __future__ import annotations

import math


def loop_growth(c: float, p: float, q: float, r: float) -> float:
    """The larger real part [1/s] of the eigenvalues of J = [[-c, p], [q, r]], the (ev, ef)
    block of the variational equations (coupling/estimate.py state_slopes)."""
    half_trace, det = 0.5 * (r - c), -c * r - p * q
    disc = half_trace * half_trace - det
    return half_trace + math.sqrt(disc) if disc > 0.0 else half_trace


def undecided(ratio: float | None) -> bool:
    """Whether a run whose closest passage near a melt read ``ratio`` (:attr:`NearRunaways.ratio`;
    None: no law with such a state) turned back within its own error of the rise (ratio >= 1)."""
    return ratio is not None and ratio >= 1.0


class NearRunaways:
    """The passages of a run through an unstable loop that turned back (module docstring).

    law: the friction law with a state that melts (its ``melt_margin``); safety [1] the margin
    the carried error is given (CheckSettings.estimate_safety)."""

    def __init__(self, law, safety: float):
        self.law, self.safety = law, safety
        self.margin_start = None  # melt margin [1] where the loop turned unstable (None: stable)
        self.margin_low = 0.0  # the lowest melt margin in the passage so far [1]
        self.error = 0.0  # the largest |carried error of f| in it [1]
        # the largest safety x error / rise over the passages that turned back (>= 1: undecided)
        self.ratio = 0.0

    def step(self, slopes: tuple[float, float, float, float] | None, f_start: float, f_end: float,
             ef: float) -> None:
        """Follow an accepted step from f_start to f_end [1] with the carry's slopes (c, p, q, r)
        over it (None: no slip step of a law with state) and the carried error ef [1] at its
        end."""
        margin = self.law.melt_margin(f_end)
        if margin <= 0.0:  # melted: the runaway was taken, and the carry follows its timing
            self.margin_start = None
            return
        if slopes is not None and loop_growth(*slopes) > 0.0:
            if self.margin_start is None:
                self.margin_start, self.margin_low, self.error = self.law.melt_margin(f_start), margin, 0.0
            self.margin_low = min(self.margin_low, margin)
            self.error = max(self.error, abs(ef))
            return
        if self.margin_start is not None:  # turned back, still solid
            rise = self.margin_start - self.margin_low
            if rise > 0.0:
                self.ratio = max(self.ratio, self.safety * self.error / rise)
            self.margin_start = None

    def export(self) -> list:
        """What a state snapshot carries of it (JSON-ready): a passage under way and the worst so far."""
        return [self.margin_start, self.margin_low, self.error, self.ratio]

    def restore(self, values: list) -> None:
        """Back to what :meth:`export` gave."""
        self.margin_start, self.margin_low, self.error, self.ratio = values

    @property
    def undecided(self) -> bool:
        """A passage turned back within the run's own error of its rise (:func:`undecided`)."""
        return undecided(self.ratio)
