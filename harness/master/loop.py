"""THE stepping loop of every co-simulation master (scipy.integrate._ivp style): the base class :class:`Master`.

The methods are its subclasses, one module per family (:mod:`harness.master.explicit`,
:mod:`harness.master.iterative`, :mod:`harness.master.implicit`), registered by name in :mod:`harness.master`.

The base class :class:`Master` owns the coupling data (prepared once: value-reference blocks, a signal
vector ``y`` of every Real output, the connection index arrays, the extrapolation :class:`History`), the
communication-point exchange, rollback snapshots, failure checks, the power-bond bookkeeping and the run
loop.  A method only says how one communication step ``[t, t+h]`` is taken:

``jacobi``        every FMU steps on inputs computed from the outputs known at ``t`` (in parallel in principle);
``gauss-seidel``  FMUs step one after the other in :func:`harness.master.graph.stepping_order` (outputs without
                  direct feed-through first); each uses the newest outputs, including those already at ``t+h``;
``iterative``     the step is repeated with get/set-FMU-state rollback until the held inputs are a fixed point
                  (fixed-point, Anderson-accelerated or Newton iteration; :class:`IterationOptions`); the same
                  solver resolves algebraic loops at each communication point;
``jacobian``      a Jacobi prediction, one Newton correction of the held inputs with interface Jacobians toward
                  an implicit fixed point, and the step again on the corrected inputs (:mod:`harness.master.jacobian`).

At every communication point the outputs are made consistent (:meth:`Master._exchange`): instances are
evaluated in the direct-feed-through order of :func:`harness.master.graph.evaluation_order`; an instance with
feed-through gets the point values of its sources before its outputs are read.  A feed-through cycle (an
algebraic loop) is detected when the master is built: ``jacobi`` and ``gauss-seidel`` refuse it
(:class:`AlgebraicLoopError` naming the loop), ``iterative`` solves it.  A loop that exists only because
outputs declare no ``dependencies`` (FMI 2.0's default: "may depend on every input") is not refused: those
outputs are taken as sampled after the step, as libcosim, Ecos and OMSimulator do, with one
:class:`AssumptionWarning` naming the FMUs (:meth:`Master._assume_sampled`).

Master time is an integer number of nanoseconds; ``t = t_ns / 1e9`` is computed from it, never accumulated.
"""
from __future__ import annotations

import math
import warnings
from typing import ClassVar

import numpy as np

from harness.errors import (AlgebraicLoopError, BlowUp, FMUError, SimulationError,
                            SystemDescriptionError)
from harness.master import coupling, graph
from harness.master.clock import NS
from harness.master.coupling import Inst as _Inst
from harness.master.extrapolation import DEPTH, History, Polynomial
from harness.master.iteration import IterationOptions, solve_fixed_point
from harness.master.multirate import Rates

__all__ = ["Master", "AssumptionWarning"]


class AssumptionWarning(UserWarning):
    """The master assumed something the FMUs do not declare (e.g. no feed-through of outputs without
    ``dependencies``)."""


