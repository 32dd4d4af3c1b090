"""The FMUs tribofmu builds, in the order they are built and listed: one adapter each,
``fmu/models/<name>.py``.

The build (:mod:`tribofmu.build`), the FMU cache and the CLI's ``build`` read this list; the
scene's wiring (:mod:`tribofmu.scene.wiring`) declares how a scene instantiates and connects
them, each by a name from here. No imports: the build reads it without loading the FMU
framework. To add an FMU: its adapter in ``fmu/models/``, its name here, and, for scenes,
its entry in the wiring.
"""
from __future__ import annotations

# The scene FMUs in the order scenes instantiate them, then the pair (BlockSpring and
# Friction in one FMU, for masters that couple explicitly).
FMU_NAMES: tuple[str, ...] = ("Drive", "BlockSpring", "Friction", "Thermal", "Load", "TriboPair")


def fmu_names() -> tuple[str, ...]:
    """Every FMU tribofmu builds (``tribofmu build``, the FMU cache); read when called, so an
    entry added to :data:`FMU_NAMES` is built too."""
    return FMU_NAMES
