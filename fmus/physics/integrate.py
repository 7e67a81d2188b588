"""Fixed-step integrators used inside a communication step.

Each call covers exactly ``[t0, t0 + h]`` with ``n = ceil(h / max_substep)`` equal sub-steps; the sub-step
times are ``t0 + i * h / n`` (computed from the counter, never accumulated), so the last sub-step ends on
``t0 + h`` to the bit.
"""
from __future__ import annotations

import cmath
import math
from typing import Callable, Sequence

import numpy as np

Derivatives = Callable[[float, np.ndarray, Sequence[float], float], np.ndarray]


def substeps(h: float, max_substep: float) -> int:
    if not (h > 0.0 and math.isfinite(h)):
        raise ValueError(f"communication step size must be positive and finite, got {h!r}")
    if not math.isfinite(max_substep):
        return 1
    return max(1, math.ceil(h / max_substep * (1.0 - 1e-12)))


def rk4(f: Derivatives, t0: float, h: float, x: np.ndarray, u: Sequence[float], max_substep: float) -> np.ndarray:
    """Classical fourth-order Runge-Kutta over [t0, t0+h] on equal sub-steps."""
    n = substeps(h, max_substep)
    dt = h / n
    for i in range(n):
        t = t0 + i * dt
        k1 = f(t, x, u, t0)
        k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1, u, t0)
        k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2, u, t0)
        k4 = f(t + dt, x + dt * k3, u, t0)
        x = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


def rk4_pair(acc: Callable[[float, float, float], float], t: float, dt: float, q: float, v: float):
    """ONE classical RK4 step of q' = v, v' = acc(t, q, v) from t over dt, in plain floats: (q, v) at t + dt.

    The same numbers as :func:`rk4` on a state array [q, v, ...] whose other entries do not change (every
    product and sum in the same order), without an array per stage: for the mechanisms whose only evolving
    state is one coordinate and its speed (an elastic link or contact driven by held inputs)."""
    hd = 0.5 * dt
    a1 = acc(t, q, v)
    q2, v2 = q + hd * v, v + hd * a1
    a2 = acc(t + hd, q2, v2)
    q3, v3 = q + hd * v2, v + hd * a2
    a3 = acc(t + hd, q3, v3)
    q4, v4 = q + dt * v3, v + dt * a3
    a4 = acc(t + dt, q4, v4)
    return (q + (dt / 6.0) * (v + 2.0 * v2 + 2.0 * v3 + v4),
            v + (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4))


def rk4_two(acc: Callable[[float, float, float, float, float], tuple[float, float]], t: float, dt: float,
            q1: float, v1: float, q2: float, v2: float):
    """ONE classical RK4 step of two coupled coordinates, q_i' = v_i, v_i' = acc(t, q1, v1, q2, v2)[i], in plain
    floats: (q1, v1, q2, v2) at t + dt (the numbers of :func:`rk4` on [q1, v1, q2, v2])."""
    hd = 0.5 * dt
    a1, b1 = acc(t, q1, v1, q2, v2)
    p2, v2_2, r2, w2 = q1 + hd * v1, v1 + hd * a1, q2 + hd * v2, v2 + hd * b1
    a2, b2 = acc(t + hd, p2, v2_2, r2, w2)
    p3, v3, r3, w3 = q1 + hd * v2_2, v1 + hd * a2, q2 + hd * w2, v2 + hd * b2
    a3, b3 = acc(t + hd, p3, v3, r3, w3)
    p4, v4, r4, w4 = q1 + dt * v3, v1 + dt * a3, q2 + dt * w3, v2 + dt * b3
    a4, b4 = acc(t + dt, p4, v4, r4, w4)
    s = dt / 6.0
    return (q1 + s * (v1 + 2.0 * v2_2 + 2.0 * v3 + v4), v1 + s * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            q2 + s * (v2 + 2.0 * w2 + 2.0 * w3 + w4), v2 + s * (b1 + 2.0 * b2 + 2.0 * b3 + b4))


def rk4_pairs(acc: Callable[[float, float, float], float], t0: float, h: float, max_substep: float,
              q: float, v: float) -> tuple[float, float]:
    """:func:`rk4` over [t0, t0 + h] for a state whose only evolving entries are (q, v), in plain floats: the
    same sub-steps (t0 + i h/n, length h/n) and the same numbers, bit for bit, without arrays."""
    n = substeps(h, max_substep)
    dt = h / n
    for i in range(n):
        q, v = rk4_pair(acc, t0 + i * dt, dt, q, v)
    return q, v


