"""Hard cases of the co-simulation with the real FMUs: each fails if the numerics go wrong
(NaN, growth, energy created, wrong regime), checked against the monolithic reference, the
exact free oscillator, the energy audit, or the theory of the coupling's order.

Spans are shortened with time.periods so the module stays within a few minutes on 2 cores.
Note (grid): simulate() drops the last output sample when stop_time is not a whole number
of nanoseconds; windows here end a little before the span so nRMS is always defined.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pytest

from tribofmu import api
from tribofmu.coupling.interpolation import NS
from tribofmu.errors import ScenarioError
from tribofmu.master.energy import energy_audit, step_integrals
from tribofmu.studies.reference import nrms, reference_solution

from cli_run import main
from scenes import SCENARIOS

pytestmark = pytest.mark.integration


def run(fmu_dir, scene, overrides=(), **kw):
    """The scene run with every communication point kept (these tests look at them)."""
    sc = api.load(SCENARIOS / f"{scene}.toml", list(overrides))
    return sc, api.simulate(sc, fmu_dir=fmu_dir, build=False, keep_points=True, **kw)


def assert_sane(result, residual_rel=1e-3, negative_steps=0):
    """Finite, completed, and the energy balance closes without energy created."""
    assert result.ok, result.message
    for k in ("x", "v", "F", "f"):
        assert np.all(np.isfinite(getattr(result, k))), k
    e = result.stats["energy"]
    assert abs(e["residual_rel"]) < residual_rel, e
    assert e["D"] >= -1e-8 * max(abs(e["W"]), abs(e["dE"]), 1e-12), e  # friction never feeds the block
    assert e["negative_dissipation_steps"] <= negative_steps, e


def error_vs_reference(sc, result):
    ref = reference_solution(sc)
    assert ref.ok, ref.message
    return nrms(result.time, result.v, ref.time, ref.v, sc.window), ref


# -- dry friction ----------------------------------------------------------------------------
def test_dry_w130_mostly_stuck_with_asymmetric_portrait(fmu_dir):
    sc, r = run(fmu_dir, "fig4_dry_w130", ["time.periods=6.6", "time.window=[5.0,6.5]"])
    assert_sane(r, negative_steps=2)
    err, ref = error_vs_reference(sc, r)
    assert err < 2e-3
    m = r.window_mask()
    stuck = np.mean(np.abs(r.V[m] - r.v[m]) < 1e-6 * np.max(np.abs(r.V[m])))
    assert stuck > 0.8  # Fig. 4f: stuck almost always
    # the block's portrait sits off-centre (x swings more to one side), as in the reference
    rm = (ref.time >= sc.window[0]) & (ref.time <= sc.window[1])
    offset, ref_offset = r.x[m].max() + r.x[m].min(), ref.x[rm].max() + ref.x[rm].min()
    assert abs(ref_offset) > 0.05 * (ref.x[rm].max() - ref.x[rm].min())
    assert offset == pytest.approx(ref_offset, rel=0.02)


def test_dry_very_high_load_always_stuck(fmu_dir):
    sc, r = run(fmu_dir, "fig2_dry", ["conditions.n=-1e6", "time.periods=2.1", "time.window=[1.0,2.0]"])
    assert_sane(r)
    assert all(p.mode.stuck for p in r.points[1:])
    scale = np.max(np.abs(r.V))
    assert np.max(np.abs(r.v - r.V)) < 1e-8 * scale
    assert np.max(np.abs((r.x - r.X) - (r.x[0] - r.X[0]))) < 1e-8 * sc.drive.A  # moves with the drive


def test_no_friction_is_the_free_oscillator(fmu_dir):
    x0 = 1e-3
    sc, r = run(fmu_dir, "fig2_dry", ["friction.mu_friction=0", f"block.x0={x0}", "time.periods=3.1",
                                      "time.window=[1.0,3.0]"])
    assert_sane(r, residual_rel=1e-9)
    w0 = math.sqrt(2 * sc.block.K / sc.block.M)
    t = np.array([p.t_ns for p in r.points]) / NS
    x = np.array([p.x for p in r.points])
    v = np.array([p.v for p in r.points])
    # the block is exact at communication points ...
    assert np.max(np.abs(x - x0 * np.cos(w0 * t))) < 1e-9 * x0
    assert np.max(np.abs(v + x0 * w0 * np.sin(w0 * t))) < 1e-9 * x0 * w0
    assert all(p.F == 0.0 for p in r.points)
    # ... and the sampled signal is within the interpolation tolerance
    assert np.max(np.abs(r.x - x0 * np.cos(w0 * r.time))) < 1e-2 * x0
    E0 = sc.block.K * x0 ** 2
    assert abs(r.stats["energy"]["dE"]) < 1e-9 * E0  # no energy created or lost


def test_no_friction_at_rest_stays_at_rest(fmu_dir):
    sc, r = run(fmu_dir, "fig2_dry", ["friction.mu_friction=0", "time.periods=1", "time.window=[0,1]"])
    assert r.ok and np.all(r.x == 0.0) and np.all(r.v == 0.0)


def test_very_stiff_spring(fmu_dir):
    """K = 1e7: the block rings at 1 ms, 200 times faster than the drive; it moves 30x less
    than the drive, so the tolerance (relative to the drive's velocity) must be tight."""
    ov = ["block.K=1e7", "time.periods=1.6", "time.window=[0.5,1.5]"]
    sc, r = run(fmu_dir, "fig2_dry", ov, algorithm="adaptive", tol=1e-5)
    assert_sane(r, residual_rel=1e-5, negative_steps=2)
    err, ref = error_vs_reference(sc, r)
    assert err < 1e-3
    assert np.max(np.abs(r.v)) < 1.01 * np.max(np.abs(ref.v))  # no growth


@pytest.mark.parametrize("K", [1e7, 3e5])
def test_very_stiff_spring_default_tolerance(fmu_dir, K):
    """The tolerance refers to the block's own motion, so the default resolves a stiff
    spring's fast ringing (1 ms at K = 1e7) although the block moves far less than the drive."""
    ov = [f"block.K={K}", "time.periods=1.6", "time.window=[0.5,1.5]"]
    sc, r = run(fmu_dir, "fig2_dry", ov, algorithm="adaptive")
    assert_sane(r, residual_rel=1e-4, negative_steps=2)
    err, _ = error_vs_reference(sc, r)
    assert err < 1e-3


# -- fluid friction --------------------------------------------------------------------------
@pytest.mark.parametrize("ov, residual_rel, negative_frac, kw", [
    # tiny m: the block barely moves and dv follows the drive's V through 0 at each of its
    # reversals (6 in 3.1 periods), where a step that spans the change of sign leaves a sliver
    # of negative dissipation (the ramped force and the interpolated dv cross 0 a hair apart):
    # at most one such step per reversal, and all of them under 1e-6 of the dissipation
    # (measured 2026-11-27: 6 steps, one at each reversal, 7.5e-15 J against 1.0e-5 J; 2 at a
    # per-step tolerance 11 % tighter)
    (["friction.gamma=-0.6666666666666666", "friction.m=1e-3", "time.periods=3.1", "time.window=[2.0,3.0]"],
     1e-4, "reversals", {}),
    # huge m: the blocks creep with |dv| ~ 1e-6 |V|, below what a tolerance on v resolves, so
    # held steps leave slivers where the interpolated dv and the held force differ in sign;
    # they must sum to under 1e-3 of the dissipation (checked below), not by count. They fall
    # in proportion to the run's tolerance: since its own estimate vouches (one run, no
    # tighter run of a check reported), 1.5e-3 at tol 2e-5, 6.7e-4 at 1e-5, 3.0e-4 at 5e-6
    # (2026-11-27); with the checked sequence, tol 2e-5 met it through the tighter runs.
    (["friction.gamma=-0.6666666666666666", "friction.m=1e3", "time.periods=3.1",
      "time.window=[2.0,3.0]"], 3e-2, None, {"tol": 1e-5}),
], ids=["gamma-2/3-m1e-3", "gamma-2/3-m1e3"])
def test_shear_thinning_extremes(fmu_dir, ov, residual_rel, negative_frac, kw):
    """Tiny m: the block barely moves (1e-4 of the drive); huge m: it nearly follows the
    drive and dv creeps through 0 with an unbounded relaxation rate. Errors are measured
    on the drive's velocity scale, which the adaptive's tolerance refers to."""
    sc, r = run(fmu_dir, "fig5_newtonian", ov, **kw)
    steps = r.stats["communication_steps"]
    if negative_frac is None:
        assert_sane(r, residual_rel=residual_rel, negative_steps=steps)
        _, WV, Wv = step_integrals(r.points)
        D = WV - Wv
        assert -D[D < 0].sum() < 1e-3 * D.sum()
    else:
        reversals = math.floor(2.0 * sc.time.periods)  # V = -A w sin(w t) changes sign at t = k pi / w
        assert_sane(r, residual_rel=residual_rel, negative_steps=reversals)
        _, WV, Wv = step_integrals(r.points)
        D = WV - Wv
        assert -D[D < 0].sum() < 1e-6 * D.sum()
    err, ref = error_vs_reference(sc, r)
    rm = (ref.time >= sc.window[0]) & (ref.time <= sc.window[1])
    drive_scale = sc.drive.A * sc.drive.omega
    assert err * np.max(np.abs(ref.v[rm])) < 1e-3 * drive_scale
    assert np.max(np.abs(r.v)) < 1.05 * np.max(np.abs(ref.v)) + 1e-6 * drive_scale  # no growth


def test_gamma_minus_095_fixed_steps(fmu_dir):
    """gamma = -0.95: the adaptive crawls (dv creeps through 0 with a rate ~|dv|^-0.95) and
    the reference solver does not finish in CI time: fixed implicit steps, checked for
    sanity, the energy balance and self-convergence (h vs h/2)."""
    ov = ["friction.gamma=-0.95", "time.periods=1.1", "time.window=[0.1,1.0]"]
    sc, coarse = run(fmu_dir, "fig5_newtonian", ov, algorithm="implicit", step=1e-4)
    _, fine = run(fmu_dir, "fig5_newtonian", ov, algorithm="implicit", step=5e-5)
    for r in (coarse, fine):
        assert_sane(r, residual_rel=1e-4, negative_steps=0.1 * r.stats["communication_steps"])
        assert np.max(np.abs(r.v)) < 1.5 * np.max(np.abs(r.V))  # no growth
    assert nrms(coarse.time, coarse.v, fine.time, fine.v, sc.window) < 1e-2


# -- boundary friction -------------------------------------------------------------------------
def test_boundary_large_fixed_steps_bounded(fmu_dir):
    sc = api.load(SCENARIOS / "fig6_boundary.toml", ["time.periods=2", "time.window=[1.0,2.0]"])
    r = api.simulate(sc, fmu_dir=fmu_dir, build=False, algorithm="implicit", step=sc.drive.period / 20)
    assert r.ok, r.message
    assert np.all(np.isfinite(r.f)) and np.all(np.isfinite(r.v)) and np.all(np.isfinite(r.F))
    # f (the lubricant's excess volume) stays within the range the reference visits
    ref = reference_solution(sc)
    assert ref.ok, ref.message
    assert r.f.min() >= ref.f.min() - 0.1 and r.f.max() <= 1.1 * ref.f.max() + 0.1
    assert np.max(np.abs(r.v)) < 10 * np.max(np.abs(r.V))  # no growth
    assert r.stats["energy"]["D"] >= 0.0


# -- long run ----------------------------------------------------------------------------------
LONG_PERIODS = 200  # 1000 periods: benchmarks/bench_stiff.py (memory set)


def test_long_run_energy_balance_does_not_drift(fmu_dir):
    n = LONG_PERIODS
    sc, r = run(fmu_dir, "fig5_newtonian", [f"time.periods={n + 0.1}", f"time.window=[{n - 1.5},{n}]"],
                algorithm="adaptive")  # the default tolerance
    # near dv = 0 the interpolants give slivers of ~1e-14 J of negative dissipation
    assert_sane(r, residual_rel=1e-4, negative_steps=0.02 * r.stats["communication_steps"])
    # a sliver is where the linear force ramp and the cubic dv cross zero a hair apart:
    # O(h^4), far below one step's own dissipation
    mean_step = r.stats["energy"]["D"] / r.stats["communication_steps"]
    assert r.stats["energy"]["most_negative_step_dissipation"] > -1e-5 * mean_step
    period_ns = sc.drive.period * NS
    # the residual of the balance over each tenth of the run: small and not growing
    cut = [0] + [next(i for i, p in enumerate(r.points) if p.t_ns >= k * n / 10 * period_ns)
                 for k in range(1, 11)]
    chunks = [energy_audit(r.points[a:b + 1], sc) for a, b in zip(cut, cut[1:])]
    res = np.array([abs(c["residual"]) / c["D"] for c in chunks])
    assert np.all(res < 1e-4)
    assert res[-3:].mean() < 3 * res[:3].mean() + 1e-9
    # the periodic state neither grows nor decays: same amplitude after n periods
    err, ref = error_vs_reference(sc, r)
    assert err < 1e-3
    D_per_period = np.array([c["D"] for c in chunks[1:]])
    assert np.ptp(D_per_period) < 1e-3 * D_per_period.mean()


# -- convergence order ----------------------------------------------------------------------
def _order(fmu_dir, algorithm, steps):
    ov = ["time.periods=2.6", "time.window=[1.5,2.5]"]
    sc = api.load(SCENARIOS / "fig5_newtonian.toml", ov)
    ref = reference_solution(sc)
    errors = []
    for h in steps:
        r = api.simulate(sc, fmu_dir=fmu_dir, build=False, algorithm=algorithm, step=h)
        assert r.ok
        errors.append(nrms(r.time, r.v, ref.time, ref.v, sc.window))
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    return slope, errors


def test_jacobi_is_first_order(fmu_dir):
    slope, errors = _order(fmu_dir, "jacobi", [4e-4, 2e-4, 1e-4])
    assert 0.85 < slope < 1.15, (slope, errors)


def test_implicit_is_second_order_on_smooth_fluid(fmu_dir):
    slope, errors = _order(fmu_dir, "implicit", [4e-4, 2e-4, 1e-4])
    assert 1.7 < slope < 2.3, (slope, errors)


# -- no run without an end, memory bounded by the output ------------------------------------
@pytest.mark.alone
def test_a_run_that_would_take_too_long_stops_with_a_message(fmu_dir):
    """A projected wall time past simulation.max_wall ends the run early: ok is False and
    the message says where it was, what it would cost and what to change."""
    sc = api.load(SCENARIOS / "fig2_dry.toml", ["time.periods=5000", "time.window=[0,1]",
                                                 "simulation.max_wall=1"])
    notices = []
    begin = time.perf_counter()
    r = api.simulate(sc, fmu_dir=fmu_dir, build=False, notice=notices.append)
    assert time.perf_counter() - begin < 30
    assert not r.ok
    assert "at this pace the run would take" in r.message and "--max-wall" in r.message
    assert 0 < r.time[-1] < sc.stop_time  # what was computed is kept
    assert np.all(np.isfinite(r.v))


def test_cli_runaway_is_one_line_and_exit_code_1(fmu_dir, tmp_path, capsys):
    out = tmp_path / "run"
    proc = main("simulate", SCENARIOS / "fig2_dry.toml", "--set", "time.periods=5000", "--set", "time.window=[0,1]",
                "--max-wall", "1", "--fmu-dir", fmu_dir, "--out", out, "-q", capsys=capsys)
    assert proc.returncode == 1, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("tribofmu:")]
    assert len(lines) == 1 and "would take" in lines[0]
    assert (out / "stats.json").is_file() and not (out / "result.csv").exists()


