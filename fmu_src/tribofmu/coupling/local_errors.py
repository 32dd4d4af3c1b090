"""One step's local errors, the formulas the embedded estimate (coupling/embedded.py) charges
and the carry (coupling/estimate.py) takes: pure functions of the step's two points, its length
and what the solve measured (the loop gain g, the block's velocity per impulse), each with its
derivation. Signs: true less computed.

- a ramped step's force curvature and its miss centred on the step (:func:`force_curvature`,
  :class:`RampStep`, :func:`centred_ramp_miss`), and the factor by which a slip on a falling
  force pushes an error on instead of pulling it back (:func:`unstable_loop_factor`);
- the error in x of a step into stick (:func:`stick_onset_x_error`), of a slip step in a stiff
  loop (:func:`stiff_x_error`), and of one that passed over a reversal (:func:`reversal_x_error`;
  both in :func:`slip_x_error`);
- how far a held step's end acceleration lags the motion's (:func:`held_slope_lag`), the slope
  of the results' dense output and of the grazing check's curve.
"""
from __future__ import annotations

from dataclasses import dataclass


def force_curvature(point, new, h: float, slope: float, h_prev: float) -> float:
    """F'' [N/s^2] from the force at the step's end (point new, after h [s]) against its
    linear extrapolation from point along the last step's chord slope [N/s] (of h_prev [s]):
    the divided difference of the two steps' chord slopes, F'' at
    (h - h_prev) / 4 past point, to first order."""
    return 2.0 * (new.F - (point.F + slope * h)) / (h * (h + h_prev))


@dataclass(frozen=True)
class RampStep:
    """An accepted slip step of h [s] whose force ramped (its start at t0_ns, its end at t_ns
    [ns], slipping in mode), with the curvature F'' [N/s^2] of :func:`force_curvature` from
    the step of h_prev [s] before it; v [m/s] is the local error in v charged from that
    curvature (-F'' h^3 / 12 through the loop), gain the loop's."""

    t0_ns: int
    t_ns: int
    mode: int
    h: float
    h_prev: float
    curvature: float
    v: float
    gain: float


def ramp_step(point, new, h: float, slope: float, h_prev: float, v: float, gain: float) -> RampStep:
    """The ramped step from point to new (see :class:`RampStep`; slope [N/s] the last step's)."""
    return RampStep(point.t_ns, new.t_ns, int(new.mode), h, h_prev, force_curvature(point, new, h, slope, h_prev),
                    v, gain)


def centred_ramp_miss(ramp: RampStep, following: RampStep) -> float:
    """The local error in v [m/s] of the ramped step ramp, charged from its force's curvature
    at the step's middle rather than near its start, once the step following it (in the same
    slip) has given the curvature near its own start.

    A ramped step misses the trapezoid's error, -F'' h^3 / 12, with F'' at the step's middle;
    :func:`force_curvature` has F'' at (h - h_prev) / 4 past the step's start, a lag of about
    h / 4 along the curve of F. Where F'' changes fast (a Stribeck drop: the force bends away
    from the static level ever more steeply, then straightens into the kinetic one) the lag
    under-reads the steps where |F''| grows and over-reads those where it falls, and the
    first grow through the falling branch, the second less. Interpolated linearly to the
    middle, between ramp's F'' and following's (at (h_next - h) / 4 past ramp's end), the
    charge is centred, to the next order. That correction is taken at most as large as the
    charge it corrects: beyond, the curve turns within the step (a step across the knee of a
    narrow drop, whose successor's F'' is a hundredfold), outside the expansion both terms
    come from. Measured (mixed friction, delta = 3, omega = 12, per-step tol 1e-4): along a
    drop the charged steps read 0.4-0.8x their true local error at its start, 1.2-1.8x at its
    end, and the run's estimate 0.64x its true error."""
    h, hp, hn = ramp.h, ramp.h_prev, following.h
    if ramp.curvature == 0.0:
        return ramp.v
    weight = (h + hp) / (2.0 * h + hn + hp)  # the middle's place between the two curvatures' points
    change = weight * (following.curvature - ramp.curvature) / ramp.curvature  # (the charge is linear in F'')
    return ramp.v * (1.0 + max(-1.0, min(1.0, change)))


