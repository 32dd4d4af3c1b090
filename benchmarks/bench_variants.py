"""Where one Fig. 6 run's time goes, and variants of the adaptive step tried against the shipped
one (docs/coupling-record.md, "Speed against the monolithic solvers", session 14).

    python benchmarks/bench_variants.py --where [--repeat 5]
    python benchmarks/bench_variants.py --variant shipped,no-force-term --scene fig6_boundary --tols 1e-3,2e-4
    python benchmarks/bench_variants.py --variant map-tol=1e-5,map-tol=1e-8 --scene fig6_boundary \
        --set drive.omega=20.56 --set block.M=0.2035 --set block.K=4005 --set friction.gamma=0.893 \
        --set conditions.T=262 --tols 1e-2,3e-3,1e-3
    python benchmarks/bench_variants.py --lengths [--tols 1e-3]
    python benchmarks/bench_variants.py --variant shipped,spread=0 --steps 0.355:0.3875 --tols 7e-3 \
        --set friction.gamma=-0.3

``--where``: the default Fig. 6 call (``api.simulate``, one worker) with ``perf_counter`` around
every FMI call of the master's instances and around the step map's pass
(``variational.lubricant_step``): medians over ``--repeat`` calls, each kind's share of the call.
What is left is the master's own coupling (and the timers' few per cent).

``--variant``: one run (``api.one_run``: per-step tolerance fixed, no check, no lead-in) per
tolerance of ``--tols`` at the point, each variant in turn: accepted and rejected steps, the
run's own estimate and the true nRMS(v) on the window against the reference (rtol 1e-10), and
whether the run's estimate vouches for it (a call may end on it alone; where not, why).
Variants (each patches the shipped code for its runs only, and puts it back):
  * ``shipped``: as shipped;
  * ``no-force-term``: the step's error without the force term of a friction with state
    (``EmbeddedCoupling.state_force_error``'s |local.F| part; the state's term stays);
  * ``state-from-path``: a lubricated slip step's state term from its path error in f (the f
    its carry takes, against error_weight x tol x the largest |f|, as x's and v's are) instead of
    f's miss of its extrapolation weighed by ``state_weight``;
  * ``measured-power``: after a rejection, the next try sized from the power of h the last two
    tries of the same step showed (within [1, order + 1]) instead of order + 1;
  * ``map-tol=X``: the step map's pass with the kinetics at tolerance X (shipped: the FMUs' 1e-5);
  * ``no-trend``: the step-size rule without the predictive term on rejected slip tries
    (``ErrorControlledCoupling.trend`` None for every step), as shipped until session 17;
  * ``spread=X``: the run's global estimate with each step's unknown share X of its local
    error carried beside it (shipped: 1 - the step-size rule's safety, 0.1; 0: none, as
    shipped until session 17; coupling/estimate.py ``GlobalErrorEstimate.spread``);
  * ``covariance``: the spread replaced by the carried error's full 3x3 covariance (each
    step's unknown share as a rank-one term, carried by the step's matrix, three carries of the
    unit vectors), the reported error the root-sum-square of the carried v and its variance's
    root: a check of the carried spread, which keeps only its diagonal's square roots;
  * ``exact-carry``: each slip step of a lubricant carried by the variational equations along
    the friction's own path (32 sub-steps, the law's slopes at each one's middle) instead of
    the step's map; slow (4-5x the run's time), a check of the map, not a method;
  * ``no-map``: every slip step of a lubricant carried by the variational equations at its
    middle (``variational.state_flow``), none by the step map;
  * ``map-where=A|B``: the step map only on the slip steps A or B name (``phase``: across the
    melt threshold; ``slow``: |g_f| h < 1 at the middle, f not relaxing within the step;
    ``fast``: the others), the rest as ``no-map``;
  * ``map-tangent-ends``: the map's tangent with each sub-step's slope averaged over its ends
    instead of taken at its middle;
  * ``rms-norm``: the step's error with the vector its carry takes (a lubricated slip step's
    path error in x, v and f; else x's local error, and v's with the impulse miss) combined as a
    weighted RMS, each against error_weight x tol x its scale (issue 36's item 2), the limits
    and the force and state terms still maxima (``rms_error_ratio``);
  * ``force-order``: the order handed to the step-size rule one below the step's kind's where a
    friction with state's force term decided the step (that term grows as h held, h^2 ramped);
  * ``group.name=V``: one tuning value of coupling/settings.py set to V, named as
    ``bench_settings.py`` names them (``coupling.root_tol_fraction=1e-2``);
  * ``a+b``: both (``map-tol=1e-5+map-tangent-ends``).

``--steps FROM:TO``: each variant's one run at ``--tols``' first value, step by step from FROM to
TO [s]: each accepted point's step length and f, the local errors the step charged to the run's
carried estimate (v over the window's max |v|, f), the carried error after it (v, f, and v's
spread) and the true error against the reference at that point (v, f). The estimate's errors are
exact less computed (coupling/path_error.py); they are printed as computed less exact, the
true error's sign.

``--lengths``: one run of ``--scene`` (Fig. 6 unless given; ``--set`` its overrides) at
``--tols``' first value: its accepted steps by length, the share of the drive's period they
cover, and which term of the step's error was the largest at each (accepted and rejected); then
where its steps shorter than 1e-4 s lie against the lubricant's melt threshold (their runs in a
row, how many hold a crossing, their time to it).

Not collected by pytest (no test_ prefix). Timings are of a shared machine: the load is printed.
"""
from __future__ import annotations

