"""api.SimulationResult and studies.reference.ReferenceResult share one declaration of the seven
sampled signals (tribofmu.trajectory.SampledTrajectory), and keep their constructors' order."""
from dataclasses import fields

import numpy as np

from tribofmu.api import SimulationResult
from tribofmu.scene.library import resolve_scene
from tribofmu.scene.scenario import load_scenario
from tribofmu.studies.reference import ReferenceResult
from tribofmu.trajectory import SampledTrajectory

SIGNALS = ["time", "X", "V", "x", "v", "F", "f"]


def test_the_seven_signals_are_declared_once_in_the_shared_base():
    assert [f.name for f in fields(SampledTrajectory)] == SIGNALS
    for cls in (SimulationResult, ReferenceResult):
        assert issubclass(cls, SampledTrajectory)
        assert not set(SIGNALS) & set(vars(cls).get("__annotations__", {})), cls  # not restated


def test_field_order_and_positional_construction_unchanged():
    assert [f.name for f in fields(SimulationResult)] == [
        "scenario", *SIGNALS, "stuck", "ok", "message", "stats", "points", "inputs"]
    assert [f.name for f in fields(ReferenceResult)] == [*SIGNALS, "wall_time", "stats", "ok", "message", "T", "n"]
    scenario = load_scenario(resolve_scene("fig2_dry"))
    arrays = [np.full(3, float(i)) for i in range(8)]  # time, X, V, x, v, F, f, stuck
    sim = SimulationResult(scenario, *arrays, True, "completed")
    assert sim.scenario is scenario and sim.f is arrays[6] and sim.stuck is arrays[7]
    assert (sim.ok, sim.message, sim.stats, sim.points, sim.inputs) == (True, "completed", {}, [], {})
    ref = ReferenceResult(*arrays[:7], 0.5)
    assert ref.time is arrays[0] and ref.f is arrays[6] and ref.wall_time == 0.5
    assert (ref.ok, ref.message, ref.T, ref.n) == (True, "", None, None)