def unstable_loop_factor(damping: float, h: float, ramped: bool, gain: float) -> float:
    """What a slip step's local errors, filtered by 1 / (1 + gain) as a stiff loop pulls an
    error back (gain [1] the loop's, the size of the friction's slope), are to be multiplied
    by where that slope is negative (damping c [1/s] < 0, the chord's: a Stribeck drop):
    the step's end force then pushes an error on instead, δ (1 + g) = the open loop's error
    with g = c h (held) or c h / 2 (ramped: the block's share of the end force) negative.
    Taken as at most 2 (g >= -1/3): past it the correction outgrows the charge it corrects and
    the loop's linearisation about its root no longer holds (factor 1 where c >= 0)."""
    if damping >= 0.0:
        return 1.0
    signed = max(damping * h * (0.5 if ramped else 1.0), -1.0 / 3.0)
    return min((1.0 + gain) / (1.0 + signed), 2.0)


def stick_onset_x_error(start, end, h: float, velocity_per_impulse: float, w2: float) -> float:
    """The error in x [m] (true less computed) of the step of h [s] from a slipping point start
    to a point end stuck at the fraction end.event of it, which the coupling solves with one
    force held all through, the one that brings v to V at the end (so its mean is the true
    force's mean). Against the true force, the friction's F0 until the onset and then the
    stick force, rising at r = M (aX' + w2 V) (M a + 2K x with a = aX, x' = V), the held
    force misses x by dF e h^2 / (2M) (the jump dF to the stick force at the fraction e) and
    by r ((1 - e) h)^3 / (12 M) (the stick force's ramp over the stuck part). (The step's own
    error term, dF h^2 / (3M) whatever e, is the bound the step control needs; carried, it
    made Fig. 2's x error 50x the true one, and a dry drive at omega = 3 7x its true error.)"""
    if velocity_per_impulse <= 0.0 or h <= 0.0:
        return 0.0
    mass = 1.0 / velocity_per_impulse
    e = min(max(end.event, 0.0), 1.0)
    jump = end.F - start.F
    rate = mass * ((end.aX - start.aX) / h + w2 * 0.5 * (start.V + end.V))
    return -(jump * e * h * h / 2.0 + rate * ((1.0 - e) * h) ** 3 / 12.0) / mass


def stiff_x_error(v: float, h: float, gain: float, ramped: bool) -> float:
    """The slip step's local error in x [m] from its error in v [m/s] (already filtered by
    1 / (1 + gain)) over a step of h [s] at loop gain g = gain.

    The loop pulls the end velocity's error back (v = v0 / (1 + g), v0 the open loop's), but
    not the position's: within the step the block felt the held force (or the ramp) where the
    true force moved, and its velocity strays from the true one in between even where the ends
    agree. With the friction's slope s and the block's velocity per impulse b (g = s b h held,
    s b h / 2 ramped), the true force F0 + F' u (held) or with F'' u^2 / 2 (ramped), and the
    end force where the loop puts it (the true one less s times the end's error), the double
    integral of the force's miss gives, true less computed:
    - held: x = -b F' h^3 (4 + g) / (12 (1 + g)) = v h (4 + g) / 6;
    - ramped: x = -b F'' h^4 (3 + g) / (72 (1 + g)) = v h (3 + g) / 6.
    At g = 0 these are the open loop's 2 h v / 3 and h v / 2; in a stiff loop the x error stays
    b F' h^3 / 12 (held) while v's vanishes. (Filtered as v, a pseudoplastic fluid's quasi-stuck
    held steps grew to the longest step: at gamma = -0.9 each added 1e-2 of the drive's
    amplitude to x, which moved the next breakaway, 3e-2 nRMS(v) at per-step tol 1e-3.)"""
    return v * h * ((3.0 if ramped else 4.0) + gain) / 6.0


