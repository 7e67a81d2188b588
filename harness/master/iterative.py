"""The ``iterative`` master: each step repeated with rollback until the held inputs are a fixed point
(fixed-point, Anderson-accelerated or Newton iteration, :mod:`harness.master.iteration`)."""
from __future__ import annotations

import warnings

import numpy as np

from harness.master.iteration import solve_fixed_point
from harness.master.loop import AssumptionWarning, Master


class Iterative(Master):
    """Each step is repeated with rollback until the held inputs are a fixed point: u = G(u), where G takes
    the step on held inputs u and returns the held inputs computed from the resulting outputs at t+h (their
    polynomial through the newest samples at the step midpoint, or the end value for order 0).  Converged,
    this is the implicit (order 0) or trapezoidal (order >= 1) coupling.  Algebraic loops at communication
    points are solved with the same iteration."""
    name = "iterative"
    solves_loops = True
    refreshes_discrete = True
    input_derivatives = False  # the iteration converges the held (midpoint) values

    def _prepare(self) -> None:
        # without fmi2GetFMUstate/fmi2SetFMUstate a step cannot be repeated: each step is then taken once on
        # the held inputs (the explicit coupling of jacobi), while algebraic loops at communication points,
        # which need no rollback, are still solved -- said once, naming the FMUs
        fixed = [f"{it.name} ({it.fmu.md.modelName})" for it in self.insts if not it.fmu.can_get_set_state]
        self.rolls_back = not fixed
        if fixed:
            warnings.warn(f"master 'iterative': {', '.join(fixed)} cannot roll back (no canGetAndSetFMUstate): "
                          f"each step is taken once on the held inputs; algebraic loops at communication points "
                          f"are still solved", AssumptionWarning, stacklevel=3)

    def needs_rollback(self) -> bool:
        return self.rolls_back

    def _step_impl(self, t, h, t_next):
        coupled = self._batched
        self._hold_all(t, h)
        if not self.rolls_back:
            self._step_fmus(self.insts, t, h, no_prior_state=True)
            self._exchange(t_next)
            return
        u0 = self.u.copy()
        self.snapshot("iterate")
        first = [True]

        def g(u):
            if not first[0]:
                self.restore("iterate")
            first[0] = False
            self.u[:] = u
            values = u.tolist()
            for it in coupled:
                it.fmu.set_list(it.inp, values[it.input_slice])
            self._step_fmus(self.insts, t, h, no_prior_state=False)
            self._exchange(t_next)
            out = np.empty_like(u)
            for it in coupled:
                out[it.input_slice] = self._held_values(it, t, h)
            return out

        _u, _gu, n = solve_fixed_point(g, u0, self.iteration, self.tol, f"coupled step at t = {t:.9g} s")
        self.iterations += n