def march_pair(step: Callable, acc: Callable[[float, float, float], float], t0: float, h: float, n: int,
               q: float, v: float, jet: Callable | None = None) -> tuple[float, float]:
    """``n`` equal sub-steps of a one-step method for (q, v) over [t0, t0 + h] (``step`` is :func:`rk4_pair` or
    :func:`exprb32_pair`); the last sub-step ends exactly at t0 + h.  ``jet(t, q, v)``: exprb32_pair's rates and
    their derivatives in closed form at each sub-step's start."""
    dt = h / n
    for i in range(n):
        t = t0 + i * dt
        dt_i = (t0 + (i + 1) * dt if i < n - 1 else t0 + h) - t
        q, v = step(acc, t, dt_i, q, v) if jet is None else step(acc, t, dt_i, q, v, jet(t, q, v))
    return q, v


def implicit_midpoint(f: Derivatives, t0: float, h: float, x: np.ndarray, u: Sequence[float],
                      max_substep: float, jacobian: Callable | None = None, tol: float = 1e-12,
                      max_iter: int = 20) -> np.ndarray:
    """Implicit midpoint rule (A-stable, symplectic) solved by Newton with a finite-difference Jacobian.

    For stiff parts (stiff shafts, contact) where explicit sub-steps would have to be tiny.
    """
    n = substeps(h, max_substep)
    dt = h / n
    m = len(x)
    eye = np.eye(m)
    for i in range(n):
        t = t0 + i * dt
        tm = t + 0.5 * dt
        z = x + dt * f(t, x, u, t0)  # explicit Euler predictor of the end point
        for _ in range(max_iter):
            xm = 0.5 * (x + z)
            r = z - x - dt * f(tm, xm, u, t0)
            if jacobian is not None:
                jac = jacobian(tm, xm, u, t0)
            else:
                jac = np.empty((m, m))
                f0 = f(tm, xm, u, t0)
                for j in range(m):
                    step = 1e-7 * max(1.0, abs(xm[j]))
                    xp = xm.copy()
                    xp[j] += step
                    jac[:, j] = (f(tm, xp, u, t0) - f0) / step
            dz = np.linalg.solve(eye - 0.5 * dt * jac, -r)
            z = z + dz
            if np.max(np.abs(dz)) <= tol * (1.0 + np.max(np.abs(z))):
                break
        x = z
    return x



# phi_matrices_2x2 takes the closed form when the eigenvalues of hJ are apart by at least this share of
# max(1, their modulus): the divided differences then lose at most about 1e-14 (below it: the series)
EIGEN_GAP = 0.05
SERIES_RADIUS = 1.0     # phi_k(z) for |z| below it from phi3's Taylor series (the forward recursion would cancel)
_PHI3_TAYLOR = tuple(1.0 / math.factorial(j + 3) for j in reversed(range(18)))  # Horner order; 1/21! < 1e-19


def _phis(z):
    """(phi1, phi2, phi3)(z) of a real or complex z.  Below SERIES_RADIUS phi3 from its Taylor series
    sum z^j / (j + 3)! (Horner), then phi2 = 1/2 + z phi3 and phi1 = 1 + z phi2 (no cancellation); above it
    from e^z and phi_{k+1} = (phi_k - 1/k!) / z."""
    if abs(z) < SERIES_RADIUS:
        p3 = 0.0
        for c in _PHI3_TAYLOR:
            p3 = p3 * z + c
        p2 = 0.5 + z * p3
        return 1.0 + z * p2, p2, p3
    e = cmath.exp(z) if isinstance(z, complex) else math.exp(z)
    p1 = (e - 1.0) / z
    p2 = (p1 - 1.0) / z
    return p1, p2, (p2 - 0.5) / z


