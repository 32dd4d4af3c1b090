"""Physics of the seed paper with no FMI inside: friction laws, lubricant kinetics, block, drive."""
from .block import BlockState, acceleration, advance_block, block_problems, energy
from .drive import drive, drive_problems
from .friction import Effects, FrictionLaw, LubricantConstants, sign
from .laws import LAWS, BoundaryLaw, DryLaw, FluidLaw, MixedLaw, law_class, make_law

__all__ = ["BlockState", "acceleration", "advance_block", "block_problems", "energy", "drive",
           "drive_problems", "Effects", "FrictionLaw", "LubricantConstants", "sign",
           "LAWS", "BoundaryLaw", "DryLaw", "FluidLaw", "MixedLaw", "law_class", "make_law"]