class Master:
    """Base class: the coupling machinery and THE run loop (:meth:`run`).  A method is a subclass that sets a
    few class attributes, may override :meth:`_prepare`, and implements :meth:`_step_impl`.

    **Configuration** (class attributes, read by ``__init__``; a subclass never changes base state after it):

    ``name``                the name ``simulate(master=...)`` takes (register the class in :data:`MASTERS`);
    ``solves_loops``        True: algebraic loops of direct feed-through are solved, not refused;
    ``refreshes_discrete``  True: non-Real connections are passed at the END of each step, feed-through chains
                            within the point (see :meth:`_pass_discrete`); False: at the start of the step;
    ``input_derivatives``   False: every instance gets its held (midpoint) inputs as values, never input
                            derivatives (methods that iterate or correct the held values);
    :meth:`history_depth`   the samples of each output kept for the held inputs;
    :meth:`needs_rollback`  True when a step is taken more than once (the FMUs' state is saved);
    :meth:`_prepare`        the hook for a method's own data, called once at the end of ``__init__`` (the
                            coupling layout is ready then); it may refuse FMUs (``SystemDescriptionError``).

    **The loop** (:meth:`run`): per communication step, input signals are applied, the step-control strategy
    (:mod:`harness.master.stepcontrol`) calls :meth:`step` once or more (rolling back with :meth:`snapshot` /
    :meth:`restore` between attempts), and each accepted point goes to the observers
    (:class:`harness.master.observers.Observer`: recording, divergence watch, progress bar).  :meth:`step` passes the
    non-Real connections, calls ``_step_impl``, checks the outputs, books the power bonds' energy and moves
    ``t_ns``.

    **The contract of** ``_step_impl(t, h, t_next)`` (times in s, from the integer ns of :meth:`step`):

    * on entry every FMU is at ``t``; ``self.y`` and the history's newest samples are the consistent outputs at
      ``t``; the held inputs ``self.u`` are those of the previous step;
    * it advances every FMU to ``t_next``, and ONLY through :meth:`_step_fmus` (which calls ``do_step`` and
      counts FMU steps into ``fmu_steps``; a helper that steps an FMU itself, such as a Jacobian estimate, is
      given :meth:`_step_fmus` to call);
    * it may set inputs (:meth:`_hold_all`, :meth:`_set_held_inputs`), save and restore state under its own slot
      names (not ``"step"`` or a controller's), step again, and add to ``iterations`` / ``halvings``;
    * on return ``self.y`` holds consistent outputs at ``t_next`` and the history has their sample at
      ``t_next`` (:meth:`_exchange` does both); ``self.u`` holds the inputs the FMUs held over the step;
    * it returns nothing and leaves ``t_ns``, the bond log and the failure checks to :meth:`step`; a failure is
      raised (an :class:`~harness.errors.FMUError`, :class:`~harness.errors.SimulationError` or
      :class:`ConvergenceError`), never returned.

    **Counters** (kept here only): ``steps`` accepted communication steps of :meth:`run`, ``fmu_steps``
    ``do_step`` calls summed over the FMUs, ``iterations`` of the fixed-point solvers, ``halvings`` steps taken
    again as two halves."""

    name: ClassVar[str] = "base"
    solves_loops: ClassVar[bool] = False
    refreshes_discrete: ClassVar[bool] = False  # pass non-Real feed-through chains within a point (Jacobi)
    input_derivatives: ClassVar[bool] = True   # False: held values only (iterated or corrected methods)
    multirate: ClassVar[bool] = False   # True: instances may step at their own rates (_step_rates)
    checkpointed: ClassVar[tuple] = ()  # a method's own attributes a checkpoint keeps (harness.master.saved)

    def __init__(self, fmus: dict, connections, bonds=(), extrapolation: Polynomial | None = None,
                 iteration: IterationOptions | None = None, tolerance: float | None = None,
                 blowup: float = 1e12):
        self.extrapolation = extrapolation or Polynomial(0)
        self.iteration = iteration or IterationOptions()
        self.tol = self.iteration.tolerance or tolerance or 1e-10
        self.blowup = blowup
        self.fmus = fmus
        mds = {n: f.md for n, f in fmus.items()}
        self.connections = list(connections)
        loops = graph.algebraic_loops(self.connections, mds)
        self.assumed: dict[str, list[str]] = {}
        if loops and not self.solves_loops:
            mds, loops = self._assume_sampled(mds, loops)
        if loops and not self.solves_loops:
            text = "; ".join(" -> ".join(loop) for loop in loops)
            raise AlgebraicLoopError(f"algebraic loop(s) of direct feed-through: {text}; master {self.name!r} "
                                     f"cannot solve them, use master='iterative'", loops)
        self.mds = mds
        self.groups = graph.evaluation_order(self.connections, mds)
        self.loops = loops
        # the signal vector y, the held-input vector u and the non-Real connections (harness.master.coupling)
        lay = coupling.layout(fmus, self.connections, mds, self.extrapolation.order > 0)
        self.insts, self.index = lay.insts, lay.index
        if not self.input_derivatives:
            for it in self.insts:
                it.interp = False
        self.signal_names, self.signal_index = lay.signal_names, lay.signal_index
        self.y = np.zeros(len(lay.signal_names))
        self.history = History(len(lay.signal_names), self.history_depth())
        self.src, self.factor, self.offset, self.u = lay.src, lay.factor, lay.offset, lay.u
        self._discrete = lay.discrete
        self._discrete_chain: list[tuple] = []  # passed after the others, in order (coupling.discrete_refresh)
        if self.refreshes_discrete and lay.discrete:
            self._discrete, self._discrete_chain = coupling.discrete_refresh(lay.discrete)
        self._group_idx = [[self.index[n] for n in g] for g in self.groups]
        in_loops = {n.split(".", 1)[0] for loop in loops for n in loop}
        self._loop_groups = {k for k, g in enumerate(self.groups) if any(n in in_loops for n in g)}
        self._plan = coupling.exchange_plan(self._group_idx, self.insts, self.connections, mds, self._loop_groups)
        self.bonds = list(bonds)
        self._prepare_bonds(bonds)
        self._range = self._declared_range()  # outputs with a declared min/max (checked by _check)
        for b in bonds:  # positions of power bonds: see _held_values
            inst, port = b.motion_in.split(".", 1)
            it = self.insts[self.index[inst]]
            for var in (f"{port}.phi", f"{port}.s"):
                if var in it.input_pos and var in it.fmu.advanced_positions:
                    it.pos_idx = np.append(it.pos_idx, it.input_pos[var]).astype(np.intp)
        # the same positions in u, for the held inputs of all instances at once (_hold_all)
        self._advanced_positions = np.concatenate([it.pos_idx + it.input_slice.start
                                                   for it in self.insts]).astype(np.intp)
        self._advanced_positions_src = self.src[self._advanced_positions]
        self._links = [link for it in self.insts for link in it.links]  # (src, factor, offset) of every entry of u
        self._advanced_positions_list = self._advanced_positions.tolist()
        self._batched = [it for it in self.insts if it.inp.n and not it.interp]
        self._interp = [it for it in self.insts if it.inp.n and it.interp]
        self._slots: dict[str, tuple] = {}
        self._y_list: list | None = None  # y as a list at the end of the last step (None: recompute)
        self.t_ns = 0
        self.steps = 0       # accepted communication steps (run)
        self.iterations = 0  # total iterations (iterative master)
        self.halvings = 0    # steps taken again as two halves (jacobian master: harness.master.jacobian.needs_halving)
        self.fmu_steps = 0   # do_step calls made, summed over the FMUs (only _step_fmus adds to it)
        self.rates: Rates | None = None   # instances at their own rates (use_rates; None: every one at the step)
        self._prepare()

    def _prepare(self) -> None:
        """A method's own data, once the coupling layout is ready (the end of ``__init__``); default: none."""

    def _assume_sampled(self, mds: dict, loops: list) -> tuple[dict, list]:
        """A loop only *assumed* by FMI 2.0's default (outputs without declared ``dependencies`` may depend
        on every input) is not a proven algebraic loop.  The outputs without declared dependencies of the
        instances in such loops are taken as sampled after the step (no feed-through), as libcosim, Ecos and
        OMSimulator take them; this is said once in one :class:`AssumptionWarning`.  Returns the dependency
        view and the loops left (through declared feed-through only; those are still refused)."""
        in_loops = {n.split(".", 1)[0] for loop in loops for n in loop}
        assumed = {n: graph.undeclared_outputs(mds[n]) for n in mds if n in in_loops}
        assumed = {n: outs for n, outs in assumed.items() if outs}
        if not assumed:
            return mds, loops
        view = {n: graph.DeclaredOnly(md) if n in assumed else md for n, md in mds.items()}
        left = graph.algebraic_loops(self.connections, view)
        if left:
            return mds, loops
        self.assumed = assumed
        names = ", ".join(f"{n} ({mds[n].modelName})" for n in assumed)
        warnings.warn(f"master {self.name!r}: FMUs {names} declare no output dependencies; a loop through "
                      f"them is only assumed by FMI 2.0's default, so their outputs are taken as sampled after "
                      f"the step (no direct feed-through), as libcosim, Ecos and OMSimulator do; declared "
                      f"feed-through would need master='iterative'", AssumptionWarning, stacklevel=3)
        return view, left

    def history_depth(self) -> int:
        """Samples of each output the master keeps for its held inputs (all that any method needs)."""
        return DEPTH

    # -- each FMU at its own rate (harness.master.multirate) -----------------------------------------------------
    def use_rates(self, rates: dict[str, int], step_ns: int | None = None) -> None:
        """Step the instances of ``rates`` (name -> whole multiple of the base step ``step_ns``, > 1) at their own
        rates; the others at the base step.  A master that cannot (``multirate`` False) refuses in one line naming it and
        the instances; no rate above 1 leaves the master as it was (the single-rate path, bit for bit)."""
        slow = {n: r for n, r in rates.items() if r > 1}
        if not slow:
            return
        if not self.multirate:
            able = ", ".join(sorted(_multirate_masters()))
            listed = ", ".join(f"{n} (every {r} steps)" for n, r in slow.items())
            raise SystemDescriptionError(f"master {self.name!r} cannot step instances at their own rates: {listed}; "
                                         f"use one of {able}, or give every instance the base step")
        self.rates = Rates(self, slow, step_ns)

    @property
    def fresh(self) -> set | None:
        """The instances at a communication point of their own at the master's time (None: every one)."""
        return None if self.rates is None else self.rates.fresh

    def _step_rates(self, t_ns: int, h_ns: int) -> None:
        """One base step with instances at their own rates (a multirate method implements it)."""
        raise NotImplementedError

    def _exchange_some(self, t: float, which: list[int]) -> None:
        """:meth:`_exchange` restricted to the instances ``which`` (at a point of their own at ``t``): the others'
        outputs keep their last samples."""
        self._run_plan(self.rates.plan(self._plan, which), t)
        for sl in self.rates.ranges(which):
            self.history.push(sl, t, self.y[sl])

    def _pass_discrete_rates(self) -> None:
        """:meth:`_pass_discrete` under rates: only the connections whose two ends' rates both divide the base
        steps taken (:meth:`harness.master.multirate.Rates.discrete_now`)."""
        now = self.rates.discrete_now()
        n = len(self._discrete)
        sampled = [(link, ok) for link, ok in zip(self._discrete, now[:n])]
        values = [src.get_value(sv) if ok else None for (src, sv, *_), ok in sampled]
        for (link, ok), value in zip(sampled, values):
            if ok:
                link[2].set_value(link[3], coupling.passed_value(link, value, self.t_ns / NS))
        for link, ok in zip(self._discrete_chain, now[n:]):
            if ok:
                src, sv, dst, dv, _ = link
                dst.set_value(dv, coupling.passed_value(link, src.get_value(sv), self.t_ns / NS))

    # -- power bonds -------------------------------------------------------------------------------------------
    def _prepare_bonds(self, bonds) -> None:
        """Per bond: indices of the effort held by the motion-out instance (in ``u``), its speed output (in
        ``y``), the speed held by the motion-in instance (in ``u``) and its effort output (in ``y``).
        ``bond_energy`` accumulates the coupling energy error per bond."""
        self.bond_labels, rows = [], []
        for b in bonds:
            a_inst, a_port = b.motion_out.split(".", 1)
            b_inst, b_port = b.motion_in.split(".", 1)
            ia, ib = self.insts[self.index[a_inst]], self.insts[self.index[b_inst]]
            tr = f"{a_inst}.{a_port}.v" in self.signal_index
            _, v, e = ("s", "v", "f") if tr else ("phi", "w", "tau")
            try:
                rows.append((ia.input_slice.start + ia.input_pos[f"{a_port}.{e}"],
                             self.signal_index[f"{a_inst}.{a_port}.{v}"],
                             ib.input_slice.start + ib.input_pos[f"{b_port}.{v}"],
                             self.signal_index[f"{b_inst}.{b_port}.{e}"]))
            except KeyError as err:
                raise SystemDescriptionError(f"bond {b.label}: variable {err.args[0]} is not part of the bond's "
                                             f"connections")
            self.bond_labels.append(b.label)
        self._bonds = [tuple(r) for r in rows]
        self.bond_log = np.zeros((3, len(rows)))  # rows P_out, P_in [W] over the last step, energy error [J]
        self.bond_power = self.bond_log[:2]       # [P_out, P_in] (views of bond_log)
        self.bond_energy = self.bond_log[2]       # accumulated integral of P_out - P_in

    def _bond_step(self, y0: list, y: list, h: float) -> None:
        """P_out = held effort x mean speed, P_in = mean effort x held speed over the step; energy += (P_out -
        P_in) * h (trapezoidal means of the outputs at both ends of the step).  In plain floats: a drive has
        a handful of bonds, too few for numpy to pay."""
        u = self.u.tolist()
        p_out = [u[tau_held] * 0.5 * (y0[w_out] + y[w_out]) for tau_held, w_out, _, _ in self._bonds]
        p_in = [0.5 * (y0[tau_out] + y[tau_out]) * u[w_held] for _, _, w_held, tau_out in self._bonds]
        energy = [e + (a - b) * h for e, a, b in zip(self.bond_log[2].tolist(), p_out, p_in)]
        self.bond_log[:] = (p_out, p_in, energy)

    # -- coupling primitives -----------------------------------------------------------------------------------
    def _pass_discrete(self, t: float) -> None:
        """Integer, Boolean, String and Enumeration connections: each target input takes its source's value
        at the current communication point ``t`` (through the connection's value mapping if it has one,
        :func:`harness.master.coupling.passed_value`) and holds it over the step (no extrapolation), as libcosim
        and Ecos pass such values.  A master that refreshes feed-through
        (``refreshes_discrete``: ``jacobi``, ``iterative``) passes them at the END of each step, so a
        feed-through output is recorded with its input of the same point, and then passes the connections
        whose source declares a direct dependency on a value just set, in chain order
        (:func:`harness.master.coupling.discrete_refresh`); the others pass them at the start of the step."""
        values = [src.get_value(sv) for src, sv, *_ in self._discrete]  # every source first: a target
        for link, value in zip(self._discrete, values):                # may feed one through
            _, _, dst, dv, _ = link
            dst.set_value(dv, coupling.passed_value(link, value, t))
        for link in self._discrete_chain:
            src, sv, dst, dv, _ = link
            dst.set_value(dv, coupling.passed_value(link, src.get_value(sv), t))

    def _read(self, it: _Inst) -> None:
        self.y[it.output_slice] = it.fmu.get(it.out)

    def _read_all(self, t: float) -> None:
        """Every instance's outputs at t, then one history sample of all of them (Jacobi family)."""
        values: list = []
        for it in self.insts:
            values += it.fmu.get_list(it.out)
        self.y[:] = values
        self.history.push_all(t, self.y)

    @staticmethod
    def _set_point_inputs(it: _Inst, values: list) -> None:
        """Inputs of ``it`` at a communication point, factor * y + offset from ``values`` (``y`` as a list), in plain
        floats: the same products and sums as on arrays, without an array for a drive's few inputs."""
        if it.links:
            it.fmu.set_list(it.inp, [factor * values[src] + offset for src, factor, offset in it.links])

    def _set_held_inputs(self, it: _Inst, t: float, h: float) -> None:
        """Inputs of ``it`` for the step [t, t+h] from the source histories (see harness.master.extrapolation)."""
        if not it.inp.n:
            return
        if it.interp:
            value, ders = self.extrapolation.at_start(self.history, it.src, t)
            it.held[:] = it.factor * value + it.offset
            it.fmu.set(it.inp, it.held)
            for order, d in enumerate(ders, start=1):
                it.fmu.set_input_derivatives(it.inp, order, it.factor * d)
        else:
            it.held[:] = self._held_values(it, t, h)
            it.fmu.set(it.inp, it.held)

    def _hold_all(self, t: float, h: float) -> None:
        """:meth:`_set_held_inputs` for every instance at once (the same values, computed on the whole input
        vector with one extrapolation; Jacobi family, where every source's history is at t)."""
        hist = self.history
        if hist.newest == t and hist.full and self.extrapolation.order <= 1 and not self._interp:
            self._hold_all_floats(t, h)
        else:
            self._hold_all_arrays(t, h)

    def _hold_all_arrays(self, t: float, h: float) -> None:
        """:meth:`_hold_all` on arrays: the general case and the reference of :meth:`_hold_all_floats`
        (tests/test_harness_masters.py runs with the arrays only and compares bit for bit)."""
        u = self.u
        np.multiply(self.factor, self.extrapolation.held(self.history, self.src, t, h), out=u)
        u += self.offset
        pos = self._advanced_positions
        hist = self.history
        newest = hist.newest  # no source has a sample newer than t: the held position IS the start sample
        if pos.size and (self.extrapolation.order or newest is None or newest > t):
            src = self._advanced_positions_src
            newer = hist.t[0, src] > t
            if self.extrapolation.order or newer.any():
                start = np.where(newer, hist.y[1, src], hist.y[0, src])
                u[pos] = self.factor[pos] * start + self.offset[pos]
        values = u.tolist()
        for it in self._batched:
            it.fmu.set_list(it.inp, values[it.input_slice])
        for it in self._interp:
            self._set_held_inputs(it, t, h)

    def _hold_all_floats(self, t: float, h: float) -> None:
        """:meth:`_hold_all` in plain floats for its common case: every source's newest sample is at t and the
        history is full, extrapolation order 0 or 1 (a drive's few dozen inputs are cheaper as floats than
        through numpy's fancy indexing).  The same operations in the same order as the array path
        (:meth:`harness.master.extrapolation.Polynomial.held`, then ``factor * held + offset``), so the same values bit for
        bit; an advanced position (:meth:`_held_values`) takes the start sample ``y0``."""
        hist = self.history
        y0 = hist.y[0].tolist()
        links = self._links
        if self.extrapolation.order == 0:
            held = [y0[s] for s, _, _ in links]
        else:
            te = t + 0.5 * h
            y1, t1 = hist.y[1].tolist(), hist.t[1].tolist()
            a = te - t  # te - t0, t0 = t for every source (newest == t)
            held = [y0[s] + a / (t - t1[s]) * (y0[s] - y1[s]) for s, _, _ in links]
            for k in self._advanced_positions_list:
                held[k] = y0[links[k][0]]
        values = [f * v + o for (_, f, o), v in zip(links, held)]
        self.u[:] = values
        for it in self._batched:
            it.fmu.set_list(it.inp, values[it.input_slice])

    def _held_values(self, it: _Inst, t: float, h: float) -> np.ndarray:
        """Held inputs of ``it`` over [t, t+h]: the extrapolation's value (harness.master.extrapolation), except for
        the position of a power bond (phi or s at a motion-input port) that the FMU declares it advances
        itself with the held speed over the step (fmus.slave.PressSlave.advances_position): it gets the
        position at the step START (for Gauss-Seidel the sample at t, not the newer one at t+h)."""
        held = it.factor * self.extrapolation.held(self.history, it.src, t, h) + it.offset
        if it.pos_idx.size:
            src = it.src[it.pos_idx]
            newer = self.history.t[0, src] > t
            if self.extrapolation.order == 0 and not newer.any():
                return held  # the start sample IS the held value (bit for bit the same expression)
            start = np.where(newer, self.history.y[1, src], self.history.y[0, src])
            held[it.pos_idx] = it.factor[it.pos_idx] * start + it.offset[it.pos_idx]
        return held

    def _exchange(self, t: float) -> None:
        """Consistent outputs at communication point t (the plan of :func:`exchange_plan`); pushes them to the
        history."""
        self._run_plan(self._plan, t)
        self.history.push_all(t, self.y)

    def _run_plan(self, plan: list, t: float) -> None:
        """Evaluate an exchange plan at ``t`` into ``y``: visit (set the point inputs of) and read each instance in
        turn, solve each algebraic loop."""
        y = self.y
        values = y.tolist()
        insts = self.insts
        for op, arg in plan:
            if op == "loop":
                y[:] = values
                self._solve_loop(arg, t)
                values = y.tolist()
                continue
            it = insts[arg]
            if op == "visit":
                self._set_point_inputs(it, values)
            values[it.output_slice] = it.fmu.get_list(it.out)
        y[:] = values

    def _solve_loop(self, group: list[int], t: float) -> None:
        """Resolve an algebraic loop among ``group`` at a communication point (iterative master)."""
        members = [self.insts[i] for i in group]
        u0 = np.concatenate([it.factor * self.y[it.src] + it.offset for it in members])

        def g(u):
            k = 0
            for it in members:
                n = it.inp.n
                it.fmu.set(it.inp, u[k:k + n])
                k += n
            for it in members:
                self._read(it)
            return np.concatenate([it.factor * self.y[it.src] + it.offset for it in members])

        where = (f"algebraic loop {' / '.join(it.name for it in members)} at t = {t:.9g} s")
        _u, _gu, n = solve_fixed_point(g, u0, self.iteration, self.tol, where)
        self.iterations += n

    # -- rollback ----------------------------------------------------------------------------------------------
    def snapshot(self, slot: str = "step") -> None:
        """Save every FMU's state and the master's coupling data under ``slot``."""
        old = self._slots.get(slot)
        states = []
        for k, it in enumerate(self.insts):
            if old is not None:
                it.fmu.free_state(old[0][k])
            states.append(it.fmu.get_state())
        self._slots[slot] = (states, self.y.copy(), self.history.snapshot(), self.u.copy(),
                             self.bond_log.copy(), self.t_ns, None if self.rates is None else self.rates.state())

    def restore(self, slot: str = "step") -> None:
        states, y, hist, u, bonds, t_ns, rates = self._slots[slot]
        if rates is not None:
            self.rates.set_state(rates)
        for it, s in zip(self.insts, states):
            it.fmu.set_state(s)
        self.y[:] = y
        self.history.copy_from(hist)
        self.u[:] = u
        self.bond_log[:] = bonds
        self._y_list = None
        self.t_ns = t_ns

    def needs_rollback(self) -> bool:
        return False

    def refresh(self, t: float) -> None:
        """Consistent outputs at communication point t again, after inputs were set from outside the coupling
        (input signals, :mod:`harness.signals`): an output that depends directly on such an input passes its
        new value on in this step, not one step late."""
        if self.rates is not None:
            self._exchange_some(t, self.rates.starting(self.t_ns))
        else:
            self._exchange(t)
        self._y_list = None

    def coupling_signals(self) -> np.ndarray:
        """Indices into ``y`` of the outputs that feed a connection (all outputs when none does)."""
        idx = sorted({int(s) for s in self.src})
        return np.array(idx if idx else range(len(self.y)), dtype=np.intp)

    # -- life cycle --------------------------------------------------------------------------------------------
    def initialize(self, start_ns: int = 0, stop_ns: int | None = None, tolerance: float | None = None,
                   parameters: dict | None = None) -> None:
        """setupExperiment, parameters (``{instance: {name: value}}``), initialization with consistent
        inputs and outputs."""
        t = start_ns / NS
        stop = stop_ns / NS if stop_ns is not None else None
        for i, it in enumerate(self.insts):
            own = stop   # an instance at its own rate ends its last own step at or after the run's stop
            if self.rates is not None and stop_ns is not None and self.rates.r[i] > 1 and self.rates.step_ns:
                own = self.rates.stop_of(i, start_ns, stop_ns) / NS
            it.fmu.setup(t, own, tolerance)
            for k, v in (parameters or {}).get(it.name, {}).items():
                it.fmu.set_value(k, v)
        for it in self.insts:
            it.fmu.enter_initialization()
        self._exchange(t)  # outputs in initialization mode, then every input from them
        values = self.y.tolist()
        for it in self.insts:
            self._set_point_inputs(it, values)
        if self._discrete:
            self._pass_discrete(t)
        self._exchange(t)
        for it in self.insts:
            it.fmu.exit_initialization()
        self.history = History(len(self.y), self.history_depth())
        self._exchange(t)
        self._check(t)
        self._y_list = None
        self.t_ns = start_ns
        if self.rates is not None:
            self.rates.start(start_ns)
            self.u[:] = self.factor * self.y[self.src] + self.offset   # every connection passes at the start

    def step(self, t_ns: int, h_ns: int) -> None:
        """One communication step from t_ns (must be the current time) of h_ns nanoseconds."""
        t, h, t_next = t_ns / NS, h_ns / NS, (t_ns + h_ns) / NS
        y0 = self._y_list if self._y_list is not None else self.y.tolist()
        if self.rates is not None:
            discrete = bool(self._discrete or self._discrete_chain)
            if discrete and not self.refreshes_discrete:
                self._pass_discrete_rates()
            self._step_rates(t_ns, h_ns)
            if discrete and self.refreshes_discrete:
                self.t_ns = t_ns + h_ns
                self._pass_discrete_rates()
        else:
            if self._discrete and not self.refreshes_discrete:
                self._pass_discrete(t)  # values sampled at t, held over the step
            self._step_impl(t, h, t_next)
            if self._discrete and self.refreshes_discrete:
                self._pass_discrete(t_next)  # refreshed at t_next, as Real feed-through is, before the point is recorded
        y = self._y_list = self.y.tolist()
        self._check(t_next, y)
        if self._bonds:
            self._bond_step(y0, y, h)
        self.t_ns = t_ns + h_ns

    def _step_impl(self, t: float, h: float, t_next: float) -> None:
        """Advance every FMU from t to t_next (= t + h) and leave consistent outputs at t_next in
        ``self.y`` (and the history): the contract in the class docstring."""
        raise NotImplementedError

    def _step_fmus(self, insts, t: float, h: float, *, no_prior_state: bool) -> None:
        """``do_step(t, h)`` of each instance in ``insts``, in order: the one place FMU steps are taken and
        counted.  ``no_prior_state``: FMI's noSetFMUStatePriorToCurrentPoint (True: this step will not be
        rolled back)."""
        for it in insts:
            it.fmu.do_step(t, h, no_prior_state=no_prior_state)
        self.fmu_steps += len(insts)

    def run(self, controller, stop_ns: int, observers=(), inputs=None, first_ns: int | None = None) -> int:
        """THE run loop: communication steps from ``t_ns`` (after :meth:`initialize`) to ``stop_ns``, each taken
        by ``controller.advance`` (:mod:`harness.master.stepcontrol`, starting with its ``step_ns``).  ``inputs``
        (None or a :class:`harness.signals.Signals`): applied at each point before the step (``apply(t_ns)``),
        the point's outputs made consistent again when a signal drives an instance that feeds others, and at
        one of its ``step_times`` the history restarted (no coupling signal is extrapolated across an event) and
        a variable step control restarted from its first step; a variable step also ends on each of the inputs'
        row times (``next_time``).
        ``observers`` (:class:`harness.master.observers.Observer`) see the start, each input event, each accepted point
        and the end, in the order given; ``on_end`` runs however the run ends; one that can finish the run
        (``can_finish``) ends it, complete, after the step where it sets ``finished``.  ``first_ns``: the first
        step (default the controller's; a run resumed from a checkpoint takes the step proposed when it stopped).
        Returns the time reached [ns]; the controller's ``next_ns`` is the step it proposes next."""
        observers = list(observers)
        t_ns = self.t_ns
        refresh = inputs is not None and any(c.source.split(".", 1)[0] in inputs.instances
                                             for c in self.connections)
        completed = False
        enders = [o for o in observers if o.can_finish]
        try:
            for o in observers:
                o.on_start(self, t_ns)
            h_ns = controller.step_ns if first_ns is None else first_ns
            while t_ns < stop_ns:
                if inputs is not None:
                    inputs.apply(t_ns)
                    if refresh:
                        self.refresh(t_ns / NS)
                    if t_ns in inputs.step_times:  # an event: no coupling signal is extrapolated across it,
                        self.history.restart()       # a variable step control starts again from its first step
                        if controller.variable:
                            controller.restart()
                            h_ns = controller.step_ns
                        for o in observers:
                            o.on_event(self, t_ns)
                # a variable step lands on each row time of the input table (a step, a ramp's corner)
                event_ns = inputs.next_time(t_ns) if inputs is not None and controller.variable else None
                t_prev = t_ns
                until = stop_ns if event_ns is None else min(stop_ns, event_ns)
                t_ns, h_ns = controller.advance(self, t_ns, h_ns, until)
                controller.next_ns = h_ns
                self.steps += 1
                for o in observers:
                    o.on_step(self, t_prev, t_ns)
                if enders and any(o.finished for o in enders):   # an observer ends the run here, complete
                    break
            completed = True
        finally:
            for o in observers:
                o.on_end(self, t_ns, completed)
        return t_ns

    def _declared_range(self) -> tuple | None:
        """(indices into y, min, max) of the Real outputs that declare ``min`` or ``max`` (None: none does)."""
        idx, lo, hi = [], [], []
        for k, name in enumerate(self.signal_names):
            inst, var = name.split(".", 1)
            v = self.fmus[inst].variables.get(var)
            a, b = getattr(v, "min", None), getattr(v, "max", None)
            if a not in (None, "") or b not in (None, ""):
                idx.append(k)
                lo.append(float(a) if a not in (None, "") else -math.inf)
                hi.append(float(b) if b not in (None, "") else math.inf)
        return (np.array(idx, dtype=np.intp), np.array(lo), np.array(hi)) if idx else None

    def _check(self, t: float, values: list | None = None) -> None:
        """Stop on a non-finite output, one beyond the blow-up limit (``values``: ``y`` as a list) or one
        outside the range its FMU declares (``min``/``max``)."""
        values = self.y.tolist() if values is None else values
        rng = self._range
        if rng is not None:
            idx, lo, hi = rng
            v = self.y[idx]
            out = (v < lo) | (v > hi)
            if out.any():
                j = int(np.argmax(out))
                k = int(idx[j])
                inst, var = self.signal_names[k].split(".", 1)
                raise SimulationError(f"t = {t:.9g} s: instance {inst}: output {var} = {float(self.y[k])!r} is "
                                      f"outside the range [{lo[j]:g}, {hi[j]:g}] its FMU "
                                      f"{self.fmus[inst].md.modelName} declares", time=t, instance=inst,
                                      variable=var)
        # every value is finite when the sum is (else: find the culprit below); then the largest magnitude
        if not values or (math.isfinite(sum(values)) and max(map(abs, values)) <= self.blowup):
            return
        y = self.y
        bad = ~np.isfinite(y) | (np.abs(y) > self.blowup)
        if bad.any():
            k = int(np.argmax(bad))
            name = self.signal_names[k]
            inst, var = name.split(".", 1)
            what = "is not finite" if not math.isfinite(y[k]) else f"exceeds the blow-up limit {self.blowup:g}"
            raise BlowUp(f"t = {t:.9g} s: instance {inst}: output {var} = {float(y[k])!r} {what}",
                                  time=t, instance=inst, variable=var)

    def terminate(self) -> None:
        for it in self.insts:
            try:
                it.fmu.terminate()
            except FMUError:
                pass

    def free(self) -> None:
        for it in self.insts:
            it.fmu.free()
        self._slots.clear()


def _multirate_masters() -> dict:
    """The defined masters that hold rates, by name (subclasses of :class:`Master` with ``multirate``)."""
    found, todo = {}, list(Master.__subclasses__())
    while todo:
        cls = todo.pop(0)
        if cls.multirate:
            found.setdefault(cls.name, cls)
        todo.extend(cls.__subclasses__())
    return found