def phi_matrices_2x2(j00: float, j01: float, j10: float, j11: float, h: float):
    """(A, B, C) = (h phi1(hJ), h^2 phi2(hJ), h^3 phi3(hJ)) of a 2x2 matrix J, each as a row-major 4-tuple.

    phi1(z) = (e^z - 1)/z, phi2(z) = (e^z - 1 - z)/z^2, phi3(z) = (e^z - 1 - z - z^2/2)/z^3: the exact increments
    over [0, h] of dy/dt = J y + f + g t + k t^2/2 from y(0) = 0 are A f + B g + C k.

    Closed form where the eigenvalues mu1, mu2 of M = hJ are apart (EIGEN_GAP): f(M) = c M + d I with, for a
    complex pair alpha +- i beta, c = Im f(mu) / beta, d = Re f(mu) - alpha c, and for real ones the divided
    differences c = (f(mu1) - f(mu2)) / (mu1 - mu2), d = (mu1 f(mu2) - mu2 f(mu1)) / (mu1 - mu2).  Near a double
    eigenvalue (or J = 0) those would cancel: :func:`phi_matrices_2x2_series` then."""
    p = (j00 + j11) * h
    q = (j00 * j11 - j01 * j10) * h * h
    disc = 0.25 * p * p - q
    root = math.sqrt(abs(disc))
    alpha = 0.5 * p
    # (beyond |mu| = 700, e^mu nears the largest double: the series' doublings then)
    if 2.0 * root < EIGEN_GAP * max(1.0, abs(alpha) + root) or abs(alpha) + root > 700.0:
        return phi_matrices_2x2_series(j00, j01, j10, j11, h)
    if disc < 0.0:
        coef = [(f.imag / root, f.real - alpha * f.imag / root) for f in _phis(complex(alpha, root))]
    else:
        mu1, mu2 = alpha + root, alpha - root
        gap = mu1 - mu2
        coef = [((f1 - f2) / gap, (mu1 * f2 - mu2 * f1) / gap) for f1, f2 in zip(_phis(mu1), _phis(mu2))]
    m00, m01, m10, m11 = h * j00, h * j01, h * j10, h * j11
    out = []
    scale = h
    for c, d in coef:
        out.append((scale * (c * m00 + d), scale * c * m01, scale * c * m10, scale * (c * m11 + d)))
        scale *= h
    return tuple(out)


def phi_matrices_2x2_series(j00: float, j01: float, j10: float, j11: float, h: float):
    """:func:`phi_matrices_2x2` for any J (singular, tiny, a double eigenvalue), without a matrix inverse: the
    Taylor series at tau = h / 2^s, reduced to first degree in tau J by Cayley-Hamilton (M^j = c_j M + d_j I
    from the trace p and determinant q of M = tau J, all real), with s chosen so that tau times the spectral
    radius of J is at most 1/2, then s doublings of the flow (E = e^{tau J}; the forcing of the second half is
    shifted by tau):  E' = E E,  A' = E A + A,  B' = E B + tau A + B,  C' = E C + tau^2/2 A + tau B + C.
    """
    p = (j00 + j11) * h
    q = (j00 * j11 - j01 * j10) * h * h
    disc = 0.25 * p * p - q
    rho = abs(0.5 * p) + math.sqrt(disc) if disc >= 0.0 else math.sqrt(q)
    s = int(math.ceil(math.log2(rho / 0.5))) if rho > 0.5 else 0
    scale = 2.0 ** -s
    tau = h * scale
    p *= scale
    q *= scale * scale
    c, d = 0.0, 1.0     # M^j = c M + d I:  c_{j+1} = p c_j + d_j,  d_{j+1} = -q c_j
    w_e = 1.0           # 1/j!
    e_c = e_d = a_c = a_d = b_c = b_d = k_c = k_d = 0.0
    for j in range(40):
        w_a = w_e / (j + 1)
        w_b = w_a / (j + 2)
        w_k = w_b / (j + 3)
        e_c += w_e * c
        e_d += w_e * d
        a_c += w_a * c
        a_d += w_a * d
        b_c += w_b * c
        b_d += w_b * d
        k_c += w_k * c
        k_d += w_k * d
        if j >= 3 and abs(w_e * c) + abs(w_e * d) < 1e-17 * (abs(e_c) + abs(e_d)):
            break
        c, d = p * c + d, -q * c
        w_e /= j + 1
    m00, m01, m10, m11 = tau * j00, tau * j01, tau * j10, tau * j11
    e = (e_c * m00 + e_d, e_c * m01, e_c * m10, e_c * m11 + e_d)
    a = (tau * (a_c * m00 + a_d), tau * a_c * m01, tau * a_c * m10, tau * (a_c * m11 + a_d))
    t2 = tau * tau
    b = (t2 * (b_c * m00 + b_d), t2 * b_c * m01, t2 * b_c * m10, t2 * (b_c * m11 + b_d))
    t3 = t2 * tau
    k = (t3 * (k_c * m00 + k_d), t3 * k_c * m01, t3 * k_c * m10, t3 * (k_c * m11 + k_d))
    for _ in range(s):
        half_t2 = 0.5 * tau * tau
        k = tuple(x + y for x, y in zip(_mul(e, k), (half_t2 * a[i] + tau * b[i] + k[i] for i in range(4))))
        b = tuple(x + y for x, y in zip(_mul(e, b), (tau * a[i] + b[i] for i in range(4))))
        a = tuple(x + y for x, y in zip(_mul(e, a), a))
        e = _mul(e, e)
        tau *= 2.0
    return a, b, k


