"""The integrators of :mod:`fmus.physics.integrate` on arrays over a batch of variants (:mod:`fmus.physics.variants`):
the same operations, element by element, so each variant's numbers are its scalar model's, bit for bit.

* :func:`rk4` and :func:`rk4_pairs`: each variant on its own sub-steps (``n`` from its own ``max_substep``); the
  step of the largest count is taken by all, a variant with fewer keeps its values after its last sub-step;
* :func:`march_pair` with :func:`exprb32_pair` (the exponential Rosenbrock step with its jet in closed form): the
  2x2 phi-functions (:func:`phi_matrices_2x2`) in their closed forms on arrays: a complex pair of eigenvalues
  through Python's own complex arithmetic written out on real and imaginary parts (CPython's product, its quotient
  by Smith's method, ``cmath.exp`` as ``exp(re) (cos(im), sin(im))``, ``abs`` as the C library's hypot), a real
  pair in floats; the variants whose eigenvalues are too close or too large for the closed form (the scalar's
  series) take the scalar function, one by one.

Python's mixed arithmetic of a complex and a float (``0.5 + z``, ``z - 1.0``, ``0.0 * z``) converts the float to a
complex with imaginary part 0.0 (CPython up to 3.13), so its zero terms are kept here as there.
"""
from __future__ import annotations

import functools
import sys

import numpy as np

from . import integrate
from .mathns import VECTOR

_MIXED_AS_COMPLEX = sys.version_info < (3, 14)   # CPython 3.14 takes a float as a real number in complex arithmetic


def substeps(h, max_substep: np.ndarray) -> np.ndarray:
    """:func:`fmus.physics.integrate.substeps` of each variant (its own ``max_substep``), as floats."""
    with np.errstate(divide="ignore", invalid="ignore"):
        n = np.ceil(h / max_substep * (1.0 - 1e-12))
    return np.maximum(1.0, np.where(np.isfinite(max_substep), n, 1.0))


def rk4_pairs(acc, t0: float, h: float, max_substep: np.ndarray, q: np.ndarray, v: np.ndarray):
    """:func:`fmus.physics.integrate.rk4_pairs` of every variant on its own sub-steps (module docstring)."""
    n = substeps(h, max_substep)
    top, low = int(n.max()), int(n.min())
    dt = h / n
    for i in range(top):
        q1, v1 = integrate.rk4_pair(acc, t0 + i * dt, dt, q, v)
        if i >= low:
            live = i < n
            q1, v1 = np.where(live, q1, q), np.where(live, v1, v)
        q, v = q1, v1
    return q, v


_RK4_STAGES = ((0.5, 2.0), (0.5, 2.0), (1.0, 1.0))   # classical RK4 after its first stage: (node, weight x 6)


def rk4(f, t0: float, h: float, x: np.ndarray, u, max_substep: np.ndarray) -> np.ndarray:
    """:func:`fmus.physics.integrate.rk4` of every variant (states x variants) on its own sub-steps, its stages
    from a table: the same products and sums in the same order (a node or weight of 1.0 multiplies exactly)."""
    n = substeps(h, max_substep)
    top, low = int(n.max()), int(n.min())
    dt = h / n
    for i in range(top):
        t = t0 + i * dt
        k = total = f(t, x, u, t0)
        for c, w in _RK4_STAGES:
            k = f(t + c * dt, x + c * dt * k, u, t0)
            total = total + w * k
        x1 = x + (dt / 6.0) * total
        x = np.where(i < n, x1, x) if i >= low else x1
    return x


# -- Python's complex arithmetic on (real, imaginary) arrays ---------------------------------------------------
def _mul(a, b):
    """CPython's product of two complex numbers."""
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def _add_real(x: float, a):
    """``x + a`` or ``a + x`` (a float and a complex: addition is commutative bit for bit), as CPython computes it."""
    return (x + a[0], 0.0 + a[1]) if _MIXED_AS_COMPLEX else (x + a[0], a[1])


def _sub_real(a, x: float):
    """``a - x`` (a complex and a float)."""
    return (a[0] - x, a[1] - 0.0) if _MIXED_AS_COMPLEX else (a[0] - x, a[1])