def test_too_many_output_samples_are_refused_up_front(fmu_dir):
    with pytest.raises(ScenarioError, match="time.periods"):
        api.simulate(SCENARIOS / "fig2_dry.toml", ["time.periods=1e6"], fmu_dir=fmu_dir, build=False)


@pytest.mark.parametrize("scene, overrides", [
    ("fig2_dry", ["drive.omega=45", "time.periods=3.2", "time.window=[1,3]"]),
    ("fig5_pseudoplastic", ["block.M=0.9", "time.periods=2.2", "time.window=[1,2]"]),
    ("fig6_boundary", ["conditions.T=310", "time.periods=1.1", "time.window=[0,1]"]),
])
def test_streamed_output_equals_the_kept_points(fmu_dir, monkeypatch, scene, overrides):
    """The grid recorder holds only a chunk of points (here 37) at a time: its samples and
    energy audit are those computed from the whole list of points at once."""
    from tribofmu.coupling.interpolation import sample
    from tribofmu.master.run import GridRecorder

    monkeypatch.setattr(GridRecorder, "CHUNK", 37)
    held = []
    original_add = GridRecorder.add

    def add(self, point):
        original_add(self, point)
        held.append(len(self.buffer))

    monkeypatch.setattr(GridRecorder, "add", add)
    sc, kept = run(fmu_dir, scene, overrides)  # keep_points=True
    streamed = api.simulate(sc, fmu_dir=fmu_dir, build=False)
    assert max(held) <= 37 and len(streamed.points) == 0
    assert len(kept.points) > 3 * 37
    whole = sample(kept.points, kept.time)
    whole_audit = energy_audit(kept.points, sc)
    assert streamed.time.shape == kept.time.shape
    for k in ("X", "V", "x", "v", "F", "f", "stuck"):
        np.testing.assert_allclose(getattr(streamed, k), whole[k], rtol=0,
                                   atol=1e-12 * max(1e-300, np.max(np.abs(whole[k]))))
    for k in ("W", "D", "dE", "negative_dissipation_steps", "steps"):
        assert streamed.stats["energy"][k] == pytest.approx(whole_audit[k], rel=1e-9, abs=1e-18)


