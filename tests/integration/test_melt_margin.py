"""The Friction FMU reports the lubricant's phase margin (mu/mu_bar - f), so that any master
can see a melt or a re-solidification as a sign change between communication points."""
from __future__ import annotations

import pytest

from scenes import scene

pytestmark = pytest.mark.integration


def test_the_melt_margin_output_crosses_zero_when_the_lubricant_melts(fmu_dir):
    from tribofmu.master import FMUInstance
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.scene.wiring import constant_inputs, fmu_parameters

    scenario = load_scenario(scene("fig6_boundary"))
    slave = FMUInstance(fmu_dir / "Friction.fmu", instance="friction",
                        parameters=fmu_parameters(scenario)["Friction"])
    try:
        r = slave.refs
        conditions = constant_inputs(scenario)
        slave.set_reals([r[k] for k in conditions], list(conditions.values()))
        mu_over_bar = (lambda lub: lub.mu_shear / lub.mu_shear_bar)(scenario.friction.law().lubricant)
        t, h = 0.0, 1e-5
        seen = []
        # slow shear: solid-like; fast: molten; slow again: re-solidified (f relaxes in ~1e-5 s)
        for dv in (1e-6, 3e-6, 1e-6):
            slave.set_reals([r["dv"]], [dv])
            for _ in range(50):
                slave.do_step(t, h)
                t += h
            margin, f = slave.get_reals([r["melt_margin"], r["f"]])
            assert margin == pytest.approx(mu_over_bar - f, abs=1e-12)
            seen.append(margin)
        assert seen[0] > 0 and seen[1] <= 0 and seen[2] > 0, seen
    finally:
        slave.close()