class _Divisor:
    """A complex divisor ``b`` = (re, im) arrays prepared for CPython's quotient, Smith's method: the larger part of
    the divisor scales both; the ratio and denominator of each side are computed once for any number of
    dividends (:meth:`divide`)."""

    def __init__(self, b):
        self.b = b
        self.real_big = np.abs(b[0]) >= np.abs(b[1])
        self.all_real = bool(self.real_big.all())
        self.all_imag = not self.all_real and not self.real_big.any()
        if not self.all_imag:
            self.r1 = b[1] / b[0]
            self.d1 = b[0] + b[1] * self.r1
        if not self.all_real:
            self.r2 = b[0] / b[1]
            self.d2 = b[0] * self.r2 + b[1]

    def divide(self, a):
        if self.all_real:
            return (a[0] + a[1] * self.r1) / self.d1, (a[1] - a[0] * self.r1) / self.d1
        side2 = (a[0] * self.r2 + a[1]) / self.d2, (a[1] * self.r2 - a[0]) / self.d2
        if self.all_imag:
            return side2
        side1 = (a[0] + a[1] * self.r1) / self.d1, (a[1] - a[0] * self.r1) / self.d1
        return np.where(self.real_big, side1[0], side2[0]), np.where(self.real_big, side1[1], side2[1])


def _div(a, b):
    """CPython's quotient of two complex numbers (:class:`_Divisor`)."""
    return _Divisor(b).divide(a)


def _phis_complex_exp(z):
    """:func:`fmus.physics.integrate._phis` of complex ``z`` = (re, im) arrays beyond the series' radius."""
    ex = VECTOR.exp(z[0])
    e = (ex * VECTOR.cos(z[1]), ex * VECTOR.sin(z[1]))
    by_z = _Divisor(z)
    p1 = by_z.divide(_sub_real(e, 1.0))
    p2 = by_z.divide(_sub_real(p1, 1.0))
    return p1, p2, by_z.divide(_sub_real(p2, 0.5))


def _phis_complex(z):
    """:func:`fmus.physics.integrate._phis` of complex ``z`` = (re, im) arrays: three (re, im) pairs."""
    small = VECTOR.chypot(z[0], z[1]) < integrate.SERIES_RADIUS
    if not small.any():
        return _phis_complex_exp(z)
    out = [(np.empty_like(z[0]), np.empty_like(z[0])) for _ in range(3)]
    if small.any():
        zs = (z[0][small], z[1][small])
        for j, c in enumerate(integrate._PHI3_TAYLOR):   # p3 = p3 * z + c from the float p3 = 0.0
            if j == 0:
                p3 = ((0.0 * zs[0] - 0.0 * zs[1], 0.0 * zs[1] + 0.0 * zs[0]) if _MIXED_AS_COMPLEX
                      else (0.0 * zs[0], 0.0 * zs[1]))
            else:
                p3 = _mul(p3, zs)
            p3 = _add_real(c, p3)
        p2 = _add_real(0.5, _mul(zs, p3))
        p1 = _add_real(1.0, _mul(zs, p2))
        for o, p in zip(out, (p1, p2, p3)):
            o[0][small], o[1][small] = p
    big = ~small
    if big.any():
        for o, p in zip(out, _phis_complex_exp((z[0][big], z[1][big]))):
            o[0][big], o[1][big] = p
    return out


def _phis_real(z):
    """:func:`fmus.physics.integrate._phis` of real ``z`` (an array): (phi1, phi2, phi3)."""
    small = np.abs(z) < integrate.SERIES_RADIUS
    out = [np.empty_like(z) for _ in range(3)]
    if small.any():
        zs = z[small]
        p3 = 0.0
        for c in integrate._PHI3_TAYLOR:
            p3 = p3 * zs + c
        p2 = 0.5 + zs * p3
        for o, p in zip(out, (1.0 + zs * p2, p2, p3)):
            o[small] = p
    big = ~small
    if big.any():
        zb = z[big]
        e = VECTOR.exp(zb)
        p1 = (e - 1.0) / zb
        p2 = (p1 - 1.0) / zb
        for o, p in zip(out, (p1, p2, (p2 - 0.5) / zb)):
            o[big] = p
    return out


