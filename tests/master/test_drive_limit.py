"""The drive's own interpolation bounds a step in every contact mode (issue 36 item 3: how well
the drive is interpolated is a limit on the step, not a share of its period): stuck, against the
block's motion (v and x ride on the drive); slipping, the drive's V and X the results carry,
against the scene's scales. The largest step, one drive period, is a Limit the method does not
reach."""
from __future__ import annotations

import math

import pytest

from tribofmu.coupling.embedded import EmbeddedCoupling
from tribofmu.coupling.interpolation import HERMITE_ERROR_DIVISOR
from tribofmu.coupling.settings import LIMITS
from tribofmu.coupling.system import Contact, Point

from fakes import drive_scales, fig2_system

OMEGA, A = 30.0, 2e-3


def prepared(tol: float = 1e-3) -> EmbeddedCoupling:
    algorithm = EmbeddedCoupling(step=1e-4, tol=tol)
    algorithm.prepare(fig2_system(omega=OMEGA, A=A), drive_scales(OMEGA, A))
    return algorithm


def drive_point(mode: Contact, phase: float) -> Point:
    """The drive X = A cos(w t) at w t = phase, the block at rest beside it."""
    return Point(0, X=A * math.cos(phase), V=-A * OMEGA * math.sin(phase), aX=-A * OMEGA ** 2 * math.cos(phase),
                 mode=mode)


def test_a_slip_step_is_bounded_by_the_drives_interpolation_against_the_scenes_scales():
    algorithm = prepared()
    point = drive_point(Contact.FORWARD, 1.0)
    w2 = OMEGA ** 2
    room = algorithm.controller.safety ** 4 * HERMITE_ERROR_DIVISOR * algorithm.tol / (w2 * w2)
    expected = min((room * A * OMEGA / abs(point.V)) ** 0.25, (room * w2 * A / abs(point.aX)) ** 0.25)
    # (before the block's w2 is known, the drive's bound is the only one; a slipping step had none)
    assert algorithm.estimate.w2 == 0.0
    assert algorithm.interpolation_limit(point) == pytest.approx(expected, rel=1e-12)


def test_stuck_the_drives_bound_is_held_to_the_blocks_own_motion():
    algorithm = prepared()
    stuck, slipping = drive_point(Contact.STUCK, 1.0), drive_point(Contact.FORWARD, 1.0)
    # the block's motion so far is far below the scene's scales (at rest: their floor), so its
    # v and x, riding on the drive, are held tighter than the drive's own signals
    assert algorithm.drive_interpolation_limit(stuck) < algorithm.drive_interpolation_limit(slipping)


def test_the_largest_step_is_a_whole_period_a_limit():
    algorithm = prepared()
    period_ns = 2.0 * math.pi / OMEGA * 1e9
    assert LIMITS.max_step_periods == 1.0
    assert abs(algorithm.max_ns - period_ns) <= algorithm.step_granularity
