"""The ``jacobian`` master: linearly implicit coupling through interface Jacobians (:mod:`harness.master.jacobian`
estimates them): a Jacobi prediction, one Newton correction of the held inputs, the step again on the corrected
inputs, and a step taken in halves where a contact is made or lost within it."""
from __future__ import annotations

import numpy as np

from harness.errors import SingularCoupling, SystemDescriptionError
from harness.master import jacobian
from harness.master.clock import NS
from harness.master.coupling import Inst as _Inst
from harness.master.loop import Master


class InterfaceJacobian(Master):
    """Linearly implicit coupling through interface Jacobians (:mod:`harness.master.jacobian`): a Jacobi prediction,
    one Newton correction of the held inputs toward an implicit, dissipative fixed point with Jacobians that
    are re-estimated only when they have changed, and the step taken again on the corrected inputs.  Stable
    where a stiff mode spans FMUs; two FMU steps per communication step.  Needs fmi2Get/SetFMUstate; non-Real
    connections are passed as by ``jacobi`` and take no part in the correction."""
    name = "jacobian"
    checkpointed = ("jacobian", "theta", "_jac_h", "_jacobian_stale", "estimates", "retries")
    refreshes_discrete = True
    input_derivatives = False  # the correction is on the held (midpoint) values

    def _prepare(self) -> None:
        fixed = [f"{it.name} ({it.fmu.md.modelName})" for it in self.insts if not it.fmu.can_get_set_state]
        if fixed:
            raise SystemDescriptionError(f"master 'jacobian' takes each step twice and estimates its Jacobians by "
                                         f"rollback, "
                                         f"but {', '.join(fixed)} cannot roll back (no canGetAndSetFMUstate): use "
                                         f"master='jacobi' or 'gauss-seidel' for such FMUs")
        # per power bond: the held effort and the held motion (not the positions the FMU advances itself), whose
        # weights of the sample at t+h follow their loop gains at each estimate (harness.master.jacobian.target_weights)
        pos = set(self._advanced_positions.tolist())
        held = [jacobian.motion_held(self.insts[self.index[b.motion_in.split(".", 1)[0]]], b) for b in self.bonds]
        self._bond_inputs = [(b[0], [k for k in m if k not in pos]) for b, m in zip(self._bonds, held)]
        self.theta = jacobian.target_weights(len(self.u), self._bond_inputs, None, self._advanced_positions)
        self.jacobian: np.ndarray | None = None  # S of harness.master.jacobian.assemble, for the step size self._jac_h
        self._jac_h, self._jacobian_stale = 0.0, True
        # Jacobian estimates (one extra FMU step per held input each) and steps taken again with fresh Jacobians
        # because the correction did not contract (the halved steps: Master.halvings)
        self.estimates = self.retries = 0

    def needs_rollback(self) -> bool:
        return True

    def _implicit_inputs(self, t: float, h: float) -> np.ndarray:
        """G: the held inputs recomputed from the history whose newest sample is at t+h: ``(1 - theta) y(t) +
        theta y(t+h)`` of each source (harness.master.jacobian.target_weights)."""
        y = self.history.y
        return self.factor * (self.theta * y[0, self.src] + (1.0 - self.theta) * y[1, self.src]) + self.offset

    def _take(self, t: float, h: float, t_next: float, u: np.ndarray) -> np.ndarray:
        """Step every FMU on held inputs ``u``, make the outputs consistent at t+h; return G(u) - u."""
        self.u[:] = u
        values = u.tolist()
        for it in self._batched:
            it.fmu.set_list(it.inp, values[it.input_slice])
        self._step_fmus(self.insts, t, h, no_prior_state=False)
        self._exchange(t_next)
        return self._implicit_inputs(t, h) - u

    def _estimate(self, t: float, h: float, u0: np.ndarray) -> None:
        """Interface Jacobians around the predictor (FMUs at t+h after the step on ``u0``, outputs in ``y``)."""
        states = self._slots["ij"][0]
        point = self.factor * self.y[self.src] + self.offset
        n_y, n_u = len(self.y), len(u0)
        A, D = np.zeros((n_y, n_u)), np.zeros((n_y, n_u))
        for it, state in zip(self.insts, states):
            if not it.inp.n:
                continue
            v = point[it.input_slice] if it.feedthrough else None
            if v is not None:
                D[it.output_slice, it.input_slice] = jacobian.feedthrough_block(it.fmu, it.inp, it.out, v)
            A[it.output_slice, it.input_slice] = jacobian.step_sensitivity(
                it.fmu, it.inp, it.out, state, u0[it.input_slice], v, self.y[it.output_slice], t, h,
                step=self._stepper(it))
        try:
            S = jacobian.assemble(A, D, self.src, self.factor)
        except np.linalg.LinAlgError:  # I - D C: the outputs' feed-through loop has no unique solution
            outs = jacobian.singular_direction(np.eye(n_y) - D @ self._output_links())
            raise self._singular(t, [k for o in outs for k in np.flatnonzero(self.src == o).tolist()],
                                 "the feed-through of the outputs at the step's end") from None
        self.jacobian, self._jac_h, self._jacobian_stale = S, h, False
        self.theta = jacobian.target_weights(len(u0), self._bond_inputs, self.jacobian, self._advanced_positions)
        self.estimates += 1

    def _stepper(self, it: _Inst):
        """``step(t, h)`` of one instance through :meth:`_step_fmus` (counted), for harness.master.jacobian."""
        one = (it,)
        return lambda t, h: self._step_fmus(one, t, h, no_prior_state=False)

    def _output_links(self) -> np.ndarray:
        """``C`` of :func:`harness.master.jacobian.assemble`: held inputs x outputs, ``factor`` at each input's source."""
        C = np.zeros((len(self.src), len(self.y)))
        C[np.arange(len(self.src)), self.src] = self.factor
        return C

    def _held_name(self, k: int) -> str:
        """``instance.input`` of entry ``k`` of the held-input vector."""
        for it in self.insts:
            if it.input_slice.start <= k < it.input_slice.stop:
                return f"{it.name}.{list(it.input_pos)[k - it.input_slice.start]}"
        return f"held input {k}"

    def _singular(self, t: float, held: list[int], what: str) -> SingularCoupling:
        """The one-line stop of a singular interface Jacobian at the step from ``t``: names the power bond whose held
        effort or motion carries the singular direction ``held`` (held-input indices, largest first), else the
        connection's input."""
        names = [self._held_name(k) for k in held[:3]]
        bonds = [label for k in held for label, (effort, motion), b in
                 zip(self.bond_labels, self._bond_inputs, self._bonds) if k in (effort, *motion, b[2])]
        bond = bonds[0] if bonds else None
        where = f"on power bond {bond}" if bond else (f"on input {', '.join(names)}" if names else "")
        return SingularCoupling(
            f"t = {t:.9g} s: master 'jacobian': the interface Jacobian is singular {where} ({what} has no unique "
            f"solution; held values in its singular direction: {', '.join(names) or 'none found'}): this step "
            f"cannot be coupled by this scheme; use another step, or master 'jacobi' or 'gauss-seidel'",
            time=t, bond=bond)

    def _step_impl(self, t, h, t_next, depth: int = 0):
        """One step of the scheme; a step whose correction does not contract even with fresh Jacobians (a contact
        made or lost within it) is taken again as two halves, at most MAX_HALVINGS deep (jacobian.needs_halving)."""
        self._hold_all(t, h)
        u0 = self.u.copy()
        self.snapshot("ij")
        for attempt in (0, 1):
            r0 = self._take(t, h, t_next, u0)
            fresh = self._jacobian_stale or self._jac_h != h
            if fresh:
                self._estimate(t, h, u0)
                r0 = self._implicit_inputs(t, h) - u0  # with the new theta, from the same predictor
            M = np.eye(len(u0)) - self.theta[:, None] * self.jacobian
            try:
                du = np.linalg.solve(M, r0)
            except np.linalg.LinAlgError:  # the corrector's matrix: no unique correction of the held inputs
                raise self._singular(t, jacobian.singular_direction(M), "the Newton correction") from None
            self.restore("ij")
            r1 = self._take(t, h, t_next, u0 + du)
            scale = np.abs(u0) + np.abs(r0) + 1e-9
            rho = jacobian.contraction(r0, r1, scale)
            self._jacobian_stale = rho > jacobian.CONTRACTION
            if fresh and depth < jacobian.MAX_HALVINGS and h * NS >= 1.5 and jacobian.needs_halving(rho, r1, scale):
                self.restore("ij")
                self.halvings += 1
                t_ns, h_ns = round(t * NS), round(h * NS)
                for a, b in ((t_ns, t_ns + h_ns // 2), (t_ns + h_ns // 2, t_ns + h_ns)):
                    self._step_impl(a / NS, (b - a) / NS, b / NS, depth + 1)
                return
            if rho <= jacobian.CONTRACTION or fresh or attempt:
                return
            self.retries += 1
            self.restore("ij")
