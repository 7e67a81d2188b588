"""The co-simulation masters and their parts, by name (:data:`MASTERS`).

One stepping loop (:mod:`harness.master.loop`: the base class :class:`Master` owns the loop, each method implements
one ``_step_impl``), the methods by family (:mod:`~harness.master.explicit`: jacobi, jacobi-sampled, gauss-seidel;
:mod:`~harness.master.iterative`; :mod:`~harness.master.implicit`: jacobian) and the loop's parts: the coupling
layout (coupling), the dependency graph (graph), input extrapolation (extrapolation), step control (stepcontrol),
the fixed-point solvers (iteration), the interface Jacobians (jacobian), what watches a run (observers,
divergence) and the one time base (clock: integer nanoseconds).
"""
from __future__ import annotations

from harness.errors import SystemDescriptionError
from harness.master.explicit import GaussSeidel, Jacobi, JacobiSampled
from harness.master.implicit import InterfaceJacobian
from harness.master.iteration import ConvergenceError, IterationOptions
from harness.master.iterative import Iterative
from harness.master.loop import AssumptionWarning, Master

__all__ = ["MASTERS", "Master", "master_class", "ConvergenceError", "IterationOptions", "AssumptionWarning",
           "Jacobi", "JacobiSampled", "GaussSeidel", "Iterative", "InterfaceJacobian"]

MASTERS: dict[str, type[Master]] = {"jacobi": Jacobi, "jacobi-sampled": JacobiSampled, "gauss-seidel": GaussSeidel,
                                    "iterative": Iterative, "jacobian": InterfaceJacobian}


def master_class(name: str) -> type[Master]:
    key = str(name).strip().lower().replace("_", "-")
    key = {"gauss seidel": "gauss-seidel", "gaussseidel": "gauss-seidel", "gs": "gauss-seidel"}.get(key, key)
    if key not in MASTERS:
        import difflib

        close = difflib.get_close_matches(key, list(MASTERS), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise SystemDescriptionError(f"master = {name!r} is not admissible{hint}: must be one of {', '.join(MASTERS)}")
    return MASTERS[key]
