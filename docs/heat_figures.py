"""Figures of the heating and load scenes (docs/figures/), and the T x n rest-state map.

    PYTHONPATH=fmu_src python docs/heat_figures.py [build]

Runs the FMUs through the master (api.build_system) and the extended reference.
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from tribofmu.coupling.algorithms import Scales, make_algorithm
from tribofmu.coupling.interpolation import sample
from tribofmu.master import FMUInstance, run
from tribofmu.physics.friction import BOUNDARY, FrictionLaw
from tribofmu.scene.scenario import load_scenario, scales
from tribofmu.api import build_system
from tribofmu.scene.wiring import fmu_parameters, input_signals
from tribofmu.master.energy import heat_audit
from tribofmu.studies.reference import nrms, reference_solution

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "figures"


def cosimulate(scenario, fmu_dir):
    slaves = {n: FMUInstance(fmu_dir / f"{n}.fmu", instance=n.lower(), parameters=p)
              for n, p in fmu_parameters(scenario).items()}
    try:
        system = build_system(scenario, slaves)
        sim = scenario.simulation
        return run(system, make_algorithm(sim.algorithm, step=sim.step, tol=sim.tol),
                   scenario.stop_time, Scales(*scales(scenario)))
    finally:
        for s in slaves.values():
            s.close()


def heating(fmu_dir):
    sc = load_scenario(ROOT / "scenarios" / "boundary_heating.toml")
    out = cosimulate(sc, fmu_dir)
    ref = reference_solution(sc)
    sig, inp = sample(out.points, ref.time), input_signals(out.points, ref.time)
    steps_dT = np.diff([p.T for p in out.points])
    print(f"heating: wall {out.wall_time:.1f} s, steps {out.counters['steps']}, "
          f"nRMS(v) {nrms(ref.time, sig['v'], ref.time, ref.v, sc.window):.2e}, "
          f"nRMS(T - T0) {nrms(ref.time, inp['T'] - 290, ref.time, ref.T - 290, sc.window):.2e}, "
          f"T end {inp['T'][-1]:.3f} / ref {ref.T[-1]:.3f} K, largest T change in one step {steps_dT.max():.3f} K, "
          f"heat {heat_audit(out.points, sc)}")
    t = ref.time / sc.drive.period
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    ax[0].plot(t, inp["T"], label="co-simulation (Thermal FMU)")
    ax[0].plot(t, ref.T, "--", label="monolithic reference")
    ax[0].axhline(1160, color="gray", lw=0.8, ls=":")
    ax[0].text(0.02, 1180, "film stays molten at rest above ~1160 K", color="gray")
    ax[0].set_ylabel("T [K]")
    ax[0].legend(loc="lower right")
    ax[1].plot(t, sig["f"])
    ax[1].axhline(4.1 / 4.0, color="gray", lw=0.8, ls=":")
    ax[1].set_ylabel("f [1]")
    ax[1].set_yscale("symlog", linthresh=1.0)
    ax[2].plot(t, sig["V"] * 1e6, label="V (drive)")
    ax[2].plot(t, sig["v"] * 1e6, label="v (block)")
    ax[2].set_ylabel("velocity [um/s]")
    ax[2].set_xlabel("t / T_drive")
    ax[2].legend(loc="lower right")
    fig.suptitle(sc.title)
    fig.tight_layout()
    fig.savefig(OUT / "boundary_heating.png", dpi=110)


def load_scene(fmu_dir):
    sc = load_scenario(ROOT / "scenarios" / "dry_load_oscillation.toml")
    out = cosimulate(sc, fmu_dir)
    ref = reference_solution(sc)
    sig, inp = sample(out.points, ref.time), input_signals(out.points, ref.time)
    print(f"load: wall {out.wall_time:.2f} s, steps {out.counters['steps']}, "
          f"nRMS(v) {nrms(ref.time, sig['v'], ref.time, ref.v, sc.window):.2e}, "
          f"stuck for good {[(round(a, 3), round(b, 3)) for a, b in ref.stats['stick_intervals'] if b - a > 0.5]}")
    t = ref.time / sc.drive.period
    fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    ax[0].plot(t, -inp["n"] * sc.friction.S, label="L = -n S (Load FMU)")
    ax[0].axhline(53.8, color="gray", ls=":", label="L = A|2K - M w^2| / mu = 53.8 N")
    ax[0].set_ylabel("load [N]")
    ax[0].legend(loc="upper right")
    ax[1].plot(t, sig["V"], label="V (drive)", lw=0.8)
    ax[1].plot(t, sig["v"], label="v (block)", lw=0.8)
    ax[1].fill_between(t, -0.07, 0.07, where=sig["stuck"] > 0.5, color="orange", alpha=0.25, label="stuck")
    ax[1].set_ylabel("velocity [m/s]")
    ax[1].set_xlabel("t / T_drive")
    ax[1].legend(loc="upper right", ncol=3)
    fig.suptitle(sc.title)
    fig.tight_layout()
    fig.savefig(OUT / "dry_load_oscillation.png", dpi=110)


def regime_map():
    """f of the film at rest (dv = 0) under a slow temperature ramp up then down, per load:
    where the two sweeps differ, melting and solidification happen at different temperatures."""
    sc = load_scenario(ROOT / "scenarios" / "fig6_boundary.toml")
    law: FrictionLaw = sc.friction.law()
    assert law.regime == BOUNDARY
    T_up = np.arange(200.0, 1400.0, 2.0)
    loads = -np.logspace(4, np.log10(3e7), 40)  # Pa
    up, down = np.empty((loads.size, T_up.size)), np.empty((loads.size, T_up.size))
    for i, n in enumerate(loads):
        f = 0.0
        for j, T in enumerate(T_up):  # each temperature held 1 s: f settles (rates >= 1e3 1/s)
            f = law.advance_f(f, 0.0, n, T, 1.0)
            up[i, j] = f
        for j in range(T_up.size - 1, -1, -1):
            f = law.advance_f(f, 0.0, n, T_up[j], 1.0)
            down[i, j] = f
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    mesh = ax[0].pcolormesh(T_up, -loads, down - up, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax[0], label="f (cooling) - f (heating)")
    melt = lambda F: [T_up[np.argmax(row > 4.1 / 4.0)] if np.any(row > 4.1 / 4.0) else np.nan for row in F]
    ax[0].plot(melt(up), -loads, "w--", label="f > mu/mub (molten) at rest")
    ax[0].set_yscale("log")
    ax[0].set_xlabel("T [K]")
    ax[0].set_ylabel("-n [Pa]")
    ax[0].set_title("hysteresis band: T x n, film at rest")
    ax[0].legend(loc="lower right")
    k = int(np.argmin(np.abs(loads + 1e6)))
    ax[1].plot(T_up, up[k], label="heating")
    ax[1].plot(T_up, down[k], "--", label="cooling")
    ax[1].axhline(4.1 / 4.0, color="gray", ls=":")
    ax[1].set_xlabel("T [K]")
    ax[1].set_ylabel("f at rest [1]")
    ax[1].set_title(f"n = {loads[k]:.3g} Pa (Fig. 6's load)")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(OUT / "regime_map_T_n.png", dpi=110)
    band = [(T_up[np.argmax(np.abs(d - u) > 1e-3)], T_up[len(T_up) - 1 - np.argmax(np.abs(d - u)[::-1] > 1e-3)])
            if np.any(np.abs(d - u) > 1e-3) else None for d, u in zip(down, up)]
    print("hysteresis band at n=-1e6:", band[k], "melting at rest:", melt(up)[k], "K")
    print("band at lightest/heaviest load:", band[0], band[-1])


if __name__ == "__main__":
    fmu_dir = ROOT / (sys.argv[1] if len(sys.argv) > 1 else "build")
    OUT.mkdir(parents=True, exist_ok=True)
    regime_map()
    load_scene(fmu_dir)
    heating(fmu_dir)
