"""The math of one variant and of many: the namespaces the hot equations take their functions from.

An equation written once, ``def rate(m, x, ...)``, runs on plain floats with :data:`SCALAR` (``math``: an FMU's
one instance, one variant) and on arrays over variants with :data:`VECTOR` (a batch of variants stepped together,
:mod:`fmus.physics.variants`), giving the same bits for every variant.  Arithmetic (``+ - * /``) is the same IEEE
operation on a float and on an array element; the functions are not always.  Measured on the project's machine
(``python -m benchmarks.vector_math``: numpy 2.4.6 with AVX-512, CPython 3.11.7, glibc; 0.6 to 1.0 million
arguments per function, uniform samples over the ranges the physics uses, e.g. exp on [-745, 710] and [-50, 1],
tanh of v/v_reg on [-1e4, 1e4], acos on [-1, 1] and within 1e-6 of its ends, angles on [-40, 40] and [-1e6, 1e6],
penetrations of 0 to 1e-3 to the powers 0.5, 1.5, 2.5, plus zeros of both signs, infinities, NaN, subnormals and
the overflow edges; contiguous arrays, strided views and arrays of 1 to 17 elements), numpy's float64 ufuncs
against ``math`` bit for bit:

* ``np.sin``, ``np.cos``: equal on every argument (numpy calls the C library's, as ``math`` does);
* ``np.hypot``: equal to the C library's hypot, which is ``abs(complex(x, y))`` (0 of 600 000 differ), but not
  to ``math.hypot`` (CPython's own algorithm: 0.43 % differ by 1 ulp);
* ``np.exp`` 4.5 %, ``np.tanh`` 16 % (up to 3 ulp), ``np.arccos`` 3.2 %, ``np.arctan2`` 3.2 %, ``np.power``
  5.3 % of the arguments differ, by 1 ulp unless said (numpy's own SIMD approximations; in strided views and
  short arrays too, so no layout avoids them).

So :data:`VECTOR` takes ``sqrt``, ``fabs``, ``copysign``, ``floor`` (correctly rounded, the same everywhere) and
``sin``, ``cos`` and ``chypot`` from numpy, where a check on a sample when a batch first runs finds numpy's bits
equal to ``math``'s on the machine at hand (:meth:`Vector.check`; else Python's ``math`` per element), and
``exp``, ``tanh``, ``acos``, ``atan2``, ``pow`` and ``hypot`` from Python's ``math`` called per element (about
60 ns an element: a batch's equations cost that much more per call than numpy's, the price of each variant's
own bits; no compiled code, so a user without a C compiler gets the same numbers).

Every namespace has the same names: ``sqrt sin cos exp tanh acos atan2 hypot copysign fabs floor pow`` as in
``math`` (:data:`VECTOR` also ``chypot``: ``abs`` of a complex number, the C library's hypot), ``pi``, and what
branches need: ``where(c, a, b)`` (``a if c else b``), ``minimum``/``maximum`` (Python's ``min``/``max`` of two,
its semantics with NaN too).  :data:`NUMPY` is numpy itself under those names (the synthesis tools' array
evaluation, as they computed it before).  An FMU's step reads these names hundreds of times: :data:`SCALAR` is a
module object (read as fast as ``math``), a scalar path's branch is an ``if`` where a call of ``where`` would cost
more than the arithmetic it picks.
"""
from __future__ import annotations

import itertools
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


def _safe(f):
    """``f`` with ``math``'s domain and range errors as NaN and inf (a failed variant, found by the batch's check of
    its state, not an exception that would stop every variant)."""
    def g(*args):
        try:
            return f(*args)
        except ValueError:
            return math.nan
        except (OverflowError, ZeroDivisionError):
            return math.inf
    g.__name__ = f.__name__
    return g


