"""The pair's in-process model (:class:`tribofmu.coupling.pair.PairModel`) on its own, at a
point no scene uses; the TriboPair FMU built from it: tests/integration/test_pair.py."""
from __future__ import annotations

import math

import numpy as np


def drive(t: float, A: float, w: float) -> dict:
    return dict(V=-A * w * math.sin(w * t), a_drive=-A * w * w * math.cos(w * t))


def test_pair_model_follows_a_newtonian_fluid_exactly_enough():
    """The in-process model alone (no FMU): Newtonian fluid F = m dv at a point no scene
    uses, host steps of 2e-3 s, against scipy's solution of M x'' + 2 K x = m (V - x')."""
    from scipy.integrate import solve_ivp
    from tribofmu.coupling.pair import PairModel, PairParameters
    from tribofmu.physics import FluidLaw

    M, K, m, A, w, h = 0.4, 2500.0, 9.0, 1.5e-3, 23.0, 2e-3
    model = PairModel(PairParameters(M, K, 0.0, 0.0, FluidLaw(m=m, gamma=0.0), 0.0, 1e-4),
                      0.0, **drive(0.0, A, w), n=-1.0, T=290.0)
    times = np.arange(0, 301) * h
    v = [0.0]
    for t in times[:-1]:
        v.append(model.step(t, h, **drive(t, A, w), n=-1.0, T=290.0).v)
    sol = solve_ivp(lambda s, y: [y[1], (m * (-A * w * math.sin(w * s) - y[1]) - 2 * K * y[0]) / M],
                    (0.0, times[-1]), [0.0, 0.0], t_eval=times, rtol=1e-11, atol=1e-14, method="DOP853")
    assert np.max(np.abs(np.array(v) - sol.y[1])) <= 2e-3 * np.max(np.abs(sol.y[1]))
