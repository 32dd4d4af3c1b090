"""The embedded error estimate never sees the solver's own resolution (issue 36)."""
from tribofmu.coupling.algorithms import Scales
from tribofmu.coupling.embedded import EmbeddedCoupling
from tribofmu.coupling.inprocess import BlockPart, FollowedDrive, FrictionPart
from tribofmu.coupling.system import CoupledSystem
from tribofmu.physics import BoundaryLaw


def solid_lubricant(tol, law_known=False):
    """Fig. 6's rig with a lubricant that stays solid (gamma = -0.85, K = 2000 N/m each), its
    drive X = A cos(w t) from rest for the first milliseconds (V = 0, aX = -A w^2): the block
    creeps on the lubricant at |dv| ~ 1e-12 m/s where the viscous slope is ~6.5e7 N/(m/s).
    law_known: the system is told its law, as a scene's run is (the estimate then has its slopes)."""
    A, omega, n = 1.4e-6, 30.0, -1e6
    law = BoundaryLaw(m=0.05, gamma=-0.85, S=3e-9)
    system = CoupledSystem(BlockPart("block", 0.7, 2000.0, 0.0, 0.0), FollowedDrive("drive", 0.0, 0.0, -A * omega ** 2),
                           FrictionPart("friction", law, 0.0, n, 290.0), {"n": n, "T": 290.0},
                           law=law if law_known else None)
    algorithm = EmbeddedCoupling(tol=tol)
    period = 2.0 * 3.141592653589793 / omega
    algorithm.prepare(system, Scales(position=A, velocity=A * omega, period=period))
    return system, algorithm, period


def test_a_creeping_solid_lubricant_does_not_collapse_the_step_to_its_floor():
    """The force the solve finds jitters by its dv resolution times the friction's slope
    (2.7e-7 N here) from step to step whatever h; the force term read that as the force's
    curvature against tol x 8.8e-4 N and held the step at its 20 ns floor (241,063 steps a
    run, 2,000 steps reached 4e-5 s). With that resolution as the term's absolute tolerance
    the steps grow past the start's transient: 2 ms in a few hundred steps, and past 0.5 ms
    none shorter than 1e-6 of the drive's period."""
    system, algorithm, period = solid_lubricant(5e-5)
    stop_ns = 2_000_000
    points = [system.start_point()]
    while points[-1].t_ns < stop_ns and len(points) < 2000:
        points += algorithm.advance(system, points[-1], stop_ns)
    assert points[-1].t_ns == stop_ns, f"{len(points)} steps reached only {points[-1].t_ns} ns"
    assert all(p.mode.slipping for p in points[1:]) and max(abs(p.V - p.v) for p in points[-10:]) < 1e-10
    assert algorithm.counters.forced <= 10  # (the start from rest: see the report)
    later = [(b.t_ns - a.t_ns) * 1e-9 for a, b in zip(points, points[1:]) if a.t_ns >= 500_000]
    assert later and min(later) >= 1e-6 * period


def from_rest(tol, stop_ns=2_000_000):
    """The solid lubricant's rig run from rest to stop_ns: its points, algorithm and period."""
    system, algorithm, period = solid_lubricant(tol)
    points = [system.start_point()]
    while points[-1].t_ns < stop_ns and len(points) < 2000:
        points += algorithm.advance(system, points[-1], stop_ns)
    assert points[-1].t_ns == stop_ns, f"{len(points)} steps reached only {points[-1].t_ns} ns"
    return points, algorithm, period


def test_a_stiff_held_step_is_not_rejected_for_the_lubricants_own_relaxation():
    """A held step charged the state half its change, unfiltered: the friction follows f along
    the step itself, and what holding the force costs it is the block's error in dv, which a
    stiff loop pulls back (the force's own miss is divided by 1 + g). Unfiltered, the solid
    lubricant relaxing from rest was rejected at each held step: 131 rejected for 635
    accepted in the first 2 ms; filtered 4 for 224."""
    points, algorithm, _ = from_rest(5e-5)
    assert algorithm.counters.rejected <= 0.1 * algorithm.counters.steps, algorithm.counters


def test_a_run_slipping_from_rest_is_not_cut_to_its_floor_at_the_start():
    """The run's first step, slipping from rest into the solid lubricant's creep, was charged
    as a held step: the force's settling from the law's at rest onto the loop's answer (within
    M / F_dv ~ 11 ns) read as a slope over the whole step, and the lubricant's relaxation from
    f = 0 as f's miss, neither falling with h: it was forced at the 20 ns floor and the next
    steps crept up from there (at per-step 3e-5: 167 steps below 1e-6 of the drive's period in
    the first 2 ms, 10 forced). With the law's slopes known (as every scene's run has them), the
    first step is charged its own path's error: none below 1e-6 of the period, none forced."""
    system, algorithm, period = solid_lubricant(3e-5, law_known=True)
    stop_ns = 2_000_000
    points = [system.start_point()]
    while points[-1].t_ns < stop_ns and len(points) < 2000:
        points += algorithm.advance(system, points[-1], stop_ns)
    assert points[-1].t_ns == stop_ns, f"{len(points)} steps reached only {points[-1].t_ns} ns"
    steps = [(b.t_ns - a.t_ns) * 1e-9 for a, b in zip(points, points[1:])]
    assert min(steps) >= 1e-6 * period, sorted(steps)[:5]
    assert algorithm.counters.forced == 0, algorithm.counters
    assert all(p.mode.slipping for p in points[1:]) and max(abs(p.V - p.v) for p in points[-10:]) < 1e-10
