"""N variants of one component model stepped together: :class:`Variants`, the batch form of
:class:`fmus.physics.base.Model`.

A batch holds one scalar model per variant (built and validated as its FMU builds it) and steps them all at once:
states ``X`` (states x variants), inputs ``U`` (inputs x variants), outputs (outputs x variants).  Two ways:

* :class:`ScalarLoop` (every model): each variant's own scalar model, called in turn.  The same numbers as the
  variant's FMU by construction; it saves the FMU and master machinery around the model, not the model's cost.
* a model's vectorised batch (``Model.Batch``, a subclass of :class:`Vectorised`): the model's own equations called
  once on arrays over the variants.  The equations are the scalar model's methods, called on a :class:`View` whose
  attributes (parameters, derived constants) are arrays and whose math namespace ``m`` is
  :data:`fmus.physics.mathns.VECTOR` (the same bits as ``math`` per element), so one variant of the batch computes
  what its FMU computes, bit for bit; branches on a state or an input are ``m.where``, a variant whose step takes
  a path the vector form does not follow (a brake that engages, a contact event) is handed to its own scalar model
  for that step (:meth:`Vectorised.by_scalar`).

Integer parameters (fidelity, law, mechanism, branch) are the same in every variant of a batch: a harness splits
variants into batches by them (:func:`structure`), so a vectorised form branches on them as the scalar one does.
"""
from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Sequence

import numpy as np

from .base import Model
from .mathns import VECTOR


def structure(model: Model) -> tuple:
    """The integer parameters of a model (its structure): variants differing in them go to separate batches."""
    return tuple((s.name, getattr(model.p, s.name)) for s in model.Params.specs() if s.is_integer)


