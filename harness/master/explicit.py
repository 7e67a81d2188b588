"""The explicit masters: ``jacobi`` (every FMU on inputs extrapolated from the outputs at t), ``jacobi-sampled``
(as libcosim, Ecos and FMPy's ``simulate_ssp`` do it) and ``gauss-seidel`` (FMUs one after the other, each on the
newest outputs).  Each step is taken once."""
from __future__ import annotations

from harness.errors import SystemDescriptionError
from harness.master import graph
from harness.master.clock import NS
from harness.master.loop import Master


class Jacobi(Master):
    """Every FMU steps on inputs extrapolated from the outputs at t; outputs with declared feed-through are
    refreshed with the new inputs at each communication point (Real and non-Real)."""
    name = "jacobi"
    refreshes_discrete = True
    multirate = True

    def history_depth(self) -> int:
        return self.extrapolation.order + 1  # every source's newest sample is at t: the polynomial's nodes

    def _step_impl(self, t, h, t_next):
        self._hold_all(t, h)
        self._step_fmus(self.insts, t, h, no_prior_state=True)
        self._outputs_at(t_next)

    _outputs_at = Master._exchange  # consistent outputs at t+h: feed-through refreshed with the new inputs

    def _step_rates(self, t_ns, h_ns):
        """The instances whose own step starts at t hold their inputs (extrapolated to the middle of their own
        step) and step; those whose step ends at t+h give their outputs (harness.master.multirate)."""
        starting, steps = self.rates.begin(t_ns, h_ns)
        t = t_ns / NS
        self._hold_starting(t, starting, steps)
        for i in starting:
            self._step_fmus((self.insts[i],), t, steps[i] / NS, no_prior_state=True)
        done = self.rates.finish(t_ns + h_ns)
        self._outputs_of((t_ns + h_ns) / NS, done)

    def _hold_starting(self, t, starting, steps):
        """:meth:`_set_held_inputs` of the instances starting a step of their own, in plain floats for orders 0
        and 1 (the same operations as :meth:`harness.master.extrapolation.Polynomial.held` and
        :meth:`_held_values`: each source's newest samples, none newer than t; an advanced position takes its
        newest sample)."""
        order = self.extrapolation.order
        if order > 1 or any(self.insts[i].interp for i in starting):
            for i in starting:
                self._set_held_inputs(self.insts[i], t, steps[i] / NS)
            return
        hist = self.history
        y0 = hist.y[0].tolist()
        if order:
            y1, t0, t1, n = hist.y[1].tolist(), hist.t[0].tolist(), hist.t[1].tolist(), hist.n.tolist()
        for i in starting:
            it = self.insts[i]
            if not it.inp.n:
                continue
            if order == 0:
                held = [y0[s] for s, _, _ in it.links]
            else:
                te = t + 0.5 * (steps[i] / NS)
                held = [y0[s] + (te - t0[s]) / (t0[s] - t1[s]) * (y0[s] - y1[s]) if n[s] > 1 else y0[s]
                        for s, _, _ in it.links]
                for k in it.pos_idx.tolist():
                    held[k] = y0[it.links[k][0]]
            values = [f * v + o for (_, f, o), v in zip(it.links, held)]
            it.held[:] = values
            it.fmu.set_list(it.inp, values)

    _outputs_of = Master._exchange_some


class JacobiSampled(Jacobi):
    """Jacobi as libcosim, Ecos and FMPy's ``simulate_ssp`` do it: outputs are sampled right after
    ``fmi2DoStep`` and passed on at the next step; an output with direct feed-through is NOT refreshed with
    the new inputs at the communication point (``jacobi`` does refresh it, which is more accurate).  Use it
    to compare with those tools step for step."""
    name = "jacobi-sampled"
    refreshes_discrete = False
    _outputs_at = Master._read_all  # the outputs as they are right after the step, Real feed-through too

    def use_rates(self, rates, step_ns=None):
        if self.extrapolation.order and any(r > 1 for r in rates.values()):
            raise SystemDescriptionError(f"master 'jacobi-sampled' holds each value a connection passed, as libcosim "
                                         f"does: with instances at their own rates it takes extrapolation 0, not "
                                         f"{self.extrapolation.order} (use master 'jacobi' to extrapolate)")
        super().use_rates(rates, step_ns)

    def _hold_starting(self, t, starting, steps):
        """libcosim's rule: each input holds the value its connection passed last (harness.master.multirate)."""
        for i in starting:
            it = self.insts[i]
            if it.inp.n:
                it.fmu.set(it.inp, it.held)

    def _outputs_of(self, t, done):
        """The outputs right after the step; then every connection whose two ends' rates divide the base steps
        taken passes its value."""
        for i in done:
            self._read(self.insts[i])
        for sl in self.rates.ranges(done):
            self.history.push(sl, t, self.y[sl])
        mask = self.rates.transfer_mask()
        self.u[mask] = self.factor[mask] * self.y[self.src[mask]] + self.offset[mask]


class GaussSeidel(Master):
    """FMUs step in dependency order; each uses the newest outputs (samples at t+h where available)."""
    name = "gauss-seidel"
    multirate = True

    def _prepare(self) -> None:
        order = graph.stepping_order(self.connections, self.mds)
        self.order = [self.insts[self.index[n]] for n in order]

    def _step_rates(self, t_ns, h_ns):
        """In stepping order, each instance whose own step starts at t holds the newest samples (extrapolated to
        the middle of its own step) and steps; one whose step ends within this base step gives its outputs at
        once to those after it; a slower one gives them when the master reaches the end of its step."""
        starting, steps = self.rates.begin(t_ns, h_ns)
        t, end_ns = t_ns / NS, t_ns + h_ns
        t_next = end_ns / NS
        point = self.extrapolation.order >= 1
        read = set()
        for it in self.order:
            i = self.index[it.name]
            if i not in steps:
                continue
            self._set_held_inputs(it, t, steps[i] / NS)
            self._step_fmus((it,), t, steps[i] / NS, no_prior_state=True)
            if self.rates.ends[i] != end_ns:
                continue
            if point and it.feedthrough and it.inp.n:
                it.fmu.set(it.inp, it.factor * self.extrapolation.value(self.history, it.src, t_next) + it.offset)
            self._read(it)
            self.history.push(it.output_slice, t_next, self.y[it.output_slice])
            read.add(i)
        done = self.rates.finish(end_ns)
        for i in done:
            if i not in read:
                it = self.insts[i]
                self._read(it)
                self.history.push(it.output_slice, t_next, self.y[it.output_slice])
        self._exchange_some(t_next, done)

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
