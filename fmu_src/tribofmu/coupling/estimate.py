"""A run's own accuracy: the steps' local error estimates carried to a global error in v.

Step doubling tells how wrong each accepted step is (its local error); what a user sees is
the global error, the local errors of all earlier steps carried forward by the motion. The
block is a mass on springs under a friction force that depends on the relative velocity,
so an error (ex [m], ev [m/s]) in its state moves, to first order, as

    ex' = ev,    ev' = -w2 ex - c ev,

w2 = 2K/M [1/s^2] (the springs over the mass) and c = (dF/d(dv)) / M [1/s] (the friction's
slope over the mass: the damping the friction adds to an error). The coupling knows neither
K nor M; it measures both from the block's own answers (its velocity per unit impulse, its
acceleration against its position) and c from each slip step. A stuck contact holds v = V
exactly: no error in v while stuck, and x rides on the drive's X, so its error stays what it
was when the contact stuck (the stick force takes up the spring's pull). Events (breakaway,
stick onset, a lubricant that re-solidifies inside a step) enter through the local errors of
the steps that hold them; the step into a stick through the x error of its held force
(:func:`.local_errors.stick_onset_x_error`).

A friction with an internal state (the lubricant's excess volume f [1], eq. 21: df/dt = g(dv,
f)) adds the state's error ef, and the three move by the variational equations of the block and
the lubricant (F the force, M the block's mass, dv = V - v moving by -ev):

    ex' = ev,    ev' = -w2 ex - (F_dv/M) ev + (F_f/M) ef,    ef' = -g_dv ev + g_f ef,

F_dv = dF/d(dv), F_f = dF/df, g_dv = dg/d(dv), g_f = dg/df: the law's own slopes
(:meth:`~tribofmu.physics.friction.FrictionLaw.state_jacobian`; the coupling is given the law
with the system, ``CoupledSystem(law=...)``). A slip step carries them along the path the
lubricant's sub-steps take (:func:`.variational.step_transition`: the step's own map, f1 and
F_mean against f0, dv0 and dv1, with the block's exact response to its mean force); taken
at the step's middle instead (:meth:`GlobalErrorEstimate.state_slopes`, :func:`state_flow`,
still the carry where the law gives no step map), the carry lost part of an error at each
melt and re-solidification (0.35x after two periods at a rig whose errors persist, 0.02x after
three at a cold film; 0.96-1.0x and 0.35x so: bench_carry_sensitivity.py, 2026-11-28). F, g
continuous in (dv, f) (the floored modulus is a kink): no saltation jump to first order. No
local error of f is charged (its miss moves the force, which the local errors in v charge).
Without the law (a Friction FMU of unknown make), the block's 2x2 carry alone.

c may be negative: a Stribeck law's force falls as the slip grows from rest, and an error
grows while it slips there. The slip solve measures only the size of the slope (its loop
gain); where the force is a function of dv alone (no internal state, no changing inputs),
:func:`chord_damping` takes the slope, sign and all, from the chord between the step's ends.
There the local errors the carry grows are charged as the drop makes them: a slip step's
through the loop that pushes an error on (:func:`.local_errors.unstable_loop_factor`), a ramped
step's from its force's curvature at the step's middle (:func:`.local_errors.centred_ramp_miss`).

:class:`.window_error.WindowError` turns the carried error into the measure --tol bounds (docs/coupling.md): the RMS of
the error in v over the scene's shown window, divided by the largest |v| there. Results
between communication points are cubic Hermite interpolants (coupling/interpolation.py), which
miss the motion by v''''/24 s^2 (h - s)^2 inside a step of h: no state error (0 at the points,
nothing carries it), but where steps are long (a dry slip, a contact stuck on the drive) the
larger part of what the user sees.

Measured (``benchmarks/bench_trust.py --one-run``, default tol, 2026-11-27): estimate / true
error on Fig. 2 0.28 -> 0.78, a dry drive at omega = 3 6.1 -> 0.94, mixed friction at
delta = 1 0.007 -> 0.88, boundary friction stuck all through 0 -> 1.0; a shear-thinning fluid
at gamma = -0.9 65 (saturated) -> 0.74, at gamma = -0.7, M = 0.2 0.19 -> 0.81 (tol 1e-3);
mixed friction at delta = 3, omega = 12 0.54 -> 0.97 (1e-3; 0.54 -> 1.03 at tol 1e-2).
Boundary friction (``--only boundary`` and ``--only fig6`` at tols default, 1e-2, 1e-4, 27 runs):
the state's calibrated impulse read 0.33-232x (2026-11-27 09:00 UTC); the law's slopes at the
step's middle, each slip step charged from its own path (coupling/path_error.py), 0.46-2.1
(13:55 UTC); the step's own map 0.74-2.0, ``--extra``'s drifting rig 0.67-0.80 and cold film
0.52-1.16 (0.27, 0.19-0.33 before; its kinetics at 1e-6, 2026-11-28 01:26 UTC; at 1e-5 the cold
film read 0.25-0.48). That difference was the sub-steps across the melt threshold, whose mean
force's dv entries the tangent had 5-48 % off (median) wherever one sub-step spanned the kink;
followed in two parts that meet there, 0.3 % at 1e-5, and the map's pass runs at the FMUs' own
tolerance (``benchmarks/bench_map_sensitivity.py``; docs/coupling-record.md, session 19).
"""
from __future__ import annotations

