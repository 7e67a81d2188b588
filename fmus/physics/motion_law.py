"""A law of periodic motion as data: pieces of (a, b, c) over the normalised phase k in [0, 1].

Kept apart from the registry of named laws (fmus.physics.laws) so that a module which builds a law of its own
(fmus.physics.bed_law's carrier law) needs only this class and the registry may list that law: the import
graph of fmus.physics stays without a circle (tests/test_physics_imports.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .mathns import NUMPY, SCALAR, namespace

PieceFn = Callable[[object, object], tuple]


def _full(v, shape):
    """``v`` (a piece's array, or a number it returns for every k) as a fresh array of ``shape`` (v times 1.0: the
    same numbers)."""
    if isinstance(v, np.ndarray) and v.shape == shape:
        return v * 1.0
    return np.broadcast_to(v, shape) * 1.0


@dataclass(frozen=True)
class Law:
    """A law of periodic motion: pieces ``(k_end, f)`` with ``f(k, m) -> (a, b, c)`` on [k_start, k_end].

    ``jerks``, when given, holds one function ``j(k, m) -> dc/dk`` per piece, written beside the piece's own
    equation (its acceleration invariant differentiated once more): the slopes of a component's outputs in the
    crank angle (its directional derivatives) need it where an output holds c."""
    name: str
    doc: str
    pieces: tuple[tuple[float, PieceFn], ...]
    params: tuple[tuple[str, float], ...] = ()
    jerks: tuple[Callable[[object, object], object], ...] = ()

    def at(self, k, m=None):
        """(a, b, c) at the phase share(s) ``k``, clipped to [0, 1]: ``m`` the namespace (mathns.namespace: ``math``
        or SCALAR for one float, numpy (the default) or NUMPY for an array, VECTOR for a batch of variants).  Each
        k takes the first piece whose end lies beyond it (the last piece up to and with 1); a piece is evaluated
        on its own k only.  The clip is numpy's for NUMPY, Python's comparisons otherwise (a batch's elements are
        one float's)."""
        m = m if m is SCALAR else namespace(m)
        if m.scalar:
            k = 0.0 if k < 0.0 else (1.0 if k > 1.0 else k)
            for end, f in self.pieces:
                if k < end:
                    return f(k, m)
            return self.pieces[-1][1](k, m)
        k = np.asarray(k, dtype=float)
        k = np.clip(k, 0.0, 1.0) if m is NUMPY else np.where(k < 0.0, 0.0, np.where(k > 1.0, 1.0, k))
        if len(self.pieces) == 1:
            return tuple(_full(v, k.shape) for v in self.pieces[0][1](k, m))
        a = np.empty_like(k)
        b = np.empty_like(k)
        c = np.empty_like(k)
        start = 0.0
        for i, (end, f) in enumerate(self.pieces):
            last = i == len(self.pieces) - 1
            mask = (k >= start) & ((k <= end) if last else (k < end))
            if np.any(mask):
                pa, pb, pc = f(k[mask], m)
                a[mask], b[mask], c[mask] = pa, pb, pc
            start = end
        return a, b, c

    __call__ = at   # also law(k, m); hot paths call .at (calling an instance costs ~100 ns more)

    def jerk(self, k: float) -> float:
        """dc/dk at one k, from the piece :meth:`at` takes there (at a junction, the piece on its right, as
        scalar's); 0 outside [0, 1], where scalar clips k (a, b, c held constant)."""
        if not self.jerks:
            raise ValueError(f"law {self.name!r} gives no jerk (dc/dk): its pieces have no derivative of c")
        if k < 0.0 or k > 1.0:
            return 0.0
        for (end, _), j in zip(self.pieces, self.jerks):
            if k < end:
                return j(k, math)
        return self.jerks[-1](k, math)

    def coefficients(self, n: int = 20001) -> tuple[float, float]:
        """(C_v, C_a) = (max|b|, max|c|) on a grid of n points."""
        _, b, c = self(np.linspace(0.0, 1.0, n))
        return float(np.max(np.abs(b))), float(np.max(np.abs(c)))