import argparse
import collections
import contextlib
import dataclasses
import datetime
import math
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_front  # noqa: E402


@contextlib.contextmanager
def patched(owner, name: str, value):
    """owner.name = value for the block's runs, put back after."""
    old = getattr(owner, name)
    setattr(owner, name, value)
    try:
        yield
    finally:
        setattr(owner, name, old)


def where(repeat: int) -> None:
    from tribofmu import api
    from tribofmu.coupling import embedded
    from tribofmu.master.instance import FMUInstance

    spent: dict[str, float] = {}

    def timed(function, key):
        return bench_front.timed(spent, key, function)

    names = ("do_step", "get_reals", "set_reals", "_get_state", "restore", "free_state")
    with contextlib.ExitStack() as stack:
        for name in names:
            stack.enter_context(patched(FMUInstance, name, timed(getattr(FMUInstance, name), f"FMI {name}")))
        stack.enter_context(patched(embedded, "lubricant_step", timed(embedded.lubricant_step, "the map's pass")))
        api.simulate("fig6_boundary", check_workers=1)  # (the FMUs unzipped, the code warm)
        calls = []
        for _ in range(repeat):
            spent.clear()
            begin = time.perf_counter()
            api.simulate("fig6_boundary", check_workers=1)
            calls.append((time.perf_counter() - begin, dict(spent)))
    whole = statistics.median(total for total, _ in calls)
    median = {key: statistics.median(parts.get(key, 0.0) for _, parts in calls) for key in calls[0][1]}
    fmi = sum(value for key, value in median.items() if key.startswith("FMI"))
    print(f"Fig. 6's default call, one worker: {whole:.3f} s (median of {repeat})")
    for key, value in sorted(median.items(), key=lambda item: -item[1]):
        print(f"  {key:22s} {value:7.3f} s {100 * value / whole:4.0f} %")
    rest = whole - fmi - median.get("the map's pass", 0.0)
    print(f"  {'FMI calls in all':22s} {fmi:7.3f} s {100 * fmi / whole:4.0f} %")
    print(f"  {'the coupling and rest':22s} {rest:7.3f} s {100 * rest / whole:4.0f} %")