import cmath
import math
from dataclasses import asdict

from .local_errors import RampStep, centred_ramp_miss, stiff_x_error
from .passages import NearRunaways
from .settings import CHECK_SETTINGS, STEP_CONTROL
from .variational import state_flow, step_transition

# exp() of more than this overflows a float: a carry that grows past it has long saturated
EXP_LIMIT = 700.0


def carry_problem(law, inputs_vary: bool) -> str | None:
    """Why the carried estimate cannot vouch for a run of friction ``law`` (None: it can).

    The carry above is exact to first order where its derivation holds: the friction force a
    function of dv alone with a bounded slope, or a law with an internal state (the lubricant's
    f), whose error the law's own slopes carry (the variational equations above) from each slip
    step's path error (coupling/path_error.py). Its melting and re-solidifying are events a
    linearisation cannot follow where a step passes over them; the step control does not take
    such a step (a grip inside a step, :func:`.path_error.passed_phase_change`), and a run that
    had to, at the shortest step, cannot vouch (GlobalErrorEstimate.passed_event). (Charged from
    the force's divided differences, the slip steps' local errors had the wrong sign, and the
    estimate read 0.07-0.26x the true error at gamma >= 0; with grips passed over, gamma = -0.3
    at per-step 1e-2 ran 46 % off and read 0.006x. With both, and the error inside a step in
    the window's estimate: estimate / true 0.46-2.1 over 27 runs at gamma = -0.95 to 2, omega
    20 and 30, the solid lubricant, tol 1e-2 to 1e-4, ``bench_trust.py --one-run --only
    boundary`` and ``--only fig6``, 2026-11-27 13:55 UTC.) Such a run is verified by a second
    before a call ends on it (:func:`carry_needs_verification`). It does not hold for
    - a force with an unbounded slope at rest (``law.slope_bounded``) other than a shear-thinning
      power law's (``law.shear_thinning``): a Stribeck curve's with delta < 1 at breakaway.
      A shear-thinning force is continuous through dv = 0 and its slope, |dv|^gamma, integrable
      over a crossing at a finite rate (gamma > -1): the error's damping c is then too, and
      where it is huge (creeping at |dv| ~ 1e-9 m/s) the carry holds x and lets v's error
      decay, as the stiff loop does. What the carry could not follow came from the local
      errors (coupling/embedded.py): a stiff loop's x error had been filtered as v's, a
      reversal passed over inside a step went uncharged, and chords of F over dv at the
      solve's resolution gave the carry a slope of either sign (gamma = -0.7: 0.16-0.36x the
      true error; gamma = -0.9: 24-276x, saturated). With those charged, estimate / true
      0.67-1.1 over 21 runs at gamma = -0.3 to -0.95, tol 1e-2 to 1e-4, other omega, m, M, K
      (``benchmarks/bench_trust.py --one-run --only pseudo`` and ``--extra``, 2026-11-27).
      A force that falls as the slip grows (mixed friction's Stribeck drop, delta >= 1) is
      followed: its error grows as the exponential of the chord's negative slope, and the
      local errors it grows from are charged as the drop makes them (:func:`centred_ramp_miss`:
      the curvature's lag, under-read where it steepens; ``unstable_loop_factor``: the loop
      pushing an error on, both in coupling/local_errors.py). Charged at the lagging curvature
      and filtered as a damping loop's, the estimate had read 0.30-0.88x its true error (0.54
      at delta = 3, omega = 12, at each per-step tol 1e-2 and 1e-3); charged so, 0.73-1.7 over
      24 runs at tol 1e-2 to 1e-4 (8 points: other omega, mu_s, v_s, delta, M, m, K;
      ``bench_trust.py --one-run --only mixed`` and ``--extra``, 2026-11-27);
    - inputs n, T that change over the run (a Load or Thermal FMU): the chord of F against dv
      is then not the slope the carry needs, and the carry's damping has no sign."""
    if not law.slope_bounded and not law.shear_thinning:
        return f"the {law.label} force's slope is unbounded at rest"
    if inputs_vary:
        return "the friction's inputs n, T change over the run (a Load or Thermal FMU)"
    return None


