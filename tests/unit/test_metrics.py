"""The sweep metrics (tribofmu.metrics) against synthetic signals with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tribofmu import metrics as M


# -- metrics on synthetic signals ---------------------------------------------------------
def grid(periods: float, omega: float = 30.0, per_period: int = 1000, t0_periods: float = 5.0):
    T = 2 * math.pi / omega
    n = int(round(periods * per_period))
    return np.linspace(t0_periods * T, (t0_periods + periods) * T, n + 1), T


def test_pure_sinusoid_has_one_harmonic_whatever_its_phase_and_offset():
    t, T = grid(1.5)
    w = 2 * math.pi / T
    for phase, offset in ((0.0, 0.0), (1.0, 3e-4), (2.5, -1e-3)):
        x = 2e-3 * np.cos(w * t + phase) + offset
        assert M.harmonics(t, x, T) == 1
        a = M.harmonic_amplitudes(t, x, T)
        assert a[0] == pytest.approx(2e-3, rel=1e-6)


def test_harmonics_counts_those_above_one_percent_of_the_largest():
    t, T = grid(2.0)
    w = 2 * math.pi / T
    # amplitudes relative to the largest: 1, 0.2, 0.05, 0.011 (significant), 0.009, 0.001 (not)
    x = (np.sin(w * t) + 0.2 * np.sin(3 * w * t + 0.3) + 0.05 * np.cos(5 * w * t)
         + 0.011 * np.sin(7 * w * t) + 0.009 * np.sin(9 * w * t) + 0.001 * np.sin(2 * w * t))
    assert M.harmonics(t, x, T) == 4
    a = M.harmonic_amplitudes(t, x, T)
    assert a[2] == pytest.approx(0.2, rel=1e-6) and a[8] == pytest.approx(0.009, rel=1e-5)


def test_harmonics_of_a_constant_is_zero_and_of_less_than_a_period_is_nan():
    t, T = grid(1.5)
    assert M.harmonics(t, np.full_like(t, 1e-3), T) == 0
    t, T = grid(0.8)
    assert math.isnan(M.harmonics(t, np.sin(2 * math.pi / T * t), T))


def test_a_window_that_lost_its_end_sample_still_holds_its_whole_period():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    t = t[:-1]  # [t0, t0 + T): 1000 samples
    assert M.whole_periods(t, T) == (1, 1000)
    assert M.harmonics(t, np.sin(w * t) + 0.1 * np.sin(3 * w * t), T) == 2


def stuck_signal(t, T, stuck):
    """V = sin; v = V where stuck(phase in [0, 1)), else 0.3 V (slipping)."""
    w = 2 * math.pi / T
    V = 0.06 * np.sin(w * t)
    mask = stuck(((t - t[0]) / T) % 1.0)
    return V, np.where(mask, V, 0.3 * V), mask


def test_stuck_half_the_time_gives_stick_fraction_one_half():
    t, T = grid(1.0)
    V, v, _ = stuck_signal(t, T, lambda p: p < 0.5)
    assert M.stick_fraction(t, V, v) == pytest.approx(0.5, abs=2e-3)


def test_stick_fraction_is_time_weighted_on_a_non_uniform_grid():
    t = np.concatenate([np.linspace(0, 0.5, 11), np.linspace(0.5, 1.0, 1001)[1:]])  # coarse, fine
    V = np.ones_like(t)
    v = np.where(t <= 0.25, 1.0, 0.0)
    assert M.stick_fraction(t, V, v) == pytest.approx(0.25, abs=0.03)


def test_four_stick_episodes_per_period_whatever_the_window_phase():
    # stuck on [0.05, 0.2), [0.3, 0.45), [0.55, 0.7), [0.8, 0.95) of each period
    def four(p):
        return ((p % 0.25) >= 0.05) & ((p % 0.25) < 0.2)
    for t0 in (5.0, 5.1, 5.37):  # windows starting inside a stick, inside a slip
        t, T = grid(1.5, t0_periods=t0)
        V, v, _ = stuck_signal(t, T, lambda p, s=t0: four((p + s) % 1.0))
        assert M.stick_episodes_per_period(t, V, v, T) == 4
        assert M.stick_fraction(t, V, v) == pytest.approx(0.6, abs=0.01)


def test_a_run_crossing_the_whole_period_end_counts_once():
    t, T = grid(2.0)
    V, v, _ = stuck_signal(t, T, lambda p: (p < 0.1) | (p >= 0.6))  # one run per period, wrapping
    assert M.stick_episodes_per_period(t, V, v, T) == 1


def test_always_or_never_stuck_has_no_stick_episodes():
    t, T = grid(1.5)
    V, v, _ = stuck_signal(t, T, lambda p: np.ones_like(p, dtype=bool))
    assert M.stick_episodes_per_period(t, V, v, T) == 0 and M.stick_fraction(t, V, v) == 1
    v = V - 0.02  # always slipping
    assert M.stick_episodes_per_period(t, V, v, T) == 0 and M.stick_fraction(t, V, v) == 0


def test_a_slipping_reversal_through_v_equals_V_is_not_a_stick_episode():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    V = 0.06 * np.sin(w * t)
    v = V + 0.01 * np.sin(2 * w * t + 0.3)  # dv crosses 0 four times per period, never dwells
    assert np.count_nonzero(M.stuck(V, v)) > 0  # the crossings do sample below the threshold
    assert M.stick_episodes_per_period(t, V, v, T) == 0


def test_dissipated_per_cycle_of_a_viscous_force():
    # F = c (V - v), v = 0, V = A w sin(w t): one period dissipates c A^2 w^2 T / 2 = pi c A^2 w
    t, T = grid(1.5)
    A, c = 2e-3, 25.0
    w = 2 * math.pi / T
    V = -A * w * np.sin(w * t)
    v = np.zeros_like(t)
    assert M.dissipated_per_cycle(t, c * (V - v), V, v, T) == pytest.approx(math.pi * c * A**2 * w, rel=1e-4)


def test_amplitude_ratio_and_melt_fraction():
    t, T = grid(1.0)
    w = 2 * math.pi / T
    assert M.amplitude_ratio(3e-3 * np.sin(w * t), 2e-3) == pytest.approx(1.5, rel=1e-6)
    f = 1.025 + 0.5 * np.sin(w * t)
    assert M.melt_fraction(t, f, 1.025) == pytest.approx(0.5, abs=2e-3)
    assert M.melt_fraction(t, f, 1.025 + 0.5 * math.sin(math.pi / 4)) == pytest.approx(0.25, abs=2e-3)
    assert math.isnan(M.melt_fraction(t, f, None))


def test_compute_metrics_gives_every_metric():
    t, T = grid(1.5)
    V, v, _ = stuck_signal(t, T, lambda p: p < 0.5)
    out = M.compute_metrics(t, V, np.sin(t), v, V - v, np.zeros_like(t), T, 1.0)
    assert list(out) == list(M.METRICS)


# -- creep (fluid and boundary friction) and no stick where the law cannot stick -------------------
def test_creep_share_of_a_sinusoidal_slip_is_the_arcsine_share():
    # V - v = D sin(w t + phase): |V - v| < r A w for a share (2/pi) asin(r A w / D), twice a period
    A, omega, D, phase = 3e-3, 17.0, 0.021, 0.4
    period = 2 * np.pi / omega
    t = np.linspace(0.0, 4 * period, 40001)
    V = A * omega * np.cos(omega * t)
    v = V - D * np.sin(omega * t + phase)
    expected = 2 / np.pi * np.arcsin(M.CREEP_REL * A * omega / D)
    assert M.creep_fraction(t, V, v, A, omega) == pytest.approx(expected, abs=2e-4)
    assert M.creep_episodes_per_period(t, V, v, A, omega, period) == 2


def test_creep_runs_longer_than_a_crossing_are_counted_as_episodes():
    # dv held inside the band for 0.3 T once a period (a plateau), else far outside it
    A, omega = 1e-3, 40.0
    period = 2 * np.pi / omega
    t = np.linspace(0.0, 3 * period, 30001)
    phase = (t / period) % 1.0
    dv = np.where((phase > 0.2) & (phase < 0.5), 0.01 * A * omega, 0.5 * A * omega)
    assert M.creep_fraction(t, dv, np.zeros_like(t), A, omega) == pytest.approx(0.3, abs=1e-3)
    assert M.creep_episodes_per_period(t, dv, np.zeros_like(t), A, omega, period) == 1


def test_a_law_that_cannot_stick_reports_no_stick_whatever_the_mask():
    T = 0.5
    t = np.linspace(0, 2 * T, 2001)
    V, v = np.cos(t), np.cos(t) * 0.9
    mask = ((t / T) % 1.0 < 0.1).astype(float)  # the coupling held dv = 0 briefly
    for creeps in (True, False):  # fluid and boundary friction creep; no friction does not
        out = M.compute_metrics(t, V, np.sin(t), v, V - v, np.zeros_like(t), T, 1.0,
                                stuck_mask=mask, sticks=False, creeps=creeps)
        assert out["stick_fraction"] == 0 and out["stick_episodes_per_period"] == 0
        assert np.isnan(out["creep_fraction"]) != creeps
    dry = M.compute_metrics(t, V, np.sin(t), v, V - v, np.zeros_like(t), T, 1.0, stuck_mask=mask, sticks=True)
    assert dry["stick_fraction"] == pytest.approx(0.1, abs=2e-3) and np.isnan(dry["creep_fraction"])


def test_stuck_mask_episodes_at_a_point_no_scene_uses():
    from tribofmu import metrics
    T = 0.37
    t = np.linspace(0, 3 * T, 3001)
    phase = (t / T) % 1.0
    stuck = ((phase > 0.1) & (phase < 0.3)) | ((phase > 0.6) & (phase < 0.65)) | (phase > 0.95)
    assert metrics.stuck_fraction(t, stuck) == pytest.approx(0.30, abs=2e-3)
    # phase > 0.95 continues into phase < 0.0 of the next period: one episode across the wrap
    assert metrics.stuck_episodes_per_period(t, stuck, T) == 3
