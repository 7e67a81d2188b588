"""Brent's root finder on a bracket, step for step the one SciPy ships (``scipy.optimize.brentq``, its C
``brentq``: the same inverse quadratic interpolation, bisection and stopping test, so the same floats, which
tests/test_roots.py checks against SciPy on many brackets).  Here so that loading a drive whose parameters come
from a root (the bed drive's four-bar strokes) does not import ``scipy.optimize``, about 0.8 s CPU of the
run command.  Pure Python floats; no FMI import.
"""
from __future__ import annotations

import math


def brentq(f, a: float, b: float, xtol: float = 2e-12, rtol: float = 8.881784197001252e-16,
           maxiter: int = 100) -> float:
    """A root of ``f`` in [a, b] (f(a) and f(b) of opposite signs), to ``xtol + rtol * |x|``."""
    if xtol <= 0.0 or rtol < 4 * 2.220446049250313e-16:
        raise ValueError(f"xtol = {xtol!r} must be > 0 and rtol = {rtol!r} >= 4 * machine epsilon")
    xpre, xcur = float(a), float(b)
    xblk = fblk = spre = scur = 0.0
    fpre, fcur = float(f(xpre)), float(f(xcur))
    if math.isnan(fpre) or math.isnan(fcur):
        raise ValueError("the function is NaN at an end of the bracket")
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError(f"f({a!r}) and f({b!r}) must have opposite signs")
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:                                   # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:                                              # extrapolate (inverse quadratic)
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry                        # a good short step
            else:
                spre = scur = sbis                             # bisect
        else:
            spre = scur = sbis                                 # bisect
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = float(f(xcur))
        if math.isnan(fcur):
            raise ValueError(f"the function is NaN at {xcur!r}")
    raise RuntimeError(f"no convergence in {maxiter} iterations (last x = {xcur!r})")