def phi_matrices_2x2(j00, j01, j10, j11, h):
    """:func:`fmus.physics.integrate.phi_matrices_2x2` of every variant (module docstring): (A, B, C), each a
    4-tuple of arrays."""
    p = (j00 + j11) * h
    q = (j00 * j11 - j01 * j10) * h * h
    disc = 0.25 * p * p - q
    root = np.sqrt(np.abs(disc))
    alpha = 0.5 * p
    span = np.abs(alpha) + root
    series = (2.0 * root < integrate.EIGEN_GAP * np.where(span > 1.0, span, 1.0)) | (span > 700.0)
    cplx = ~series & (disc < 0.0)
    real = ~series & ~(disc < 0.0)
    if cplx.all():      # every variant a complex pair (an underdamped mode): no subsets
        coef = [(f[1] / root, f[0] - alpha * f[1] / root) for f in _phis_complex((alpha, root))]
        return _assembled(coef, j00, j01, j10, j11, h)
    j00, j01, j10, j11, h = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (j00, j01, j10, j11, h)))
    coef = [(np.empty_like(p), np.empty_like(p)) for _ in range(3)]
    if cplx.any():
        al, ro = alpha[cplx], root[cplx]
        for (c, d), f in zip(coef, _phis_complex((al, ro))):
            c[cplx] = f[1] / ro
            d[cplx] = f[0] - al * f[1] / ro
    if real.any():
        al, ro = alpha[real], root[real]
        mu1, mu2 = al + ro, al - ro
        gap = mu1 - mu2
        for (c, d), f1, f2 in zip(coef, _phis_real(mu1), _phis_real(mu2)):
            c[real] = (f1 - f2) / gap
            d[real] = (mu1 * f2 - mu2 * f1) / gap
    out = _assembled(coef, j00, j01, j10, j11, h)
    for i in np.flatnonzero(series).tolist():    # the scalar's series, once per distinct matrix and step
        one = _series(float(j00[i]), float(j01[i]), float(j10[i]), float(j11[i]), float(h[i]))
        for o, m in zip(out, one):
            for k in range(4):
                o[k][i] = m[k]
    return tuple(tuple(o) for o in out)


@functools.lru_cache(maxsize=4096)
def _series(j00: float, j01: float, j10: float, j11: float, h: float):
    """:func:`fmus.physics.integrate.phi_matrices_2x2` of one matrix and step (a pure function, kept: a free
    flight's J = [[0, 1], [0, 0]] comes back every step with the same step length)."""
    return integrate.phi_matrices_2x2(j00, j01, j10, j11, h)


def _assembled(coef, j00, j01, j10, j11, h):
    """(A, B, C) from the phi-functions' coefficients (c, d): h^k (c M + d I), M = hJ, as the scalar assembles them."""
    m00, m01, m10, m11 = h * j00, h * j01, h * j10, h * j11
    out = []
    scale = h
    for c, d in coef:
        out.append([scale * (c * m00 + d), scale * c * m01, scale * c * m10, scale * (c * m11 + d)])
        scale = scale * h
    return out


def exprb32_pair(acc, t, dt, q, v, jet):
    """:func:`fmus.physics.integrate.exprb32_pair` of every variant with its jet (a0, a_q, a_v, g) in closed form."""
    a0, a_q, a_v, g = jet
    a, b, c = phi_matrices_2x2(0.0, 1.0, a_q, a_v, dt)
    u0 = a[0] * v + a[1] * a0 + b[1] * g
    u1 = a[2] * v + a[3] * a0 + b[3] * g
    d1 = acc(t + dt, q + u0, v + u1) - a0 - (a_q * u0 + a_v * u1) - g * dt
    k = 2.0 / (dt * dt)
    return q + u0 + k * c[1] * d1, v + u1 + k * c[3] * d1


def march_pair(acc, jet, t0: float, h: float, n: np.ndarray, q: np.ndarray, v: np.ndarray):
    """:func:`fmus.physics.integrate.march_pair` with :func:`exprb32_pair` of every variant, each on its own ``n``
    (floats) equal sub-steps; the last one ends exactly at t0 + h."""
    dt = h / n
    top, low = int(n.max()), int(n.min())
    for i in range(top):
        t = t0 + i * dt
        dt_i = np.where(i < n - 1, t0 + (i + 1) * dt, t0 + h) - t
        q1, v1 = exprb32_pair(acc, t, dt_i, q, v, jet(t, q, v))
        if i >= low:
            live = i < n
            q1, v1 = np.where(live, q1, q), np.where(live, v1, v)
        q, v = q1, v1
    return q, v


__all__ = ["substeps", "rk4", "rk4_pairs", "phi_matrices_2x2", "exprb32_pair", "march_pair"]