def reversal_x_error(start, end, h: float, gain: float, velocity_per_impulse: float, course: float) -> float:
    """The x error [m] (true less computed) of a step of h [s] from point start to point end
    that slips the same way at both ends but ends where the force that keeps the block on the
    drive, F_a = end.F + M (aX - a), is one the friction cannot give in that direction: the
    relative velocity reached 0 inside the step and the force reversed there (a shear-thinning
    fluid's force all but jumps at dv = 0: an event the step passed over).

    The event is located by the impulse: a stiff loop (gain g) pins the end's velocity, so the
    force the block felt (held at F1 = end.F, or ramped from F0 = start.F) has the mean of the
    true one, the force's smooth course F0 + s u (s = course [N/s], its slope over the last step
    of this slip) with a jump dF = F_a - F0 - s h at the reversal; the reversal is at the
    fraction 1 - q of the step with q = (F1 - F0 - s h / 2) / dF held, (F1 - F0 - s h) / (2 dF)
    ramped. The two forces' paths then move x apart by b dF h^2 q (1 - q) / 2 held,
    b dF h^2 q (2 - 3 q) / 6 ramped (b = velocity_per_impulse), weighed by g / (1 + g): how far
    the loop pins the end on the drive, where F_a is the true force. (At gamma = -0.95,
    omega = 80, per-step tol 1e-2, reversals passed over inside 1.75 and 3.9 ms steps moved x
    by 4.1e-3 and 7.7e-3 of the drive's amplitude where the steps' linear force read 1.1e-3
    and 1.0e-3. Without the course, a Newtonian fluid's stiff steps at a crossing read the
    course itself as a jump: 1.9x its carried error at m = 200 N s/m.)"""
    b = velocity_per_impulse
    if not (end.mode.slipping and start.mode == end.mode) or b <= 0.0:
        return 0.0
    needed = end.F + (end.aX - end.a) / b
    jump = needed - start.F - course * h
    if needed * end.mode.direction >= 0.0 or jump == 0.0:
        return 0.0
    felt = end.F - start.F - (course * h if end.ramped else 0.5 * course * h)  # the mean's excess, x2 ramped
    q = min(max(felt / (2.0 * jump if end.ramped else jump), 0.0), 1.0)
    shape = q * (2.0 - 3.0 * q) / 6.0 if end.ramped else q * (1.0 - q) / 2.0
    return -b * jump * h * h * shape * gain / (1.0 + gain)


def slip_x_error(start, end, v: float, h: float, gain: float, velocity_per_impulse: float, course: float,
                 ramped: bool) -> float:
    """The slip step's local error in x [m]: its force's smooth miss (:func:`stiff_x_error`,
    from v [m/s], charged as ramped or held) or a reversal it passed over
    (:func:`reversal_x_error`), the larger."""
    x = stiff_x_error(v, h, gain, ramped)
    reversal = reversal_x_error(start, end, h, gain, velocity_per_impulse, course)
    return reversal if abs(reversal) > abs(x) else x


def held_slope_lag(start, end, h: float, gain: float) -> float:
    """How far [m/s^2] the motion's acceleration at the end of a held slip step of h [s] (from
    point start to point end, slipping the same way at both or breaking away at its start) lies
    beyond the block's own, end.a: what the results' dense output adds to the end's slope
    (``Point.a_lag``, interpolation.py).

    A held step's end force F1 is not the true end force F(t1): with the friction's slope s and
    the block's velocity per impulse b (gain g = s b h), the end velocity's error b h (F1 - mean)
    moves the force by -g (F1 - mean), so F1 = w mean + (1 - w) F(t1), w = g / (1 + g): an open
    loop (w = 0) ends at the true force, a stiff one (w = 1) at the step's mean, and the block's
    end acceleration a lags the motion's by w b (F(t1) - mean). Where the loop is stiff the block
    follows the drive, its relative velocity creeping: the motion's acceleration is the drive's
    less the creep's rate, aX - (dv1 - dv0) / h, off by dv'' h / 2 only (dv tiny and smooth).
    The slope is a moved that way by w, so that it is exact at both ends of the range of w
    (between them off by w (1 - w) b |F(t1) - mean|, 1 - w of the unmoved slope's miss).
    (With a alone, a shear-thinning fluid creeping at |dv| ~ 4e-7 m/s (gamma = -0.863,
    omega = 16.37, tol 1e-4: bench_trust.py --random 2617:12, r2617.5) had its samples 5e-4 of
    max |v| off between points 1e-7 off, and read 0.17x its true error; its held ends' slopes
    were 0.04 m/s^2 off (RMS), with the lag of a force linear in time 1.6e-3, with this 3.9e-6.)
    0 for a ramped step, whose end force is the true one, or one that does not end in the slip
    it began in or broke away into."""
    if end.ramped or h <= 0.0 or not end.mode.slipping or not (start.mode == end.mode or start.mode.stuck):
        return 0.0
    creep_rate = ((end.V - end.v) - (start.V - start.v)) / h
    return gain / (1.0 + gain) * (end.aX - creep_rate - end.a)
