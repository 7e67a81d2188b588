"""The math of one variant and of many: the namespaces the hot equations take their functions from.

An equation written once, ``def rate(m, x, ...)``, runs on plain floats with :data:`SCALAR` (``math``: an FMU's
one instance, one variant) and on arrays over variants with :data:`VECTOR` (a batch of variants stepped together,
:mod:`fmus.physics.variants`), giving the same bits for every variant.  Arithmetic (``+ - * /``) is the same IEEE
operation on a float and on an array element; the functions are not: numpy computes ``exp``, ``tanh``, ``acos``,
``atan2``, ``hypot`` and ``**`` by its own approximations (SIMD), which differ from ``math``'s in the last bit for
a few percent of the arguments.  So :data:`VECTOR` takes

* from numpy what is correctly rounded there as in ``math``: ``sqrt``, ``fabs``, ``copysign``, ``floor``, ``%``,
  and ``sin``/``cos`` where numpy computes them as ``math`` does (checked when first used, on a sample);
* libm's own function element by element for the rest: a compiled loop over the C library's functions (the ones
  ``math`` calls; :func:`install_loops`, given by :mod:`fmus.batch_libm`), else Python's ``math`` per element;
  ``hypot`` always the latter (CPython computes it by its own algorithm, not the C library's).

Every namespace has the same names: ``sqrt sin cos exp tanh acos atan2 hypot copysign fabs floor pow`` as in
``math`` (:data:`VECTOR` also ``chypot``: ``abs`` of a complex number, the C library's hypot), ``pi``, and what
branches need: ``where(c, a, b)`` (``a if c else b``), ``minimum``/``maximum`` (Python's ``min``/``max`` of two,
its semantics with NaN too).  :data:`NUMPY` is numpy itself under those names (the synthesis tools' array
evaluation, as they computed it before).  An FMU's step reads these names hundreds of times: :data:`SCALAR` is a
module object (read as fast as ``math``), a scalar path's branch is an ``if`` where a call of ``where`` would cost
more than the arithmetic it picks.
"""
from __future__ import annotations

import math
import operator
import types

import numpy as np


class Scalar:
    """``math`` for one float, with the branch helpers of the other namespaces."""
    scalar = True
    pi = math.pi
    sqrt, sin, cos, exp, tanh = math.sqrt, math.sin, math.cos, math.exp, math.tanh
    acos, atan2, hypot, copysign, fabs = math.acos, math.atan2, math.hypot, math.copysign, math.fabs
    minimum, maximum = min, max

    @staticmethod
    def floor(x):
        return float(math.floor(x))

    pow = operator.pow      # ``x ** y`` itself (the same C call), without a Python frame

    @staticmethod
    def where(c, a, b):
        return a if c else b

    stack = np.array        # a state or rate vector of these numbers


class Numpy:
    """numpy under the namespace's names: its own approximations (the array evaluations of the synthesis tools)."""
    scalar = False
    pi = np.pi
    sqrt, sin, cos, exp, tanh = np.sqrt, np.sin, np.cos, np.exp, np.tanh
    acos, atan2, hypot, copysign, fabs, floor = np.arccos, np.arctan2, np.hypot, np.copysign, np.abs, np.floor
    pow, where = np.power, staticmethod(np.where)
    minimum, maximum = np.minimum, np.maximum
    stack = staticmethod(np.array)


def _each(f):
    """``f`` of ``math`` element by element on arrays (scalars broadcast): math's bits at Python's speed."""
    def g(*args):
        arrays = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in args])
        if arrays[0].ndim == 0:
            return np.float64(f(*(float(a) for a in arrays)))
        out = np.fromiter(map(f, *(a.ravel().tolist() for a in arrays)), float, arrays[0].size)
        return out.reshape(arrays[0].shape)
    g.__name__ = f.__name__
    return g