# A dry block that slips into stick at the very end of a step (a point no scene uses)
SLIP_INTO_STICK = ["drive.omega=23.6", "block.M=0.2945", "block.K=9430", "friction.mu_friction=0.565",
                   "conditions.n=-16.53"]


def test_a_step_that_slips_into_stick_at_its_end_is_sampled_as_a_slip(fmu_dir):
    """The run's steps end on their stick onsets; where one ends there, the block slipped all
    along the step, and its samples follow the block's own accelerations, not the drive's
    (with the drive's: 1.1e-3 off at tol 1e-4, the call said ok)."""
    sc, r = run(fmu_dir, "fig2_dry", SLIP_INTO_STICK, tol=1e-4)
    assert r.ok, r.message
    err, _ = error_vs_reference(sc, r)
    assert err < 1e-4
    onset_at_end = [(p0, p1) for p0, p1 in zip(r.points, r.points[1:])
                    if p0.mode.slipping and p1.mode.stuck and p1.event == 1.0]
    assert onset_at_end  # (the point is what the test says it is)


# -- the default tolerance means the same off the paper's points -------------------------------
@pytest.mark.parametrize("scene, overrides", [
    ("fig5_dilatant", ["friction.gamma=2", "time.periods=2.2", "time.window=[1,2]"]),
    ("fig2_dry", ["block.K=2e4", "drive.omega=70", "time.periods=3.2", "time.window=[2,3]"]),
    ("fig2_dry", ["drive.omega=10"]),  # dv grazes 0 between steps: short sticks to catch
    ("fig2_dry", ["block.K=1e6", "time.periods=4", "time.window=[3,4]"]),
    # F ~ |dv|^0.1 is nearly a jump: a single run of the one-solve coupling at the default
    # per-step tol was 8.9e-3 wrong (late breakaways from near-sticks); the check catches it
    # and tightens until the error is checked to meet tol
    ("fig5_pseudoplastic", ["friction.gamma=-0.9", "time.periods=3.2", "time.window=[2,3]"]),
    ("fig2_dry", ["friction.regime=boundary", "time.periods=1.1", "time.window=[0,1]"]),
    ("fig6_boundary", ["conditions.n=-2e6", "conditions.T=300", "time.periods=1.6", "time.window=[0.5,1.5]"]),
])
def test_default_tolerance_meets_1e_3_off_the_paper(fmu_dir, scene, overrides):
    sc, r = run(fmu_dir, scene, overrides)
    assert r.ok, r.message
    err, _ = error_vs_reference(sc, r)
    assert err < 1e-3
