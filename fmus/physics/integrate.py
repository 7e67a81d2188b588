"""Fixed-step integrators used inside a communication step.

Each call covers exactly ``[t0, t0 + h]`` with ``n = ceil(h / max_substep)`` equal sub-steps; the sub-step
times are ``t0 + i * h / n`` (computed from the counter, never accumulated), so the last sub-step ends on
``t0 + h`` to the bit.
"""
from __future__ import annotations

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
