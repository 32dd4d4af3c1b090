"""The implicit coupling's tuning in one place: every constant of its step solve (contact.py,
blocks.py, solvers.py) and of its step control (implicit.py, controlled.py), each with why it
has its value. (The embedded error estimate's weights are coupling/embedded.py's, the
step-size rule's physics/stepsize.py's.)

Fractions and tolerances are relative to the scene's scales or to the step unless a unit is
given. ``CALIBRATED`` names the values measured on one shipped scene rather than derived.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CouplingSettings:
    # -- what counts as stuck, and how finely the step's solves resolve ----------------------
    # The "zero" relative velocity, as a fraction of the scene's velocity scale: |dv| within it
    # counts as stuck. Far below any velocity error the error control resolves (the root
    # tolerance is 1e-3 of the per-step tolerance's share of |v|), far above v's round-off.
    zero_velocity: float = 1e-10
    # The slip root is solved to this fraction of the step's error allowance: tighter buys
    # nothing the error control can see, and each iteration is a friction and a block step.
    root_tol_fraction: float = 1e-3
    # Any iteration of one step's solve (bracket widening, Illinois, the stick force's secant)
    # stops after this many evaluations: a monotone loop converges in a few dozen at most.
    max_iterations: int = 60
    # Friction steps one slip step may take to settle its root with the state integrated. A
    # law without state needs one; the lubricant, whose f moves the force, two or three.
    max_settle_rounds: int = 6
    # Aiming at the slip root with the last step's loop gain, the first iterate is placed this
    # fraction beyond the aim, so that it brackets the root when the gain is a little off.
    root_aim_beyond: float = 0.05
    # The stick onset inside a step is located to this fraction of the step (1 ns in a 1 s
    # step: below the integer-nanosecond time grid of any step the controller takes).
    stick_onset_xtol: float = 1e-9
    # The stick ramp's Newton iterations on (dv, x) with secant slopes: the block's answer is
    # affine in (F0, rate), so two or three converge; more means the block is not linear.
    stick_ramp_iterations: int = 8
    # The stick ramp keeps x on the drive to this fraction of the scene's position scale
    # (round-off of x, ~1e-16 relative, times the few operations of one step).
    stick_ramp_position_tol: float = 1e-12

    # -- the ramp (trapezoidal) or the held force (backward Euler) ---------------------------
    # The trapezoidal ramp damps an error mode by (1 - g)/(1 + g) per step at loop gain g,
    # which rings toward -1 as g grows: above this gain the force is held instead. Measured
    # on fig6 (stiff solid lubricant): 30 rather than 3 cut rejections 7x at equal error.
    max_ramp_gain: float = 30.0
    # Where the force is smooth (slipping on the same way) it is ramped over the step: second
    # order. False holds it everywhere (backward Euler in the force), for comparison.
    second_order: bool = True
    # A slip going on is sought with the friction stepped from its first trial while the law
    # has not stuck (contact.ImplicitStep.stepped_slip): on fig6 29 -> 23 FMU calls a step.
    stepped_trials: bool = True

    # -- the block's affine response, reused instead of stepped (blocks.BlockResponse) --------
    # The final force is always stepped for real and the model checked against it: a block
    # whose modelled answer misses the real one by more than this many root tolerances is not
    # affine, and is stepped for every iterate from there.
    model_miss_tolerance: float = 1.0
    # End forces this close (relative) are one force to the block's model: two real answers a
    # few ulps apart differ by round-off, and an affine model through them extrapolates
    # round-off (a Stribeck force at its floor, 6.0 and 6.000000000000001 N: a slip root
    # where the block sticks).
    same_force_rtol: float = 1e-12

    # -- the step control ---------------------------------------------------------------------
    # A step's error is measured against the block's own motion: its largest |v| and |x| so
    # far, floored at this fraction of the scene's scales (from complete rest the motion is
    # round-off, and no step would pass).
    scale_floor: float = 1e-6
    # The smallest and largest step, as fractions of the scene's period: 1e-7 T resolves any
    # event the kinetics can produce; T/20 keeps the drive's own cosine resolved.
    min_step_periods: float = 1e-7
    max_step_periods: float = 1.0 / 20.0
    # An event (a breakaway) this early in a step, as a fraction of it, is not landed on: the
    # step is accepted with the event inside (its own error estimate judges it).
    min_landing_fraction: float = 0.01
    # w2 is learned only from points whose |x| is beyond this fraction of the largest |x| so
    # far: nearer the spring's rest a = F/M - w2 x divides round-off by x.
    w2_position_floor: float = 1e-3
    # How much smaller than its allowance a grazing step's error is treated: > 1 rejects it
    # (dv dips past 0 between communication points: a stick or a reversal the step would pass
    # over).
    grazing_error: float = 4.0
    # Where between two communication points the interpolated relative velocity is checked
    # for a crossing of 0 (quarters: a dip shorter than a quarter step is below the step's
    # resolution).
    grazing_samples: tuple[float, ...] = (0.25, 0.5, 0.75)


# The settings every coupling runs with unless it is given others.
SETTINGS = CouplingSettings()

# The values measured on one shipped scene rather than derived from the method (see the
# comments above): what a rebuild of the method should replace by a rule.
CALIBRATED = ("max_ramp_gain",)