def _each(f):
    """``f`` of ``math`` element by element on arrays (numbers broadcast): ``math``'s bits, one Python call an
    element; where an element raises (a domain or range error), every element again through :func:`_safe`."""
    safe = _safe(f)

    def g(*args):
        if len(args) == 1:
            x = args[0]
            if not isinstance(x, np.ndarray) or x.ndim == 0:
                return np.float64(safe(float(x)))
            xs = [x.ravel().tolist()]
        else:
            a, b = args
            fa, fb = not isinstance(a, np.ndarray) or a.ndim == 0, not isinstance(b, np.ndarray) or b.ndim == 0
            if fa and fb:
                return np.float64(safe(float(a), float(b)))
            if fb or fa:
                x = b if fa else a
                one = itertools.repeat(float(a if fa else b), x.size)
                xs = [one, x.ravel().tolist()] if fa else [x.ravel().tolist(), one]
            else:
                a, b = np.broadcast_arrays(a, b)
                x = a
                xs = [a.ravel().tolist(), b.ravel().tolist()]
        try:
            out = np.fromiter(map(f, *xs), float, x.size)
        except (ValueError, OverflowError, ZeroDivisionError, TypeError):
            xs = [x.ravel().tolist()] if len(args) == 1 else [np.broadcast_to(np.asarray(v, dtype=float),
                                                                              x.shape).ravel().tolist() for v in args]
            out = np.fromiter((float(v) if isinstance(v, float) else math.nan for v in map(safe, *xs)), float, x.size)
        return out.reshape(x.shape)
    g.__name__ = f.__name__
    return g


def _cabs(x, y):
    """``abs(complex(x, y))``: the C library's hypot (what CPython's complex abs calls)."""
    return abs(complex(x, y))


class Vector:
    """Arrays over variants with ``math``'s bits (module docstring): numpy where its bits are ``math``'s, Python's
    ``math`` per element elsewhere."""
    scalar = False
    pi = math.pi
    sqrt, copysign, fabs, floor = np.sqrt, np.copysign, np.abs, np.floor
    hypot = staticmethod(_each(math.hypot))
    # numpy's ufunc for these where :meth:`check` finds its bits equal to math's (measured: the module docstring)
    NUMPY_IF_EQUAL = (("sin", np.sin, math.sin), ("cos", np.cos, math.cos), ("chypot", np.hypot, _cabs))

    def __init__(self):
        for name, f in (("exp", math.exp), ("tanh", math.tanh), ("acos", math.acos), ("atan2", math.atan2),
                        ("pow", operator.pow), ("sin", math.sin), ("cos", math.cos), ("chypot", _cabs)):
            setattr(self, name, _each(f))
        self.checked = None

    def check(self) -> str:
        """Take numpy's ``sin``, ``cos`` and ``hypot`` (as ``chypot``) where their bits equal ``math``'s on a sample
        of arguments (checked once per process: numpy's loops depend on its build and the machine); returns one
        line saying what computes each function."""
        if self.checked is None:
            rng = np.random.default_rng(7)
            x = np.concatenate([np.linspace(-40.0, 40.0, 4001), rng.uniform(-1e4, 1e4, 4000),
                                rng.normal(0.0, 1e-3, 2000), [0.0, -0.0, 1e-300, 5e-324, math.pi, 1e6]])
            y = np.concatenate([rng.normal(0.0, 1.0, x.size - 6), [0.0, -0.0, 1e-300, 1e300, -1.0, 3.0]])
            taken = []
            for name, f, g in self.NUMPY_IF_EQUAL:
                args = (x,) if g is not _cabs else (x, y)
                ref = np.array([g(*v) for v in zip(*(a.tolist() for a in args))])
                if np.array_equal(f(*args).view(np.int64), ref.view(np.int64)):
                    setattr(self, name, f)
                    taken.append(name)
            rest = [n for n in ("exp", "tanh", "acos", "atan2", "pow", "hypot", "sin", "cos", "chypot")
                    if n not in taken]
            self.checked = (f"numpy's {', '.join(taken)} (their bits math's on this machine); " if taken else "") + \
                f"Python's math per element for {', '.join(rest)}"
        return self.checked

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
