"""The explicit masters: ``jacobi`` (every FMU on inputs extrapolated from the outputs at t), ``jacobi-sampled``
(as libcosim, Ecos and FMPy's ``simulate_ssp`` do it) and ``gauss-seidel`` (FMUs one after the other, each on the
newest outputs).  Each step is taken once."""
from __future__ import annotations

from harness.master import graph
from harness.master.loop import Master


class Jacobi(Master):
    """Every FMU steps on inputs extrapolated from the outputs at t; outputs with declared feed-through are
    refreshed with the new inputs at each communication point (Real and non-Real)."""
    name = "jacobi"
    refreshes_discrete = True

    def history_depth(self) -> int:
        return self.extrapolation.order + 1  # every source's newest sample is at t: the polynomial's nodes

    def _step_impl(self, t, h, t_next):
        self._hold_all(t, h)
        self._step_fmus(self.insts, t, h, no_prior_state=True)
        self._outputs_at(t_next)

    _outputs_at = Master._exchange  # consistent outputs at t+h: feed-through refreshed with the new inputs


class JacobiSampled(Jacobi):
    """Jacobi as libcosim, Ecos and FMPy's ``simulate_ssp`` do it: outputs are sampled right after
    ``fmi2DoStep`` and passed on at the next step; an output with direct feed-through is NOT refreshed with
    the new inputs at the communication point (``jacobi`` does refresh it, which is more accurate).  Use it
    to compare with those tools step for step."""
    name = "jacobi-sampled"
    refreshes_discrete = False
    _outputs_at = Master._read_all  # the outputs as they are right after the step, Real feed-through too


class GaussSeidel(Master):
    """FMUs step in dependency order; each uses the newest outputs (samples at t+h where available)."""
    name = "gauss-seidel"

    def _prepare(self) -> None:
        order = graph.stepping_order(self.connections, self.mds)
        self.order = [self.insts[self.index[n]] for n in order]

    def _step_impl(self, t, h, t_next):
        point = self.extrapolation.order >= 1
        for it in self.order:
            self._set_held_inputs(it, t, h)
            self._step_fmus((it,), t, h, no_prior_state=True)
            if point and it.feedthrough and it.inp.n:
                # the FMUs after this one take its sample at t+h as exact: a feed-through output must see its
                # inputs AT t+h (newest samples, or the polynomial at t+h for sources not yet stepped), not
                # the midpoint values held over the step -- otherwise a rigid link hands a midpoint value on
                # as the end value and the coupling drops to first order
                it.fmu.set(it.inp, it.factor * self.extrapolation.value(self.history, it.src, t_next) + it.offset)
            self._read(it)
            self.history.push(it.output_slice, t_next, self.y[it.output_slice])
        self._exchange(t_next)
