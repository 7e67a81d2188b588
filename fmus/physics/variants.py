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
        if not hasattr(first, name):     # an attribute of another structure (mechanism, fidelity) than this one
            continue
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

    @classmethod
    def key(cls, model) -> tuple:
        """What must be the same in every variant this form steps at once, beyond the structure (a law built from
        real parameters, a linkage's kind): variants of different keys are stepped as separate batches
        (:class:`Split`).  Default: nothing."""
        return ()

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


def last_call(fn):
    """:func:`fmus.physics.base.last_call` for arrays over variants: a call with arguments equal, element by element,
    to the previous call's returns the previous result (a master reads a component's outputs twice at one
    communication point, before and after an input that does not move the memoised geometry is set)."""
    memo: list = [None, None]

    def call(*args):
        last = memo[0]
        if last is None or len(last) != len(args) or not all(
                a is b or (np.shape(a) == np.shape(b) and np.array_equal(a, b)) for a, b in zip(args, last)):
            memo[0], memo[1] = tuple(np.array(a, copy=True) if isinstance(a, np.ndarray) else a for a in args), fn(*args)
        return memo[1]
    return call


class Split(Variants):
    """Variants in sub-batches of one :meth:`Vectorised.key` each, stepped one sub-batch after the other; the states,
    inputs and outputs stay in the variants' order."""

    def __init__(self, models, parts: list[tuple[np.ndarray, Variants]] | None = None):
        super().__init__(models)
        if parts is None:
            form = type(self.models[0]).Batch
            keys: dict = {}
            for i, m in enumerate(self.models):
                keys.setdefault(form.key(m), []).append(i)
            parts = [(np.array(idx, dtype=np.intp), _formed([self.models[i] for i in idx], form))
                     for idx in keys.values()]
        self.parts = parts

    def initial_state(self, U):
        return self._each(lambda b, cols: b.initial_state(U[:, cols]), len(self.cls.states))

    def output(self, t, X, U, rows=None):
        return self._each(lambda b, cols: b.output(t, X[:, cols], U[:, cols], rows), len(self.cls.outputs))

    def advance(self, t0, h, X, U):
        return self._each(lambda b, cols: b.advance(t0, h, X[:, cols], U[:, cols]), X.shape[0])

    def _each(self, f, rows: int) -> np.ndarray:
        out = np.zeros((rows, self.n))
        for cols, b in self.parts:
            out[:, cols] = f(b, cols)
        return out

    def take(self, keep):
        where = np.full(self.n, -1)
        where[keep] = np.arange(len(keep))
        parts = []
        for cols, b in self.parts:
            mine = np.flatnonzero(where[cols] >= 0)
            if mine.size:
                parts.append((where[cols[mine]], b.take(mine)))
        return Split([self.models[i] for i in keep], parts)


def _formed(models, form) -> Variants:
    return form(models) if form.refuses(models) is None else ScalarLoop(models)


def batch_of(models: Sequence[Model], vectorise: bool = True) -> Variants:
    """The batch of ``models`` (one class, one structure): the class's vectorised form where it takes them
    (``vectorise``; split by its :meth:`Vectorised.key` where the variants differ in it), else :class:`ScalarLoop`."""
    cls = type(models[0])
    form = getattr(cls, "Batch", None) if vectorise else None
    if form is None:
        return ScalarLoop(models)
    if len({form.key(m) for m in models}) > 1:
        return Split(models)
    return _formed(models, form)


def finite_columns(X: np.ndarray) -> np.ndarray:
    """Per variant (column): every state finite."""
    return np.isfinite(X).all(axis=0) if X.size else np.ones(X.shape[1], dtype=bool)


__all__ = ["Variants", "ScalarLoop", "Vectorised", "Split", "view_of", "batch_of", "structure", "last_call",
           "finite_columns", "math"]
