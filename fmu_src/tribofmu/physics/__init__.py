"""Physics of the seed paper with no FMI inside: friction laws, lubricant kinetics, block, drive."""
from .block import BlockState, acceleration, advance_block, block_problems, energy
from .drive import drive, drive_problems
from .friction import (BOUNDARY, DRY, FLUID, REGIME_NAMES, REGIMES, Effects, FrictionLaw,
                       LubricantConstants, sign)

__all__ = ["BlockState", "acceleration", "advance_block", "block_problems", "energy", "drive",
           "drive_problems", "BOUNDARY", "DRY", "FLUID", "REGIME_NAMES", "REGIMES", "Effects",
           "FrictionLaw", "LubricantConstants", "sign"]