def measured_power_patches() -> list:
    """ErrorControlledCoupling._accepted with the next try after a rejection sized from the
    power of h the step's last two tries showed (forgotten after an accepted or landed try)."""
    from tribofmu.coupling import controlled

    owner = controlled.ErrorControlledCoupling
    shipped, landed, landed_at_crossing = owner._accepted, owner._landed, owner._landed_at_crossing

    def accepted(self, system, start, h_ns, error, order, min_ns, steps):
        last, rule, power = getattr(self, "_variant_rejected", None), self.controller, None
        if last is not None and last[2] == order and last[0] > h_ns > 0 and last[1] > 0.0 and error > 0.0:
            power = min(max(math.log(last[1] / error) / math.log(last[0] / h_ns), 1.0), order + 1.0)
        if power is not None:
            self.controller = _PowerRule(rule, power)
        try:
            kept = shipped(self, system, start, h_ns, error, order, min_ns, steps)
        finally:
            self.controller = rule
        self._variant_rejected = None if kept else (h_ns, error, order)
        return kept

    def forgetting(function):
        def wrapper(self, *args):
            landing = function(self, *args)
            if landing:
                self._variant_rejected = None
            return landing
        return wrapper

    return [(owner, "_accepted", accepted), (owner, "_landed", forgetting(landed)),
            (owner, "_landed_at_crossing", forgetting(landed_at_crossing))]


class _PowerRule:
    """The shipped step-size rule with its exponent 1 / power instead of 1 / (order + 1): its
    own factor() at the order power - 1 (the rule reads the order through that exponent only)."""

    def __init__(self, rule, power: float):
        self.rule, self.power = rule, power
        self.max_factor = rule.max_factor

    def factor(self, error, order, after_reject=False, previous_error=1.0):
        return self.rule.factor(error, self.power - 1.0, after_reject, previous_error)


def tangent_at_ends(shipped_substep):
    """StepTangent.substep with the slope g_f averaged over the sub-step's ends (shipped: at
    the middle)."""
    def substep(self, f_a, f_b, dv_a, dv_b, u_a, u_b, dt):
        slope = self.slope
        middle = 0.5 * (slope(f_a) + slope(f_b))
        with patched(self, "slope", lambda f: middle):
            shipped_substep(self, f_a, f_b, dv_a, dv_b, u_a, u_b, dt)
    return substep


def exact_carry_patches(substeps: int = 32) -> list:
    """GlobalErrorEstimate._carried with a lubricant's slip step carried by its variational
    equations composed over ``substeps`` equal parts of the step along the friction's path (dv
    on the straight line between the step's ends, f advanced along it by the law at 1e-8), the
    law's slopes at each part's middle (the ``exact-carry`` variant): the linearised exact flow
    the path's local errors (coupling/path_error.py) are measured against, where the shipped
    carry takes the step's own map (the coupling's, which rings where the loop is stiff)."""
    from tribofmu.coupling import embedded
    from tribofmu.coupling import estimate as estimate_module
    from tribofmu.coupling.variational import state_flow

    carry_error = embedded.EmbeddedCoupling._carry_error
    carried = estimate_module.GlobalErrorEstimate._carried

    def carry_error_seen(self, point, new, local, h):
        self.estimate.variant_step = (point, new, self.velocity_per_impulse, self.dv_resolution())
        try:
            return carry_error(self, point, new, local, h)
        finally:
            self.estimate.variant_step = None

    def carried_along_path(self, h, damping, stuck_through, slopes, transition, ex, ev, ef):
        step = getattr(self, "variant_step", None)
        if transition is None or step is None or self.law is None:
            return carried(self, h, damping, stuck_through, slopes, transition, ex, ev, ef)
        start, end, velocity_per_impulse, dv_floor = step
        n, T, f, part = 0.5 * (start.n + end.n), 0.5 * (start.T + end.T), start.f, h / substeps
        for k in range(substeps):
            dv0 = start.dv + (end.dv - start.dv) * k / substeps
            dv1 = start.dv + (end.dv - start.dv) * (k + 1) / substeps
            f1, _ = self.law.advance(f, dv1, n, T, part, 1e-8, 1e-8, dv0)
            dv = 0.5 * (dv0 + dv1)
            dv = math.copysign(dv_floor, dv) if abs(dv) < dv_floor else dv
            F_dv, F_f, g_dv, g_f = self.law.state_jacobian(dv, 0.5 * (f + f1), n, T)
            ex, ev, ef = state_flow(part, self.w2, F_dv * velocity_per_impulse, F_f * velocity_per_impulse,
                                    -g_dv, g_f, ex, ev, ef)
            f = f1
        return ex, ev, ef

    return [(embedded.EmbeddedCoupling, "_carry_error", carry_error_seen),
            (estimate_module.GlobalErrorEstimate, "_carried", carried_along_path)]


