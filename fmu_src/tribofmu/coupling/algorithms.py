"""Coupling algorithms: small classes behind one interface, chosen by name from a registry.

An algorithm advances the coupled system from one communication point and returns the new
points (one per accepted communication step; none if it rejected and rolled back).

- ``jacobi``: fixed step; every slave steps with the others' outputs from the start of the
  step (the explicit baseline every co-simulation tool offers).
- ``gauss-seidel``: fixed step; drive, block, friction step in turn, each with the freshest
  outputs of the ones before.
- ``implicit``: fixed step; iterates with rollback until the force the block felt and the
  friction at the resulting relative velocity agree. The loop dv -> F -> dv is monotone, so
  the agreement is a root of a monotone scalar function; where it sits on the jump of a
  discontinuous law (dry friction at dv = 0) the blocks are stuck and the force is the one
  that keeps dv = 0. Stick is resolved exactly without telling the friction FMU anything
  about the block.
- ``adaptive``: the implicit step under error control, one solve per step: an embedded
  estimate (the coupling force predicted from the last steps against the one the solve
  found) rejects and retries steps that miss the tolerance, so steps shrink at stick/slip
  transitions and melting, grow elsewhere (coupling/embedded.py).

The classes live below this module, one role each: base.py (the interface, the explicit
couplings), implicit.py, controlled.py (what error control shares), embedded.py. (The
step-doubling coupling of before issue 31 is benchmarks/doubling.py's.)
"""
from __future__ import annotations

from .base import Counters, CouplingAlgorithm, ExplicitCoupling, Magnitudes, Scales
from .controlled import ErrorControlledCoupling, grazing_crossing
from .embedded import EmbeddedCoupling as AdaptiveCoupling
from .implicit import ImplicitCoupling

__all__ = ["ALGORITHMS", "AdaptiveCoupling", "Counters", "CouplingAlgorithm", "ErrorControlledCoupling",
           "ExplicitCoupling", "ImplicitCoupling", "Magnitudes", "Scales", "grazing_crossing", "make_algorithm"]

ALGORITHMS = {
    "jacobi": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=False),
    "gauss-seidel": lambda step=None, tol=None: ExplicitCoupling(step, tol, sequential=True),
    "implicit": ImplicitCoupling,
    "adaptive": AdaptiveCoupling,
}


def make_algorithm(name: str, step: float | None = None, tol: float | None = None) -> CouplingAlgorithm:
    """The algorithm registered under name; raises ValueError naming the known ones."""
    try:
        factory = ALGORITHMS[name]
    except KeyError:
        raise ValueError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})") from None
    return factory(step=step, tol=tol)
