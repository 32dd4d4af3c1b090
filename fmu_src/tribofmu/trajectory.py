"""What every solution of a scene holds: the two blocks' motion and the friction between them,
sampled on one time grid. :class:`tribofmu.api.SimulationResult` (the co-simulation) and
:class:`tribofmu.studies.reference.ReferenceResult` (the monolithic yardstick) both derive from
:class:`SampledTrajectory`, so the signals a study compares are declared once, here."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SampledTrajectory:
    """time [s]; X [m], V [m/s] the upper block (the drive; zeros when the scene has none);
    x [m], v [m/s] the lower block; F [N] the friction force on the lower block; f [1] the
    lubricant's excess volume (0 for dry and fluid friction). One value per time."""

    time: np.ndarray
    X: np.ndarray
    V: np.ndarray
    x: np.ndarray
    v: np.ndarray
    F: np.ndarray
    f: np.ndarray