def map_where(shipped, where: list[str]):
    """variational.lubricant_step only on the slip steps ``where`` names, the others carried by
    the variational equations at the step's middle (state_flow): "phase", across the melt
    threshold (the law's melt margin changes sign); "slow", f not relaxing within the step
    (|g_f| h < 1 at the step's middle); "fast", f relaxing within it."""
    def lubricant_step(law, start, end, h, velocity_per_impulse):
        crossed = (law.melt_margin(start.f) > 0.0) != (law.melt_margin(end.f) > 0.0)
        g_f = law.state_jacobian(0.5 * (start.dv + end.dv), 0.5 * (start.f + end.f), 0.5 * (start.n + end.n),
                                 0.5 * (start.T + end.T))[3]
        slow = abs(g_f) * h < 1.0
        if ("phase" in where and crossed) or ("slow" in where and slow) or ("fast" in where and not slow):
            return shipped(law, start, end, h, velocity_per_impulse)
        return None
    return lubricant_step


def rms_error_ratio(self, point, new, local, h):
    """EmbeddedCoupling.error_ratio with the vector the carry takes (a lubricated slip step's path
    error in x, v and f; else the local error in x and in v with the impulse miss) combined as a
    weighted RMS, each component against error_weight x tol x its scale (issue 36, item 2); the
    limits (interpolants, the breakaway's timing) and the force and state terms stay maxima."""
    allowance = self.errors.error_weight * self.tol
    v_scale, x_scale = self.velocity_scale(point, new), self.position_scale(point, new)
    if local.path is not None:
        x, v, f, _ = local.path
        f_scale = max(self.magnitudes.f, abs(new.f), abs(point.f)) or 1.0
        terms = (x / (allowance * x_scale), v / (allowance * v_scale), f / (allowance * f_scale))
    else:
        terms = (local.x / (allowance * x_scale), (local.v + local.impulse) / (allowance * v_scale))
    error = math.sqrt(sum(term * term for term in terms) / len(terms))
    if point.mode.stuck and new.mode.stuck:
        error = max(error, self.stuck_interpolation_error(point, new, h, v_scale, x_scale))
    if local.stuck and new.F_rate != 0.0:
        error = max(error, self.breakaway_timing_error(point, new, local, h, allowance * v_scale))
    elif new.f != 0.0 or point.f != 0.0:
        error = self.state_force_error(error, point, new, local, h)
    if new.mode.slipping and (point.mode == new.mode or point.mode.stuck):
        error = max(error, self.interpolation_error(point, new, h, v_scale, x_scale))
    return error


def force_order_patches() -> list:
    """The order handed to the step-size rule is the deciding term's own power of h less one:
    where a friction with state's force term decides a slip step (its held form half the
    force's change over the step, ~h; its ramped form the curvature's h^2 / 8, ~h^2), one
    below the step's kind's (held 1, ramped 2), which the rule otherwise takes."""
    from tribofmu.coupling import controlled, embedded

    coupling, owner = embedded.EmbeddedCoupling, controlled.ErrorControlledCoupling
    shipped_ratio, shipped_accepted = coupling.error_ratio, owner._accepted

    def error_ratio(self, point, new, local, h):
        error = shipped_ratio(self, point, new, local, h)
        self._variant_force_decided = False
        if not local.stuck and (new.f != 0.0 or point.f != 0.0) and new.mode.slipping:
            F_scale = max(self.magnitudes.F, abs(new.F), abs(point.F)) or 1.0
            force = abs(local.F) / (self.tol * F_scale + self.force_term_floor(point, new, h))
            self._variant_force_decided = force == error
        return error

    def accepted(self, system, start, h_ns, error, order, min_ns, steps):
        if getattr(self, "_variant_force_decided", False) and order in (1, 2):
            order -= 1
        return shipped_accepted(self, system, start, h_ns, error, order, min_ns, steps)

    return [(coupling, "error_ratio", error_ratio), (owner, "_accepted", accepted)]


