"""Powell's hybrid method for a square system of nonlinear equations, in numpy: the root finder an FMU runs.

An FMU needs nothing of its host but numpy (docs/howto/export.md), so the synthesis a component runs when it is
initialised (the sector pairs of :mod:`fmus.physics.gear_sectors`) cannot call SciPy.  This is the algorithm of
MINPACK's ``hybrd`` (Moré, Garbow and Hillstrom, *User Guide for MINPACK-1*, ANL-80-74, 1980), which SciPy's
``optimize.root(method="hybr")`` calls, written from its description: a forward-difference Jacobian, its QR
factorisation, a dogleg step inside a trust region scaled by the Jacobian's column norms, Broyden's rank-one
updates of Q and R between Jacobians (a new Jacobian after two failed steps) and MINPACK's tests for the trust
region and for the end.  Taking the same steps as SciPy from the same start, it ends at the same root where a
system has several (the sector synthesis has: which one a start reaches is the method's), which a plain Newton
iteration does not (measured: another root on about a third of a sweep of the sector tasks).
``tests/test_handoff.py`` compares it with SciPy's on the sector tasks of the shipped drives, a sweep of them, and
systems with known roots.
"""
from __future__ import annotations

import math

import numpy as np

EPS = float(np.finfo(float).eps)
GIANT = float(np.finfo(float).max)


def _norm(v) -> float:
    return math.sqrt(float(np.dot(v, v)))


def _jacobian(f, x, fx, eps: float) -> np.ndarray:
    """Forward differences, MINPACK's fdjac1: step eps*|x_j| (eps where x_j = 0)."""
    J = np.empty((fx.size, x.size))
    for j in range(x.size):
        keep = x[j]
        h = eps * abs(keep) or eps
        x[j] = keep + h
        J[:, j] = (f(x) - fx) / h
        x[j] = keep
    return J


