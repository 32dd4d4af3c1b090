"""Physics of the seed paper with no FMI inside: friction laws, lubricant kinetics, block, drive."""
from .block import BlockParams, BlockState, acceleration, advance_block, energy
from .drive import DriveParams, drive
from .friction import Effects, FrictionLaw, LubricantConstants, sign
from .laws import LAWS, BoundaryLaw, DryLaw, FluidLaw, MixedLaw, law_class, make_law

__all__ = ["BlockParams", "BlockState", "acceleration", "advance_block", "energy", "DriveParams", "drive",
           "Effects", "FrictionLaw", "LubricantConstants", "sign",
           "LAWS", "BoundaryLaw", "DryLaw", "FluidLaw", "MixedLaw", "law_class", "make_law"]