def variant_patches(name: str) -> list:
    """(owner, attribute, value) for the variant's runs; "a+b": both."""
    if "+" in name:
        return [patch for part in name.split("+") for patch in variant_patches(part)]
    from tribofmu.coupling import embedded, variational
    from tribofmu.physics.laws.tangent import StepTangent

    if name == "shipped":
        return []
    if name == "no-force-term":
        def state_error_only(self, error, point, new, local, h):
            f_scale = max(self.magnitudes.f, abs(new.f), abs(point.f)) or 1.0
            return max(error, self.errors.state_weight * abs(local.f) / (self.tol * f_scale))
        return [(embedded.EmbeddedCoupling, "state_force_error", state_error_only)]
    if name == "state-from-path":
        shipped = embedded.EmbeddedCoupling.state_force_error

        def state_from_path(self, error, point, new, local, h):
            if local.path is None:
                return shipped(self, error, point, new, local, h)
            F_scale = max(self.magnitudes.F, abs(new.F), abs(point.F)) or 1.0
            error = max(error, abs(local.F) / (self.tol * F_scale + self.force_term_floor(point, new, h)))
            f_scale = max(self.magnitudes.f, abs(new.f), abs(point.f)) or 1.0
            return max(error, abs(local.path[2]) / (self.errors.error_weight * self.tol * f_scale))
        return [(embedded.EmbeddedCoupling, "state_force_error", state_from_path)]
    if name == "measured-power":
        return measured_power_patches()
    if name.startswith("map-tol="):
        tol = float(name.split("=", 1)[1])
        return [(variational, "KINETICS_TOL", tol)]
    if name == "rms-norm":
        return [(embedded.EmbeddedCoupling, "error_ratio", rms_error_ratio)]
    if name == "force-order":
        return force_order_patches()
    if name == "no-trend":
        from tribofmu.coupling import controlled
        return [(controlled.ErrorControlledCoupling, "trend", lambda self, h_ns, order: None)]
    if name.startswith("spread="):
        from tribofmu.coupling import estimate as estimate_module
        from tribofmu.coupling.settings import STEP_CONTROL
        share = float(name.split("=", 1)[1])
        return [(estimate_module, "STEP_CONTROL", dataclasses.replace(STEP_CONTROL, safety=1.0 - share))]
    if name == "exact-carry":
        return exact_carry_patches()
    if name == "covariance":
        return covariance_patches()
    if name == "no-map":
        return [(embedded, "lubricant_step", lambda *args: None)]
    if name.startswith("map-where="):
        return [(embedded, "lubricant_step", map_where(embedded.lubricant_step, name.split("=", 1)[1].split("|")))]
    if name == "map-tangent-ends":
        return [(StepTangent, "substep", tangent_at_ends(StepTangent.substep))]
    if "." in name.split("=", 1)[0]:
        import bench_settings
        owner, attribute, value = bench_settings.setting(name)
        return [(owner, attribute, value)]
    raise SystemExit(f"bench_variants: no variant {name!r}")


