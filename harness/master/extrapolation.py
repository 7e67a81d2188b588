"""Input extrapolation: the value an FMU holds on an input over a communication step.

FMI 2.0 FMUs without ``canInterpolateInputs`` hold each input constant over ``[t, t+h]``.  The constant
that minimises the coupling error is the source signal's value at the step MIDPOINT, not at its start: the
held value then matches the signal's mean over the step to O(h^2), so the global coupling error is of order 2
instead of 1.  So, for polynomial order ``k``:

* ``k = 0`` (zero-order hold): the newest known sample of the source (time t for Jacobi; time t+h for a
  source that Gauss-Seidel has already stepped);
* ``k >= 1``: the polynomial of degree ``k`` through the newest ``k+1`` samples, evaluated at ``t + h/2``
  (extrapolation for Jacobi; interpolation where the newest sample is already at t+h);
* an FMU that declares ``canInterpolateInputs`` receives the polynomial's value at the step START and its
  derivatives there (fmi2SetRealInputDerivatives, orders 1..k), so it can follow the polynomial itself.

Until ``k+1`` samples exist (the first steps) the degree drops to what the samples allow.
"""
from __future__ import annotations

import numpy as np

from harness.errors import SystemDescriptionError

DEPTH = 3  # samples kept per signal (enough for degree 2)


class History:
    """The last ``depth`` (at most :data:`DEPTH`) samples (time, value) of each coupling signal; row 0 is the
    newest.

    Samples are pushed per instance (a slice of the signal vector), because Gauss-Seidel advances instances
    one after the other; pushing again at the newest time overwrites that sample (iterations of a step)."""

    __slots__ = ("t", "y", "n", "depth", "_newest", "_full")

    def __init__(self, n_signals: int, depth: int = DEPTH):
        if not 1 <= depth <= DEPTH:
            raise ValueError(f"history depth {depth!r} must be 1 to {DEPTH}")
        self.depth = depth                  # samples kept (a master that needs the newest only keeps 1)
        self.t = np.zeros((DEPTH, n_signals))
        self.y = np.zeros((DEPTH, n_signals))
        self.n = np.zeros(n_signals, dtype=np.int64)
        self._newest: float | None = None   # time of the newest sample when it is the same for every signal
        self._full = False                  # every signal holds ``depth`` samples

    @property
    def full(self) -> bool:
        """Every signal holds ``depth`` samples (kept by :meth:`push_all` and :meth:`copy_from`; :meth:`push`
        leaves it as it was, so it may read False for a while after every signal has filled up, never True early)."""
        return self._full

    @property
    def newest(self) -> float | None:
        """Time of the newest sample when every signal's newest sample has that time, else None."""
        return self._newest

    def push(self, sl: slice, t: float, values: np.ndarray) -> None:
        if sl.stop == sl.start:
            return
        self._newest = None
        if self.n[sl.start] > 0 and self.t[0, sl.start] == t:
            self.y[0, sl] = values
            return
        d = self.depth
        if d > 1:
            self.t[1:d, sl] = self.t[:d - 1, sl]
            self.y[1:d, sl] = self.y[:d - 1, sl]
        self.t[0, sl] = t
        self.y[0, sl] = values
        np.minimum(self.n[sl] + 1, d, out=self.n[sl])

    def push_all(self, t: float, values: np.ndarray) -> None:
        """:meth:`push` of every signal at once (the same result as pushing each instance's slice)."""
        if self._newest is not None:  # the newest samples share one time (Jacobi family): no search
            if self._newest == t:
                self.y[0] = values
                return
            self._shift()
            self.t[0] = t
            self.y[0] = values
            if not self._full:
                self._count()
            self._newest = t
            return
        same = self.t[0] == t
        same &= self.n > 0
        if same.all():
            self.y[0] = values
        elif same.any():  # some signals already hold a sample at t (Gauss-Seidel): overwrite those only
            for k in np.flatnonzero(~same):
                self.push(slice(k, k + 1), t, values[k:k + 1])
            self.y[0, same] = values[same]
            self._full = bool(self.n.min() == self.depth)
        else:
            self._shift()
            self.t[0] = t
            self.y[0] = values
            self._count()
        self._newest = t

    def _shift(self) -> None:
        d = self.depth
        if d > 1:
            self.t[1:d] = self.t[:d - 1]
            self.y[1:d] = self.y[:d - 1]

    def _count(self) -> None:
        np.minimum(self.n + 1, self.depth, out=self.n)
        self._full = bool(self.n.size == 0 or self.n.min() == self.depth)

    def restart(self) -> None:
        """Keep only the newest sample of every signal: an event (an input's step) lies behind it, so the
        extrapolation starts again from there (order 0, then rising as samples come) instead of reaching
        across the event."""
        np.minimum(self.n, 1, out=self.n)
        self._full = bool(self.n.size == 0 or self.n.min() == self.depth)

    def copy_from(self, other: "History") -> None:
        self.t[:] = other.t
        self.y[:] = other.y
        self.n[:] = other.n
        self._newest, self._full = other._newest, other._full

    def snapshot(self) -> "History":
        h = History(self.t.shape[1], self.depth)
        h.copy_from(self)
        return h