def carry_needs_verification(law) -> bool:
    """Whether a run of friction ``law`` that vouches for itself (:func:`carry_problem` None) is
    to be verified by a second run's estimate before a call ends on it (checked.py
    CheckSequence): a law with an internal state whose steps the carry can take only by its
    slopes at their middles (not ``law.gives_step_map``). Its melting and re-solidifying then
    lose part of an error at each (bench_carry_sensitivity.py: 0.35x after two periods at
    gamma = 1.5, omega = 15, M = 0.4, whose call at tol 1e-2 said ok 9.8 % off, 2026-11-27;
    0.02x after three at a cold film, said ok at 2.4x tol). The boundary law gives its steps'
    own map (coupling/variational.py step_transition), which keeps 0.96-1.0x and 0.35x there:
    its runs stand on their own estimates (none silent or out of band in 161 calls: the trust
    list, --extra's boundary points, seeds 906-909; bench_trust.py, 2026-11-28 01:30-02:28)."""
    return law.has_state and not law.gives_step_map


class GlobalErrorEstimate:
    """The carried error (ex [m], ev [m/s], and ef [1] for a friction with state) and what it
    needs of the block and the law."""

    def __init__(self, law=None):
        self.ex = self.ev = 0.0
        self.ef = 0.0  # [1] the error in the friction's state f (0 without a law with state)
        self.w2 = 0.0  # 1/s^2, 2K/M as last measured (0: not yet)
        # the friction law whose slopes carry its state's error (:meth:`state_slopes`); None:
        # a law without state, or one the coupling was not given (a user's own Friction FMU):
        # the block's carry alone
        self.law = law if law is not None and law.has_state else None
        # the last accepted step's force ramp, whose charge the next ramp centres (recentre)
        self.ramp: RampStep | None = None
        # the carry reached the motion's own size somewhere: past its linearisation, it says only
        # that the run is far off, not how far (it cannot vouch for the run)
        self.saturated = False
        # a step passed over an event the linearisation cannot follow (a grip of the lubricant
        # inside a step, coupling/path_error.py): the run cannot vouch
        self.passed_event = False
        # the passages near a melt the run did not take (coupling/passages.py)
        self.near_runaways = NearRunaways(self.law, CHECK_SETTINGS.estimate_safety) if self.law is not None else None
        # (ex, ev, ef) of the error carried since :meth:`mark`, with no local error added since:
        # how the error made before then decays (coupling/lead_in.py); None: not marked. Its
        # spread is the spread at the mark, carried as it is (:meth:`old_v`)
        self.old: tuple[float, float, float] | None = None
        self.old_spread = (0.0, 0.0, 0.0)
        # (x [m], v [m/s], f [1]) what the local error estimates leave unknown, carried as the
        # error is (:meth:`advance`); reported beside it, as a root-sum-square
        self.spread = (0.0, 0.0, 0.0)

    def export(self) -> list:
        """What a state snapshot carries of it (JSON-ready): ex, ev, w2, the last ramp, ef, and
        what the run so far says of its own estimate (saturated, passed_event, the passages
        near a melt), the error carried since the mark, the spread, and the spread carried since
        the mark: a run restored to a snapshot reports as if it had never gone past it."""
        passages = self.near_runaways.export() if self.near_runaways is not None else None
        return [self.ex, self.ev, self.w2, asdict(self.ramp) if self.ramp is not None else None, self.ef,
                self.saturated, self.passed_event, passages, list(self.old) if self.old is not None else None,
                list(self.spread), list(self.old_spread)]

    def restore(self, values: list) -> None:
        """Back to what :meth:`export` gave (or its first three, from a snapshot without a ramp;
        ef 0 from one without it; the flags and passages as they are from one without them)."""
        self.ex, self.ev, self.w2 = values[:3]
        ramp = values[3] if len(values) > 3 else None
        self.ramp = RampStep(**ramp) if ramp is not None else None
        self.ef = values[4] if len(values) > 4 else 0.0
        if len(values) > 7:
            self.saturated, self.passed_event = values[5], values[6]
            if self.near_runaways is not None and values[7] is not None:
                self.near_runaways.restore(values[7])
        if len(values) > 8:
            self.old = tuple(values[8]) if values[8] is not None else None
        self.spread = tuple(values[9]) if len(values) > 9 else (0.0, 0.0, 0.0)
        self.old_spread = tuple(values[10]) if len(values) > 10 else (0.0, 0.0, 0.0)

    def mark(self) -> None:
        """From here on, also carry the error as it is now without the local errors to come
        (:attr:`old`): what the steps before this point leave in the run later."""
        self.old = (self.ex, self.ev, self.ef)
        self.old_spread = self.spread

    def old_v(self) -> float:
        """The error in v [m/s] made before the mark, as :meth:`advance` reports the whole one: the
        carried old error and its spread as a root-sum-square, the sign the carried one's (0 before
        a mark)."""
        if self.old is None:
            return 0.0
        return math.copysign(math.hypot(self.old[1], self.old_spread[1]), self.old[1])

    def observe(self, x: float, a: float, F: float, velocity_per_impulse: float, x_floor: float) -> None:
        """Learn w2 from a point: a = F/M - w2 x, with 1/M the block's velocity per unit impulse
        (x [m] beyond x_floor [m], so that round-off in x does not decide)."""
        if (velocity_per_impulse > 0.0 or F == 0.0) and abs(x) > x_floor:  # (no force: a = -w2 x)
            w2 = (F * velocity_per_impulse - a) / x
            if w2 > 0.0:
                self.w2 = w2

    def advance(self, h: float, damping: float, local_x: float, local_v: float, stuck: bool,
                x_scale: float = math.inf, v_scale: float = math.inf, stuck_through: bool = False,
                slopes: tuple[float, float, float, float] | None = None, f_scale: float = math.inf,
                local_f: float = 0.0, transition: tuple | None = None) -> float:
        """Carry the error over a step of h [s] with the friction's damping c [1/s], add the
        step's local errors (x [m], v [m/s]); returns the error in v [m/s] at its end.
        stuck: stuck at the step's end (no error in v there); stuck_through: stuck at both
        ends, the block riding on the drive all along: the error in x is held, not carried by
        the spring (carried as a free block's, it fell 3x over a stick where the true error
        stayed put: mixed friction, delta = 1). slopes: a friction with state's
        (:meth:`state_slopes`): the error (ex, ev, ef) is carried by its variational equations
        (:func:`state_flow`) instead, with their c in place of damping; transition (1/M and a
        lubricant slip step's sensitivities, variational.lubricant_step): by its own map instead.

        The carried error saturates at the motion's own size (x_scale [m], v_scale [m/s], and
        f_scale [1] for f): a linearised carry is meaningless past it (a stiff spring whose
        2K/M the block's answers give only roughly would otherwise let it grow without bound,
        as would a friction whose slope is negative).

        The returned error in v is the carried one and its :attr:`spread` as a root-sum-square
        (its sign the carried one's): the spread is what each step's local error estimate leaves
        unknown, the share the step-size rule allows for its own estimate's miss (1 - its
        safety: a tenth), of unknown sign, carried by the same map, each step's share added to
        it as a square (component by component: the shares are independent). Where the motion
        makes the carried terms cancel (a lubricant's melt taking back the error it met:
        docs/coupling-record.md, "The carried error's spread"), the sum shrinks and the spread does
        not."""
        scales = (x_scale, v_scale, f_scale)
        if self.old is not None:  # (the same motion, no local errors: nothing to flag)
            self.old = _bounded(self._carried(h, damping, stuck_through, slopes, transition, *self.old), scales, stuck)
            if any(self.old_spread):
                self.old_spread = _bounded(self._carried(h, damping, stuck_through, slopes, transition,
                                                         *self.old_spread), scales, stuck)
        locals_ = (local_x, local_v, local_f)
        carried = self._carried(h, damping, stuck_through, slopes, transition, self.ex, self.ev, self.ef)
        error = (carried[0] + local_x, carried[1] + local_v, carried[2] + local_f)
        share = 1.0 - STEP_CONTROL.safety
        spread = self._carried(h, damping, stuck_through, slopes, transition, *self.spread) \
            if any(self.spread) else self.spread  # (none yet: an overflowing carry's inf is not it)
        spread = tuple(math.copysign(math.hypot(s, share * local), s) for s, local in zip(spread, locals_))
        self.ex, self.ev, self.ef = _bounded(error, scales, stuck)
        self.spread = _bounded(spread, scales, stuck)
        if ((self.ex, self.ev, self.ef) != (error[0], 0.0 if stuck else error[1], error[2])
                or self.spread != (spread[0], 0.0 if stuck else spread[1], spread[2])):
            self.saturated = True
        return math.copysign(math.hypot(self.ev, self.spread[1]), self.ev)

    def watch(self, slopes: tuple[float, float, float, float] | None, f_start: float, f_end: float) -> None:
        """After :meth:`advance` over a step from f_start to f_end [1] with those slopes: follow
        the passages near a melt (coupling/passages.py)."""
        if self.near_runaways is not None:
            self.near_runaways.step(slopes, f_start, f_end, self.ef)

    def state_slopes(self, start, end, velocity_per_impulse: float,
                     dv_floor: float) -> tuple[float, float, float, float] | None:
        """The coefficients (c [1/s], p [m/s^2], q [1/m], r [1/s]) of the variational equations
        over the slip step from point start to point end of a friction with an internal
        state f (:data:`law`; F its force, g = df/dt its rate, eq. 21, M the block's mass):

            ex' = ev,  ev' = -w2 ex - c ev + p ef,  ef' = q ev + r ef,

        c = dF/d(dv) / M, p = dF/df / M, q = -dg/d(dv), r = dg/df (dv = V - v moves by -ev),
        from the law's exact slopes (:meth:`~tribofmu.physics.friction.FrictionLaw.state_jacobian`)
        at the step's middle: dv, f, n and T the means of its two points, |dv| no nearer 0
        than dv_floor [m/s] (the solve's resolution: a shear-thinning slope is infinite at
        rest), 1/M = velocity_per_impulse [m/s per N s]. At the step's end instead, the
        melting runaway's positive dg/df over a whole step read 7x-236x the true error. F
        and g are continuous in (dv, f) (the modulus floored at 0 is a kink, not a jump): no
        saltation jump to first order. None without such a law, before the block's mass is
        known, or where a slope is not finite."""
        law = self.law
        if law is None or velocity_per_impulse <= 0.0:
            return None
        dv = 0.5 * (start.dv + end.dv)
        if abs(dv) < dv_floor:
            dv = math.copysign(dv_floor, dv)
        F_dv, F_f, g_dv, g_f = law.state_jacobian(dv, 0.5 * (start.f + end.f), 0.5 * (start.n + end.n),
                                                  0.5 * (start.T + end.T))
        slopes = (F_dv * velocity_per_impulse, F_f * velocity_per_impulse, -g_dv, g_f)
        return slopes if all(map(math.isfinite, slopes)) else None

    def recentre(self, ramp: RampStep | None) -> None:
        """Before the step that ramp describes (None: not a ramp whose curvature is known) is
        carried: correct the last step's charged error by :func:`centred_ramp_miss`, if ramp
        follows it in the same slip, then remember ramp."""
        last, self.ramp = self.ramp, ramp
        if last is not None and ramp is not None and last.t_ns == ramp.t0_ns and last.mode == ramp.mode:
            dv = centred_ramp_miss(last, ramp) - last.v
            self.ex += stiff_x_error(dv, last.h, last.gain, True)
            self.ev += dv

    def _carried(self, h: float, damping: float, stuck_through: bool, slopes, transition,
                 ex: float, ev: float, ef: float) -> tuple[float, float, float]:
        """The error (ex, ev, ef) carried over the step as :meth:`advance` describes, no local
        error added."""
        if stuck_through:
            return ex, 0.0, ef
        if transition is not None:
            return step_transition(h, self.w2, *transition, ex, ev, ef)
        if slopes is not None:
            return state_flow(h, self.w2, *slopes, ex, ev, ef)
        return (*self._flow(h, damping, ex, ev), ef)

    def _flow(self, h: float, c: float, ex: float, ev: float) -> tuple[float, float]:
        """exp(A h) (ex, ev) for A = [[0, 1], [-w2, -c]], in closed form."""
        w2 = self.w2
        root = cmath.sqrt(0.25 * c * c - w2)
        l1, l2 = -0.5 * c + root, -0.5 * c - root
        if abs(l1 - l2) <= 1e-9 * (abs(l1) + abs(l2)) or abs(l1 - l2) * h < 1e-9:
            lam = 0.5 * (l1 + l2)  # a double eigenvalue: exp(A h) = e^(lam h) (I + (A - lam) h)
            e = cmath.exp(lam * h)
            nx = e * (ex + h * (-lam * ex + ev))
            nv = e * (ev + h * (-w2 * ex + (-c - lam) * ev))
            return nx.real, nv.real
        # exp(A h) = (e^(l1 h) (A - l2) - e^(l2 h) (A - l1)) / (l1 - l2); a stiff l2 underflows to 0
        if (l1 * h).real > EXP_LIMIT:  # (a negative c grows the error past any scale: saturated)
            return math.copysign(math.inf, ex or 1.0), math.copysign(math.inf, ev or 1.0)
        e1 = cmath.exp(l1 * h)
        e2 = cmath.exp(l2 * h) if (l2 * h).real > -EXP_LIMIT else 0.0
        d = l1 - l2
        ax, av = ev, -w2 * ex - c * ev  # A (ex, ev)
        nx = (e1 * (ax - l2 * ex) - e2 * (ax - l1 * ex)) / d
        nv = (e1 * (av - l2 * ev) - e2 * (av - l1 * ev)) / d
        return nx.real, nv.real