class Variants:
    """The batch interface: ``models`` (one validated scalar model per variant, all of one class and structure)."""

    def __init__(self, models: Sequence[Model]):
        self.models = list(models)
        self.n = len(self.models)
        self.cls = type(self.models[0])

    @classmethod
    def refuses(cls, models: Sequence[Model]) -> str | None:
        """Why this form cannot step these variants (None: it can)."""
        return None

    def initial_state(self, U: np.ndarray) -> np.ndarray:
        """States x variants at the start, for inputs ``U`` (inputs x variants)."""
        return np.stack([np.asarray(m.initial_state(U[:, i].tolist()), dtype=float)
                         for i, m in enumerate(self.models)], axis=1).reshape(len(self.cls.states), self.n)

    def output(self, t: float, X: np.ndarray, U: np.ndarray, rows: Sequence[int] | None = None) -> np.ndarray:
        """Outputs x variants (``rows``: the outputs wanted, in the model's order; the others are 0)."""
        raise NotImplementedError

    def advance(self, t0: float, h: float, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """States x variants at t0 + h."""
        raise NotImplementedError

    def take(self, keep: np.ndarray) -> "Variants":
        """The batch of the variants ``keep`` (indices), in that order."""
        return type(self)([self.models[i] for i in keep])


class ScalarLoop(Variants):
    """Each variant's own scalar model in turn (module docstring): what every model can do."""

    def output(self, t, X, U, rows=None):
        Y = np.zeros((len(self.cls.outputs), self.n))
        Us = U.T.tolist()
        for i, m in enumerate(self.models):
            Y[:, i] = _called(m.output, t, X[:, i].copy(), Us[i])
        return Y

    def advance(self, t0, h, X, U):
        out = np.empty_like(X)
        Us = U.T.tolist()
        for i, m in enumerate(self.models):
            out[:, i] = _called(m.advance, t0, h, X[:, i].copy(), Us[i])
        return out


def _called(f, *args):
    """``f(*args)`` of one variant's scalar model; NaN where it raises (its FMU's call would fail: the batch
    fails that variant, found by its check of states and outputs, and the others go on)."""
    try:
        return f(*args)
    except Exception:   # noqa: BLE001 (the variant fails; an FMU call of its own would have)
        return math.nan


def view_of(models: Sequence[Model], names: Sequence[str] = ()) -> Model:
    """A view of ``models``: an instance of their class, not built by its ``__init__``, whose ``p`` holds every
    parameter (integers as the one value all variants share, reals as arrays over the variants), whose ``m`` is
    :data:`~fmus.physics.mathns.VECTOR`, and whose attributes ``names`` hold each variant's value (numbers as
    arrays; anything else must be the same in every variant and is kept as it is).  The class's own methods then
    compute every variant at once (module docstring)."""
    first = models[0]
    params = {}
    for spec in first.Params.specs():
        values = [getattr(m.p, spec.name) for m in models]
        params[spec.name] = values[0] if spec.is_integer else np.array(values, dtype=float)
    v = object.__new__(type(first))
    v.p, v.m, v.n, v.p_scalar = SimpleNamespace(**params), VECTOR, len(models), first.p
    for name in names:
        values = [getattr(m, name) for m in models]
        if isinstance(values[0], (float, int)) and not isinstance(values[0], bool):
            setattr(v, name, np.array(values, dtype=float))
        else:
            setattr(v, name, values[0])
    return v


class Vectorised(Variants):
    """A model's equations on arrays over the variants (module docstring).  A subclass names the attributes its
    methods read (``attributes``, besides ``p`` and ``max_substep``) and implements :meth:`output` and
    :meth:`advance` by calling the model's own methods on ``self.v`` (:func:`view_of`; ``v.p_scalar`` is the first
    variant's parameters, for the integers)."""

    attributes: tuple[str, ...] = ()

    def __init__(self, models):
        super().__init__(models)
        self.v = view_of(self.models, ("max_substep",) + tuple(self.attributes))

    def by_scalar(self, which: np.ndarray, t0: float, h: float, X: np.ndarray, U: np.ndarray,
                  out: np.ndarray) -> np.ndarray:
        """``out`` with the variants ``which`` (a mask) advanced by their own scalar models instead."""
        idx = np.flatnonzero(which)
        if idx.size:
            Us = U[:, idx].T.tolist()
            for k, i in enumerate(idx.tolist()):
                out[:, i] = _called(self.models[i].advance, t0, h, X[:, i].copy(), Us[k])
        return out


def substeps(h: float, max_substep: np.ndarray) -> np.ndarray:
    """:func:`fmus.physics.integrate.substeps` of each variant (its own ``max_substep``), as floats."""
    with np.errstate(divide="ignore", invalid="ignore"):
        n = np.ceil(h / max_substep * (1.0 - 1e-12))
    return np.maximum(1.0, np.where(np.isfinite(max_substep), n, 1.0))


def rk4_pairs(acc, t0: float, h: float, max_substep: np.ndarray, q: np.ndarray, v: np.ndarray):
    """:func:`fmus.physics.integrate.rk4_pairs` of every variant on its own sub-steps (``n`` of each from its own
    ``max_substep``): the same sub-step times t0 + i h/n and numbers, a variant with fewer sub-steps held after
    its last (the step of the largest count is taken by all, the others keep their values)."""
    from .integrate import rk4_pair

    n = substeps(h, max_substep)
    top = int(n.max())
    if top == 1:
        return rk4_pair(acc, t0 + 0 * (h / n), h / n, q, v)
    dt = h / n
    for i in range(top):
        q1, v1 = rk4_pair(acc, t0 + i * dt, dt, q, v)
        if i >= int(n.min()):
            live = i < n
            q1, v1 = np.where(live, q1, q), np.where(live, v1, v)
        q, v = q1, v1
    return q, v


def rk4(f, t0: float, h: float, x: np.ndarray, u, max_substep: np.ndarray) -> np.ndarray:
    """:func:`fmus.physics.integrate.rk4` of every variant (states x variants) on its own sub-steps, as
    :func:`rk4_pairs` takes them."""
    n = substeps(h, max_substep)
    top = int(n.max())
    dt = h / n
    for i in range(top):
        t = t0 + i * dt
        k1 = f(t, x, u, t0)
        k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1, u, t0)
        k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2, u, t0)
        k4 = f(t + dt, x + dt * k3, u, t0)
        x1 = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x = np.where(i < n, x1, x) if i >= int(n.min()) else x1
    return x


def batch_of(models: Sequence[Model], vectorise: bool = True) -> Variants:
    """The batch of ``models`` (one class, one structure): the class's vectorised form where it takes them
    (``vectorise``), else :class:`ScalarLoop`."""
    cls = type(models[0])
    form = getattr(cls, "Batch", None) if vectorise else None
    if form is not None and form.refuses(models) is None:
        return form(models)
    return ScalarLoop(models)


def finite_columns(X: np.ndarray) -> np.ndarray:
    """Per variant (column): every state finite."""
    return np.isfinite(X).all(axis=0) if X.size else np.ones(X.shape[1], dtype=bool)


__all__ = ["Variants", "ScalarLoop", "Vectorised", "view_of", "batch_of", "structure", "rk4", "rk4_pairs",
           "substeps", "finite_columns", "math"]