def _householder(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MINPACK's qrfac without pivoting: a holds the Householder vectors below and R above its diagonal on
    return; the diagonal of R, and the column norms of the input."""
    m, n = a.shape
    norms = np.sqrt((a * a).sum(axis=0))
    rdiag = np.zeros(n)
    for j in range(min(m, n)):
        ajnorm = _norm(a[j:, j])
        if ajnorm != 0.0:
            if a[j, j] < 0.0:
                ajnorm = -ajnorm
            a[j:, j] /= ajnorm
            a[j, j] += 1.0
            for k in range(j + 1, n):
                a[j:, k] -= (float(np.dot(a[j:, j], a[j:, k])) / a[j, j]) * a[j:, j]
        rdiag[j] = -ajnorm
    return rdiag, norms


def _q_from(a: np.ndarray) -> np.ndarray:
    """MINPACK's qform: the orthogonal Q of the Householder vectors in ``a`` (square)."""
    n = a.shape[0]
    q = np.tril(a)   # the vectors; R above the diagonal is not Q's
    for k in range(n - 1, -1, -1):
        w = q[k:, k].copy()
        q[k:, k] = 0.0
        q[k, k] = 1.0
        if w[0] != 0.0:
            for j in range(k, n):
                q[k:, j] -= (float(np.dot(q[k:, j], w)) / w[0]) * w
    return q


def _dogleg(r: np.ndarray, diag: np.ndarray, qtb: np.ndarray, delta: float) -> np.ndarray:
    """MINPACK's dogleg: the convex combination of the Gauss-Newton and the scaled steepest-descent directions
    that minimises ||R x - qtb|| in the trust region ||diag * x|| <= delta."""
    n = r.shape[0]
    x = np.zeros(n)
    for j in range(n - 1, -1, -1):
        s = float(np.dot(r[j, j + 1:], x[j + 1:]))
        temp = r[j, j]
        if temp == 0.0:
            temp = EPS * (float(np.max(np.abs(r[:j + 1, j]))) or 1.0)
        x[j] = (qtb[j] - s) / temp
    qnorm = _norm(diag * x)
    if qnorm <= delta:
        return x
    grad = (r.T @ qtb) / diag
    gnorm = _norm(grad)
    sgnorm = 0.0
    alpha = delta / qnorm
    if gnorm != 0.0:
        grad = (grad / gnorm) / diag
        temp = _norm(r @ grad)
        sgnorm = (gnorm / temp) / temp
        alpha = 0.0
        if sgnorm < delta:
            bnorm = _norm(qtb)
            temp = (bnorm / gnorm) * (bnorm / qnorm) * (sgnorm / delta)
            temp = (temp - (delta / qnorm) * (sgnorm / delta) ** 2
                    + math.sqrt((temp - delta / qnorm) ** 2 + (1.0 - (delta / qnorm) ** 2) * (1.0 - (sgnorm / delta) ** 2)))
            alpha = ((delta / qnorm) * (1.0 - (sgnorm / delta) ** 2)) / temp
    return (1.0 - alpha) * min(sgnorm, delta) * grad + alpha * x


def _rotation(a: float, b: float) -> tuple[float, float, float]:
    """(cos, sin, tau) of the Givens rotation that zeroes b against a, MINPACK's way (tau encodes it)."""
    if abs(a) < abs(b):
        cotan = a / b
        sin = 0.5 / math.sqrt(0.25 + 0.25 * cotan * cotan)
        cos = sin * cotan
        tau = 1.0 / cos if abs(cos) * GIANT > 1.0 else 1.0
    else:
        tan = b / a
        cos = 0.5 / math.sqrt(0.25 + 0.25 * tan * tan)
        sin = cos * tan
        tau = sin
    return cos, sin, tau


def _rank_one(r: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MINPACK's r1updt (R upper triangular, S = R^T): R becomes the triangular factor of R + v u^T times
    rotations; returns the rotations' codes (v's and w's) for :func:`_apply`."""
    n = r.shape[0]
    v = v.copy()
    w = np.zeros(n)
    w[n - 1] = r[n - 1, n - 1]
    for j in range(n - 2, -1, -1):
        w[j] = 0.0
        if v[j] != 0.0:
            cos, sin, tau = _rotation(v[n - 1], v[j])
            v[n - 1] = sin * v[j] + cos * v[n - 1]
            v[j] = tau
            row = r[j, j:].copy()
            r[j, j:] = cos * row - sin * w[j:]
            w[j:] = sin * row + cos * w[j:]
    w += v[n - 1] * u
    for j in range(n - 1):
        if w[j] != 0.0:
            cos, sin, tau = _rotation(r[j, j], w[j])
            row = r[j, j:].copy()
            r[j, j:] = cos * row + sin * w[j:]
            w[j:] = -sin * row + cos * w[j:]
            w[j] = tau
    r[n - 1, n - 1] = w[n - 1]
    return v, w


def _apply(a: np.ndarray, v: np.ndarray, w: np.ndarray) -> None:
    """MINPACK's r1mpyq: a (rows) times the rotations coded in v and w, in place."""
    n = a.shape[1]
    for codes, sign in ((v, -1.0), (w, 1.0)):
        order = range(n - 2, -1, -1) if sign < 0 else range(n - 1)
        for j in order:
            c = codes[j]
            if abs(c) > 1.0:
                cos = 1.0 / c
                sin = math.sqrt(1.0 - cos * cos)
            else:
                sin = c
                cos = math.sqrt(1.0 - sin * sin)
            aj = a[:, j].copy()
            a[:, j] = cos * aj + sign * sin * a[:, n - 1]
            a[:, n - 1] = -sign * sin * aj + cos * a[:, n - 1]


def hybrid(f, x0, xtol: float = 1.49012e-08, maxfev: int | None = None, factor: float = 100.0) -> np.ndarray:
    """A root of ``f`` (n equations in n unknowns) from ``x0`` by Powell's hybrid method (module docstring), with
    SciPy's defaults: relative tolerance ``xtol`` between the last two iterates, at most ``maxfev`` calls of ``f``
    (200 (n + 1)), initial trust radius ``factor`` times the scaled start.  Returns the last iterate, converged or
    not: the caller judges the residual."""
    x = np.array(x0, dtype=float)
    n = x.size
    maxfev = 200 * (n + 1) if maxfev is None else maxfev
    fvec = np.asarray(f(x), dtype=float)
    nfev = 1
    fnorm = _norm(fvec)
    eps = math.sqrt(EPS)
    it, ncsuc, ncfail, nslow1, nslow2 = 1, 0, 0, 0, 0
    diag = delta = xnorm = None
    while True:
        jeval = True
        fjac = _jacobian(f, x, fvec, eps)
        nfev += n
        rdiag, norms = _householder(fjac)
        if it == 1:
            diag = np.where(norms == 0.0, 1.0, norms)
            xnorm = _norm(diag * x)
            delta = factor * xnorm or factor
        qtf = fvec.copy()
        for j in range(n):
            if fjac[j, j] != 0.0:
                qtf[j:] += (-float(np.dot(fjac[j:, j], qtf[j:])) / fjac[j, j]) * fjac[j:, j]
        r = np.triu(fjac)
        r[np.diag_indices(n)] = rdiag
        q = _q_from(fjac)
        diag = np.maximum(diag, norms)
        while True:
            step = -_dogleg(r, diag, qtf, delta)
            trial = x + step
            pnorm = _norm(diag * step)
            if it == 1:
                delta = min(delta, pnorm)
            ftrial = np.asarray(f(trial), dtype=float)
            nfev += 1
            fnorm1 = _norm(ftrial)
            actred = 1.0 - (fnorm1 / fnorm) ** 2 if fnorm1 < fnorm else -1.0
            predicted = qtf + r @ step
            temp = _norm(predicted)
            prered = 1.0 - (temp / fnorm) ** 2 if temp < fnorm else 0.0
            ratio = actred / prered if prered > 0.0 else 0.0
            if ratio < 0.1:
                ncsuc, ncfail = 0, ncfail + 1
                delta *= 0.5
            else:
                ncfail, ncsuc = 0, ncsuc + 1
                if ratio >= 0.5 or ncsuc > 1:
                    delta = max(delta, pnorm / 0.5)
                if abs(ratio - 1.0) <= 0.1:
                    delta = pnorm / 0.5
            if ratio >= 1e-4:
                x, fvec, fnorm = trial, ftrial, fnorm1
                xnorm = _norm(diag * x)
                it += 1
            nslow1 = 0 if actred >= 1e-3 else nslow1 + 1
            if jeval:
                nslow2 += 1
            if actred >= 0.1:
                nslow2 = 0
            if delta <= xtol * xnorm or fnorm == 0.0:
                return x
            if nfev >= maxfev or 0.1 * max(0.1 * delta, pnorm) <= EPS * xnorm or nslow2 == 5 or nslow1 == 10:
                return x
            if ncfail == 2:
                break
            qf = q.T @ ftrial
            u = diag * ((diag * step) / pnorm)
            v = (qf - predicted) / pnorm
            if ratio >= 1e-4:
                qtf = qf
            codes_v, codes_w = _rank_one(r, u, v)
            _apply(q, codes_v, codes_w)
            row = qtf.reshape(1, n)
            _apply(row, codes_v, codes_w)
            qtf = row.ravel()
            jeval = False