def _bounded(values, scales, stuck: bool) -> tuple[float, float, float]:
    """(x, v, f) each within its scale (:func:`_saturated`), v 0 where the contact is stuck."""
    (x, v, f), (x_scale, v_scale, f_scale) = values, scales
    return _saturated(x, x_scale), 0.0 if stuck else _saturated(v, v_scale), _saturated(f, f_scale)


def _saturated(value: float, scale: float) -> float:
    """value within [-scale, scale]; at the scale where the linear carry overflowed (nan)."""
    if math.isnan(value):
        return scale
    # max(-scale, min(scale, value)) with the builtins' comparisons written out, in their order
    # (some nine times a step)
    below = value if value < scale else scale
    return below if below > -scale else -scale


def _same(a: float, b: float) -> bool:
    """Equal, or both nan (an input the scene does not have, as T without a Thermal FMU)."""
    return a == b or (math.isnan(a) and math.isnan(b))


def chord_damping(start, end, velocity_per_impulse: float, dv_resolution: float) -> float | None:
    """The friction's damping c [1/s] over the slip step from point start to point end: the
    chord of its force against dv, (F1 - F0) / (dv1 - dv0), times the block's velocity per
    unit impulse 1/M [m/s per N s]; negative where the force falls as the slip grows.
    None where the chord is not the slope of F(dv): across a change of contact mode, for a
    friction with an internal state (f moves the force too: Fig. 6's chords read its melting
    as slope, 4x -> 64x the true error), with changing inputs (n, T), where dv moved by no
    more than the solve resolves at the two ends (2 dv_resolution [m/s]), or where an end's dv
    is within that resolution of 0 or past it: its force is the law's at the dv the solve found,
    on its mode's side, which the point's dv (the block's answer, off it by up to the
    resolution) then does not show. (A shear-thinning fluid at gamma = -0.9 slipping through
    dv = 0 in one mode read a chord from 4.7e-8 to -1.1e-8 m/s as a damping of -1.8e7 1/s, and
    its carry saturated: the run could not vouch, and the call took a third run.)"""
    if not (end.mode.slipping and start.mode == end.mode) or velocity_per_impulse <= 0.0:
        return None
    if start.f != 0.0 or end.f != 0.0 or not (_same(start.n, end.n) and _same(start.T, end.T)):
        return None
    ddv = end.dv - start.dv
    side = end.mode.direction
    if abs(ddv) <= 2.0 * dv_resolution or min(side * start.dv, side * end.dv) <= dv_resolution:
        return None
    return (end.F - start.F) / ddv * velocity_per_impulse