def _safe(f):
    """``f`` with ``math``'s domain and range errors as NaN and inf (a failed variant, found by the batch's check of
    its state, not an exception that would stop every variant)."""
    def g(*args):
        try:
            return f(*args)
        except ValueError:
            return math.nan
        except OverflowError:
            return math.inf
    g.__name__ = f.__name__
    return g


def _pow(x, y):
    return x ** y


def _cabs(x, y):
    """``abs(complex(x, y))``: the C library's hypot (what CPython's complex abs calls)."""
    return abs(complex(x, y))


class Vector:
    """Arrays over variants with ``math``'s bits (module docstring).  The element-by-element functions are
    Python's until :func:`install_loops` gives compiled ones."""
    scalar = False
    pi = math.pi
    sqrt, copysign, fabs, floor = np.sqrt, np.copysign, np.abs, np.floor
    hypot = staticmethod(_each(_safe(math.hypot)))

    def __init__(self):
        self.loops = "python"
        for name, f in (("exp", math.exp), ("tanh", math.tanh), ("acos", math.acos), ("atan2", math.atan2),
                        ("pow", _pow), ("sin", math.sin), ("cos", math.cos), ("chypot", _cabs)):
            setattr(self, name, _each(_safe(f)))
        self._trig_checked = False

    def install(self, functions: dict, label: str) -> None:
        """Take ``functions`` (name -> array function giving math's bits) in place of the per-element ones."""
        for name, f in functions.items():
            setattr(self, name, f)
        self.loops = label

    def trig(self) -> None:
        """Use numpy's own sin and cos if they give math's bits on a sample of arguments (checked once)."""
        if self._trig_checked:
            return
        self._trig_checked = True
        x = np.concatenate([np.linspace(-40.0, 40.0, 4001), np.random.default_rng(7).uniform(-1e4, 1e4, 4000),
                            np.random.default_rng(8).normal(0.0, 1e-3, 2000)])
        for name, f, g in (("sin", np.sin, math.sin), ("cos", np.cos, math.cos)):
            if np.array_equal(f(x).view(np.int64), np.array([g(v) for v in x.tolist()]).view(np.int64)):
                setattr(self, name, f)

    where = staticmethod(np.where)

    @staticmethod
    def stack(items):
        """Rows of these values over the variants (numbers broadcast): states or rates x variants."""
        n = next((i.shape[0] for i in items if isinstance(i, np.ndarray) and i.ndim), 1)
        out = np.empty((len(items), n))
        for k, i in enumerate(items):
            out[k] = i
        return out

    @staticmethod
    def minimum(a, b):
        """Python's ``min(a, b)``: ``b`` where ``b < a``, else ``a``."""
        return np.where(b < a, b, a)

    @staticmethod
    def maximum(a, b):
        """Python's ``max(a, b)``: ``b`` where ``b > a``, else ``a``."""
        return np.where(b > a, b, a)


def _as_module(cls) -> types.ModuleType:
    """``cls``'s names as a module's: an FMU's step reads them hundreds of times, and Python reads a module's
    attribute about three times faster than a class's through an instance (CPython 3.11: 15 ns against 50 ns,
    measured like ``math.sin``)."""
    ns = types.ModuleType(f"{__name__}.{cls.__name__.upper()}", cls.__doc__)
    for name, value in vars(cls).items():
        if not name.startswith("__"):
            setattr(ns, name, value.__func__ if isinstance(value, staticmethod) else value)
    return ns


SCALAR = _as_module(Scalar)
NUMPY = Numpy()
VECTOR = Vector()


def namespace(m):
    """The namespace of ``m``: :data:`SCALAR` for the ``math`` module, :data:`NUMPY` for ``numpy``, ``m`` itself
    for a namespace (the laws and kinematics take any of them)."""
    if m is math:
        return SCALAR
    if m is np or m is None:
        return NUMPY
    return m


def install_loops(functions: dict, label: str) -> None:
    """Compiled element loops over the C library's functions for :data:`VECTOR` (:mod:`fmus.batch_libm`)."""
    VECTOR.install(functions, label)
