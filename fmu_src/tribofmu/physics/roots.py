"""The one bracketed root finder of the project (Illinois regula falsi), pure Python.

Hand-written rather than scipy's brentq so that the physics shipped inside the FMUs runs
in any host Python that has only the standard library; the tests check it against brentq.
Used by the lubricant kinetics (backward Euler) and by the master's implicit coupling.
"""
from __future__ import annotations


def illinois(fun, lo: float, hi: float, f_lo: float | None = None, f_hi: float | None = None,
             xtol: float = 1e-15, rtol: float = 1e-14, ftol: float = 0.0,
             max_iterations: int = 200) -> float:
    """Root of fun on the bracket [lo, hi] (fun changes sign between them).

    f_lo, f_hi: fun's values at lo and hi when the caller has them already (saves calls).
    Stops when |fun(x)| <= ftol, or the bracket is narrower than xtol + rtol |x|; after
    max_iterations returns the bracket's midpoint.
    """
    f_lo = fun(lo) if f_lo is None else f_lo
    f_hi = fun(hi) if f_hi is None else f_hi
    if f_hi == 0.0:
        return hi
    if f_lo == 0.0:
        return lo
    side = 0
    for _ in range(max_iterations):
        if f_hi == f_lo:  # no sign change left to interpolate (only a non-monotone fun)
            break
        x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        fx = fun(x)
        if fx == 0.0 or abs(fx) <= ftol:
            return x
        if (fx > 0.0) == (f_lo > 0.0):
            lo, f_lo = x, fx
            if side == -1:  # the same end twice: halve the other's weight (Illinois)
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = x, fx
            if side == 1:
                f_lo *= 0.5
            side = 1
        if abs(hi - lo) <= xtol + rtol * abs(x):
            return x
    return 0.5 * (lo + hi)