def variants(names: list[str], scene: str, overrides: dict, tols: list[float]) -> None:
    import bench_trust
    from tribofmu import api
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.studies.reference import nrms

    scenario = api.load(scene, overrides)
    reference = bench_trust.trusted_reference(scenario, scene)
    fmu_dir = find_fmus(tuple(scenario.fmus))
    print(f"{'variant':18s} {'per-step':>8s} {'steps':>6s} {'rejected':>8s} {'estimate':>9s} {'true':>9s} "
          f"{'est/true':>8s} {'vouches':>7s} {'wall s':>6s}", flush=True)
    for name in names:
        with contextlib.ExitStack() as stack:
            for owner, attribute, value in variant_patches(name):
                stack.enter_context(patched(owner, attribute, value))
            for tol in tols:
                begin = time.perf_counter()
                result = api.one_run(scenario, tol, fmu_dir)
                wall = time.perf_counter() - begin
                stats = result.stats
                true = nrms(result.time, result.v, reference.time, reference.v, scenario.window)
                estimate = stats["estimated_error"].get("nrms_v")
                ratio = estimate / true if estimate is not None and true > 0 else math.nan
                print(f"{name:18s} {tol:8.2g} {stats['communication_steps']:6d} {stats['rejected_steps']:8d} "
                      f"{estimate if estimate is not None else math.nan:9.3g} {true:9.3g} {ratio:8.2f} "
                      f"{str(stats['estimated_error'].get('vouches')):>7s} {wall:6.2f}",
                      flush=True)
                why = stats["estimated_error"].get("method", "").partition("it cannot vouch for the run: ")[2]
                if why:  # (where it does not: why, as stats.json says it)
                    print(f"{'':18s} cannot vouch: {why}", flush=True)


def lengths(tol: float, scene: str = "fig6_boundary", overrides: dict | None = None) -> None:
    """One run of scene (with overrides) at tol: its steps by length and each step's largest
    error term."""
    import numpy as np

    from tribofmu import api
    from tribofmu.coupling import embedded
    from tribofmu.fmu_cache import find_fmus

    scenario = api.load(scene, overrides or {})
    largest = []
    shipped = embedded.EmbeddedCoupling.error_ratio

    def named(self, point, new, local, h):
        error = shipped(self, point, new, local, h)
        allowance = self.errors.error_weight * self.tol
        v_scale, x_scale = self.velocity_scale(point, new), self.position_scale(point, new)
        terms = {"v": abs(local.v) / (allowance * v_scale), "x": abs(local.x) / (allowance * x_scale),
                 "impulse": abs(local.impulse) / (allowance * v_scale)}
        if not (local.stuck and new.F_rate != 0.0) and (new.f != 0.0 or point.f != 0.0):
            F_scale = max(self.magnitudes.F, abs(new.F), abs(point.F)) or 1.0
            terms["force"] = abs(local.F) / (self.tol * F_scale + self.force_term_floor(point, new, h))
            f_scale = max(self.magnitudes.f, abs(new.f), abs(point.f)) or 1.0
            terms["state"] = self.errors.state_weight * abs(local.f) / (self.tol * f_scale)
        if local.path is not None:
            terms["path"] = max(abs(local.path[0]) / (allowance * x_scale), abs(local.path[1]) / (allowance * v_scale))
        term = max(terms, key=terms.get)
        # (the interpolation and breakaway terms: named where they are the largest)
        largest.append((h, term if terms[term] >= error else "interpolation or breakaway", error <= 1.0))
        return error

    with patched(embedded.EmbeddedCoupling, "error_ratio", named):
        result = api.one_run(scenario, tol, find_fmus(tuple(scenario.fmus)), keep_points=True)
    t = np.array([p.t_ns for p in result.points]) / 1e9
    h = np.diff(t)
    period = 2.0 * math.pi / scenario.drive.omega
    print(f"{scene} {overrides or ''}, one run at per-step {tol:g}: {len(h)} steps")
    for low, high in ((0.0, 1e-7), (1e-7, 1e-6), (1e-6, 1e-5), (1e-5, 1e-4), (1e-4, 1e-3), (1e-3, 1.0)):
        inside = (h >= low) & (h < high)
        kept = collections.Counter(term for length, term, ok in largest if ok and low <= length < high)
        rejected = collections.Counter(term for length, term, ok in largest if not ok and low <= length < high)
        print(f"  h in [{low:g}, {high:g}) s: {int(inside.sum()):5d} steps over {h[inside].sum() / period:.3f} "
              f"periods; largest term, accepted {dict(kept)}, rejected {dict(rejected)}")
    melts(scenario, result.points, t, h)