class Polynomial:
    """Extrapolation of polynomial order ``order`` (0, 1 or 2).  ``uses_midpoint`` is True for order >= 1."""

    name = "polynomial"

    def __init__(self, order: int):
        if order not in (0, 1, 2):
            raise SystemDescriptionError(f"extrapolation = {order!r} is not admissible: must be 0, 1 or 2")
        self.order = order
        self.uses_midpoint = order >= 1

    def __repr__(self) -> str:
        return f"Polynomial({self.order})"

    def _coefficients(self, hist: History, idx: np.ndarray, te: float):
        """Weights w (3 x len(idx)) with p(te) = sum w * y, and dw, ddw for p', p''."""
        t0, t1, t2 = hist.t[0, idx], hist.t[1, idx], hist.t[2, idx]
        k = np.minimum(self.order, hist.n[idx] - 1)
        m = len(idx)
        w = np.zeros((3, m))
        dw = np.zeros((3, m))
        ddw = np.zeros((3, m))
        w[0] = 1.0
        lin = k == 1
        if lin.any():
            d = np.where(lin, t0 - t1, 1.0)
            a = (te - t0) / d
            w[0] = np.where(lin, 1.0 + a, w[0])
            w[1] = np.where(lin, -a, w[1])
            dw[0] = np.where(lin, 1.0 / d, 0.0)
            dw[1] = np.where(lin, -1.0 / d, 0.0)
        quad = k == 2
        if quad.any():
            d0 = np.where(quad, (t0 - t1) * (t0 - t2), 1.0)
            d1 = np.where(quad, (t1 - t0) * (t1 - t2), 1.0)
            d2 = np.where(quad, (t2 - t0) * (t2 - t1), 1.0)
            for j, (ta, tb, dj) in enumerate(((t1, t2, d0), (t0, t2, d1), (t0, t1, d2))):
                w[j] = np.where(quad, (te - ta) * (te - tb) / dj, w[j])
                dw[j] = np.where(quad, ((te - ta) + (te - tb)) / dj, dw[j])
                ddw[j] = np.where(quad, 2.0 / dj, ddw[j])
        return w, dw, ddw

    def held(self, hist: History, idx: np.ndarray, t: float, h: float) -> np.ndarray:
        """The constant to hold on the inputs fed by signals ``idx`` over ``[t, t+h]``."""
        if self.order == 0:
            return hist.y[0, idx]
        te = t + 0.5 * h
        if hist.n[idx].min() > self.order:  # fast path: every signal has its full set of samples
            y, ts = hist.y[:, idx], hist.t[:, idx]
            if self.order == 1:
                return y[0] + (te - ts[0]) / (ts[0] - ts[1]) * (y[0] - y[1])
            a, b, c = te - ts[0], te - ts[1], te - ts[2]
            return (y[0] * b * c / ((ts[0] - ts[1]) * (ts[0] - ts[2]))
                    + y[1] * a * c / ((ts[1] - ts[0]) * (ts[1] - ts[2]))
                    + y[2] * a * b / ((ts[2] - ts[0]) * (ts[2] - ts[1])))
        w, _, _ = self._coefficients(hist, idx, te)
        return np.einsum("ij,ij->j", w, hist.y[:, idx])

    def value(self, hist: History, idx: np.ndarray, te: float) -> np.ndarray:
        """The polynomial through the newest samples at the point ``te`` (the newest sample itself if it is at
        ``te``, whatever the order)."""
        if self.order == 0:
            return hist.y[0, idx]
        w, _, _ = self._coefficients(hist, idx, te)
        return np.einsum("ij,ij->j", w, hist.y[:, idx])

    def at_start(self, hist: History, idx: np.ndarray, t: float) -> tuple[np.ndarray, list[np.ndarray]]:
        """Value and derivatives (orders 1..order) of the polynomial at the step start ``t`` (for FMUs that
        can interpolate inputs)."""
        w, dw, ddw = self._coefficients(hist, idx, t)
        y = hist.y[:, idx]
        value = np.einsum("ij,ij->j", w, y)
        ders = [np.einsum("ij,ij->j", dw, y), np.einsum("ij,ij->j", ddw, y)][: self.order]
        return value, ders


EXTRAPOLATIONS = {"hold": 0, "zoh": 0, "linear": 1, "quadratic": 2}


def extrapolation(spec) -> Polynomial:
    """An extrapolation strategy from an order (0, 1, 2), a name (hold/zoh, linear, quadratic) or itself."""
    if isinstance(spec, Polynomial):
        return spec
    if spec is None:
        return Polynomial(0)
    if isinstance(spec, str):
        key = spec.strip().lower()
        if key in EXTRAPOLATIONS:
            return Polynomial(EXTRAPOLATIONS[key])
        if key.isdigit():
            return Polynomial(int(key))
        raise SystemDescriptionError(f"extrapolation = {spec!r} is not admissible: use 0, 1, 2 or one of "
                                     f"{', '.join(EXTRAPOLATIONS)}")
    if isinstance(spec, bool) or not isinstance(spec, int):
        raise SystemDescriptionError(f"extrapolation = {spec!r} is not admissible: must be 0, 1 or 2")
    return Polynomial(spec)
