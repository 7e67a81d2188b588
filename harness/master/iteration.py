"""Fixed-point solvers of the coupling: the options of the ``iterative`` master and the one solver of
``u = g(u)`` (fixed-point, Anderson-accelerated or Newton iteration) that it uses for coupled steps and
algebraic loops (moved out of :mod:`harness.master` to keep the stepping loop readable)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from harness.errors import HarnessError, SystemDescriptionError


class ConvergenceError(HarnessError):
    """An iteration (coupled step or algebraic loop) that did not reach its tolerance."""


@dataclass
class IterationOptions:
    """Options of the ``iterative`` master.  ``method``: ``fixed-point``, ``anderson`` or ``newton``;
    ``tolerance``: max |G(u) - u| / (1 + |u|) over the held inputs (None: the run's tolerance, else 1e-10);
    ``memory``: Anderson depth."""
    method: str = "anderson"
    tolerance: float | None = None
    max_iterations: int = 100
    memory: int = 5

    def __post_init__(self):
        if self.method not in ("fixed-point", "anderson", "newton"):
            raise SystemDescriptionError(f"iteration method = {self.method!r} is not admissible: must be fixed-point, "
                                         f"anderson or newton")
        if not (isinstance(self.max_iterations, int) and self.max_iterations >= 1):
            raise SystemDescriptionError(f"max_iterations = {self.max_iterations!r} must be an integer >= 1")
        if self.tolerance is not None and not self.tolerance > 0:
            raise SystemDescriptionError(f"iteration tolerance = {self.tolerance!r} must be > 0")


def solve_fixed_point(g, u0: np.ndarray, options: IterationOptions, tol: float, what: str):
    """Solve ``u = g(u)``; return (u, g(u) evaluated last, iterations).  The last call of ``g`` is always at
    the returned ``u`` (callers keep side effects of that call)."""
    u = np.array(u0, dtype=float)
    gu = g(u)
    if u.size == 0:
        return u, gu, 1
    method, m = options.method, options.memory
    dF, dG = [], []
    f_prev = g_prev = None
    for it in range(1, options.max_iterations + 1):
        f = gu - u
        err = float(np.max(np.abs(f) / (1.0 + np.abs(u))))
        if not math.isfinite(err):
            raise ConvergenceError(f"{what}: the iteration diverged (non-finite residual) after {it} evaluations")
        if err <= tol:
            return u, gu, it
        if method == "newton":
            n = u.size
            jac = np.empty((n, n))
            for j in range(n):
                d = 1e-7 * (1.0 + abs(u[j]))
                up = u.copy()
                up[j] += d
                jac[:, j] = ((g(up) - up) - f) / d
            try:
                u = u - np.linalg.solve(jac, f)
            except np.linalg.LinAlgError:
                u = gu
        elif method == "anderson" and f_prev is not None:
            dF.append(f - f_prev)
            dG.append(gu - g_prev)
            if len(dF) > m:
                dF.pop(0)
                dG.pop(0)
            F = np.array(dF).T
            gamma = np.linalg.lstsq(F, f, rcond=None)[0]
            f_prev, g_prev = f, gu
            u = gu - np.array(dG).T @ gamma
        else:
            f_prev, g_prev = f, gu
            u = gu
        gu = g(u)
    raise ConvergenceError(f"{what}: no convergence in {options.max_iterations} iterations of {method} "
                           f"(residual {err:.3g} > tolerance {tol:.3g})")
