"""Operating points inside the ranges the FMUs declare for their inputs: the components refuse an input outside its
declared min/max, so tests that drive inputs with made-up values fold each value into the inside of its range."""
from __future__ import annotations


def declared_range(variable) -> tuple[float | None, float | None]:
    """(min, max) of an FMPy model variable, None where it declares none."""
    lo, hi = getattr(variable, "min", None), getattr(variable, "max", None)
    return (None if lo is None else float(lo)), (None if hi is None else float(hi))


def fold(value: float, lo: float | None, hi: float | None) -> float:
    """``value`` where the range allows it, else mapped into the middle 80 % of [lo, hi] (an interval with room for
    a difference quotient's step on either side); a one-sided range is met by reflection at its bound."""
    value = float(value)
    if lo is not None and hi is not None:
        if lo <= value <= hi and (hi - lo) * 0.1 <= min(value - lo, hi - value):
            return value
        return lo + (hi - lo) * (0.1 + 0.8 * (((value - lo) / (hi - lo)) % 1.0))
    if lo is not None and value < lo:
        return 2.0 * lo - value
    if hi is not None and value > hi:
        return 2.0 * hi - value
    return value