def _mul(x, y):
    return (x[0] * y[0] + x[1] * y[2], x[0] * y[1] + x[1] * y[3], x[2] * y[0] + x[3] * y[2], x[2] * y[1] + x[3] * y[3])


def exprb32_pair(acc: Callable[[float, float, float], float], t: float, dt: float, q: float, v: float,
                 jet: tuple[float, float, float, float] | None = None):
    """ONE exponential Rosenbrock step of order 3 (exprb32, Hochbruck and Ostermann, Acta Numerica 2010,
    sec. 2.4) of q' = v, v' = acc(t, q, v) from t over dt, in plain floats: (q, v) at t + dt.

    With F0 the rates at the step start, J = [[0, 1], [a_q, a_v]] and g = (0, a_t) their derivatives (by
    differences; exact for the columns in which acc is affine), A, B, C = phi_matrices_2x2(J, dt):

        U = y0 + A F0 + B g,     D = F(t + dt, U) - F0 - J (U - y0) - g dt,     y1 = U + (2 / dt^2) C D.

    The linear part is integrated exactly (no stability limit from a stiff spring in J); the method is exact for
    a linear system with forcing quadratic in time and of order 3 otherwise (tests/test_exponential.py).

    ``jet``: (acc, d acc/dq, d acc/dv, d acc/dt) at (t, q, v) when the caller has them in closed form; the step
    then calls ``acc`` once (for D) instead of seven times."""
    if jet is not None:
        return _exprb32_from(acc, t, dt, q, v, *jet)
    a0 = acc(t, q, v)
    # central differences in q and t with steps large enough that the rounding of acc (a spring force from a
    # small difference of lengths) stays below 1e-10 of the derivative: results do not depend on the last bits
    # of the time doubles a host hands over (tests/test_ssp.py compares hosts to 1e-9)
    dq = 1e-5 * (1.0 + abs(q))
    dv = 1e-3 * (1.0 + abs(v))
    tp, tm = t + 1e-2 * dt, t - 1e-2 * dt
    a_q = (acc(t, q + dq, v) - acc(t, q - dq, v)) / (2.0 * dq)
    a_v = (acc(t, q, v + dv) - a0) / dv      # exact up to rounding where acc is affine in v
    g = (acc(tp, q, v) - acc(tm, q, v)) / (tp - tm)
    return _exprb32_from(acc, t, dt, q, v, a0, a_q, a_v, g)


def _exprb32_from(acc, t, dt, q, v, a0, a_q, a_v, g):
    """exprb32_pair's step from the rates a0 and their derivatives a_q, a_v, g = d acc/dt at (t, q, v)."""
    a, b, c = phi_matrices_2x2(0.0, 1.0, a_q, a_v, dt)
    u0 = a[0] * v + a[1] * a0 + b[1] * g          # U - y0
    u1 = a[2] * v + a[3] * a0 + b[3] * g
    # D: its first component (v + u1) - v - u1 vanishes (q' = v is linear)
    d1 = acc(t + dt, q + u0, v + u1) - a0 - (a_q * u0 + a_v * u1) - g * dt
    k = 2.0 / (dt * dt)
    return q + u0 + k * c[1] * d1, v + u1 + k * c[3] * d1