def melts(scenario, points, t, h, short: float = 1e-4) -> None:
    """Where the run's short steps (< short [s]) lie against the lubricant's melt threshold f =
    mu/mu_bar: their runs in a row, how many hold a crossing of it, and each short step's time to
    the nearest crossing (from its middle to the middle of the step that crosses)."""
    import numpy as np

    lubricant = scenario.friction.law().lubricant
    threshold = lubricant.mu_shear / lubricant.mu_shear_bar
    side = np.sign(np.array([p.f for p in points]) - threshold)
    crossing = np.nonzero(side[1:] != side[:-1])[0]  # the steps that cross it
    middle = t[:-1] + 0.5 * h
    is_short = h < short
    runs, i = [], 0
    while i < len(h):
        j = i
        while j < len(h) and is_short[j]:
            j += 1
        if j > i:
            runs.append((i, j))
        i = j + 1
    holding = sum(any(a <= c < b for c in crossing) for a, b in runs)
    sizes = sorted(b - a for a, b in runs)
    print(f"  steps shorter than {short:g} s: {int(is_short.sum())}, in {len(runs)} runs in a row "
          f"(median {sizes[len(sizes) // 2] if sizes else 0} steps), {holding} of them holding one of the run's "
          f"{len(crossing)} crossings of the melt threshold f = {threshold:g}")
    if not len(crossing):
        return
    distance = np.min(np.abs(middle[is_short][:, None] - middle[crossing][None, :]), axis=1)
    edges = (0.0, 1e-5, 1e-4, 1e-3, 1e-2, math.inf)
    counts = [int(((distance >= low) & (distance < high)).sum()) for low, high in zip(edges, edges[1:])]
    print("  their time to the nearest crossing: " + ", ".join(
        f"[{low:g}, {high:g}) s {count}" for low, high, count in zip(edges, edges[1:], counts)))


def covariance_patches() -> list:
    """GlobalErrorEstimate.advance with the spread as a full covariance P: P' = S P S^T + (share
    l)(share l)^T, S the step's carry (its columns the carried unit vectors), share 1 - the
    step-size rule's safety, l the step's local errors; reported hypot(ev, sqrt(P_vv)) (the
    ``covariance`` variant)."""
    from tribofmu.coupling import estimate as estimate_module
    from tribofmu.coupling.settings import STEP_CONTROL

    advance = estimate_module.GlobalErrorEstimate.advance
    share = 1.0 - STEP_CONTROL.safety  # (the shipped share; the carried spread itself is off)

    def advance_with_covariance(self, h, damping, local_x, local_v, stuck, x_scale=math.inf, v_scale=math.inf,
                                stuck_through=False, slopes=None, f_scale=math.inf, local_f=0.0, transition=None):
        P = getattr(self, "variant_covariance", [[0.0] * 3 for _ in range(3)])
        columns = [self._carried(h, damping, stuck_through, slopes, transition, *unit)
                   for unit in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
        S = [[columns[j][i] if math.isfinite(columns[j][i]) else 0.0 for j in range(3)] for i in range(3)]
        SP = [[sum(S[i][k] * P[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        unknown = [share * local for local in (local_x, local_v, local_f)]
        Q = [[sum(SP[i][k] * S[j][k] for k in range(3)) + unknown[i] * unknown[j] for j in range(3)]
             for i in range(3)]
        if stuck:
            for k in range(3):
                Q[1][k] = Q[k][1] = 0.0
        for i, scale in enumerate((x_scale, v_scale, f_scale)):
            if math.isfinite(scale) and not Q[i][i] <= scale * scale:
                Q[i][i] = scale * scale
        self.variant_covariance = Q
        advance(self, h, damping, local_x, local_v, stuck, x_scale, v_scale, stuck_through, slopes, f_scale,
                local_f, transition)
        return math.copysign(math.hypot(self.ev, math.sqrt(max(Q[1][1], 0.0))), self.ev)

    return [(estimate_module, "STEP_CONTROL", dataclasses.replace(STEP_CONTROL, safety=1.0)),  # (spread off)
            (estimate_module.GlobalErrorEstimate, "advance", advance_with_covariance)]


def steps(names: list[str], scene: str, overrides: dict, tol: float, start: float, end: float) -> None:
    """Each variant's run at tol, point by point from start to end [s] (``--steps``)."""
    import numpy as np

    from tribofmu import api
    from tribofmu.coupling import estimate as estimate_module
    from tribofmu.fmu_cache import find_fmus
    from tribofmu.studies.reference import converged_reference

    scenario = api.load(scene, overrides)
    fmu_dir = find_fmus(tuple(scenario.fmus))
    advance = estimate_module.GlobalErrorEstimate.advance
    for name in names:
        charged = []  # (local v, local f, carried v, carried f, spread v) at each accepted step

        def logged(self, h, damping, local_x, local_v, stuck, *args, **kwargs):
            reported = advance(self, h, damping, local_x, local_v, stuck, *args, **kwargs)
            local_f = args[5] if len(args) > 5 else kwargs.get("local_f", 0.0)
            charged.append((local_v, local_f, self.ev, self.ef, self.spread[1]))
            return reported

        with contextlib.ExitStack() as stack:
            for owner, attribute, value in variant_patches(name):
                stack.enter_context(patched(owner, attribute, value))
            stack.enter_context(patched(estimate_module.GlobalErrorEstimate, "advance", logged))
            result = api.one_run(scenario, tol, fmu_dir, keep_points=True)
        points = result.points
        t = np.array([p.t_ns for p in points]) / 1e9
        reference = converged_reference(scenario, t_eval=t)
        window = (t >= scenario.window[0]) & (t <= scenario.window[1])
        v_max = float(np.max(np.abs(reference.v[window]))) if window.any() else float(np.max(np.abs(reference.v)))
        print(f"{name}, per-step {tol:g}, {len(points)} points; v over max |v| on the window ({v_max:.4g} m/s); "
              "local, carried: computed less exact", flush=True)
        print(f"{'t s':>10s} {'h s':>8s} {'f':>6s} | {'local v':>9s} {'local f':>9s} | {'carried v':>9s} "
              f"{'carried f':>9s} {'spread v':>8s} | {'true v':>9s} {'true f':>9s}")
        for i in range(1, len(points)):
            if not start <= t[i] <= end or i - 1 >= len(charged):
                continue
            local_v, local_f, ev, ef, spread_v = charged[i - 1]
            print(f"{t[i]:10.6f} {t[i] - t[i - 1]:8.1e} {points[i].f:6.3f} | {-local_v / v_max:+9.2e} "
                  f"{-local_f:+9.2e} | {-ev / v_max:+9.2e} {-ef:+9.2e} {spread_v / v_max:8.1e} | "
                  f"{(points[i].v - reference.v[i]) / v_max:+9.2e} {points[i].f - reference.f[i]:+9.2e}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--where", action="store_true")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--variant", default=None, help="comma-separated: shipped, no-force-term, measured-power, "
                                                        "map-tol=X, map-tangent-ends")
    parser.add_argument("--scene", default="fig6_boundary")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--tols", default="1e-3")
    parser.add_argument("--lengths", action="store_true")
    parser.add_argument("--steps", default=None, metavar="FROM:TO",
                        help="with --variant: each variant's run at the first tol, point by point over [FROM, TO] s")
    args = parser.parse_args(argv)
    print(f"# bench_variants {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    tols = [float(value) for value in args.tols.split(",")]
    overrides = {key: float(value) for key, value in (item.split("=", 1) for item in args.set)}
    if args.where:
        where(args.repeat)
    if args.variant:
        if args.steps:
            start, end = (float(value) for value in args.steps.split(":"))
            steps(args.variant.split(","), args.scene, overrides, tols[0], start, end)
        else:
            variants(args.variant.split(","), args.scene, overrides, tols)
    if args.lengths:
        lengths(tols[0], args.scene, overrides)
    print(f"# load at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
