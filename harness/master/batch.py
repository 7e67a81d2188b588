"""Many variants of one system stepped together by the same master algebra: :class:`BatchMaster` and its methods
(``jacobi``, ``jacobi-sampled``, ``gauss-seidel``; :data:`BATCH_MASTERS`).

A batch is N variants of one system that differ in real-valued parameters (their integer parameters, the
structure, are the same: :mod:`harness.run.batch` groups them).  Each instance is a :class:`fmus.batch.Batch`: the
component's physics for all variants at once, run as its FMU runs each one, in place of N FMUs.  The master is the
scalar master (:class:`harness.master.loop.Master`: its coupling layout, evaluation order, exchange plan and power
bonds, built from the same model descriptions) with a variant axis on its two vectors: the signals ``Y`` (signals x
variants) and the held inputs ``U`` (inputs x variants).  Every product and sum of the scalar method is taken on
those arrays, element by element, and the extrapolation is the scalar one on a history whose columns are
(signal, variant) pairs, so each variant's numbers are its scalar run's, bit for bit, wherever the physics is
(:mod:`fmus.physics.variants`).

A variant that fails (an input outside its range, a state or output not finite or beyond the blow-up limit, an
output outside its declared range) is taken out of the batch at the end of that step, its reason and time kept
(:attr:`BatchMaster.failures`); the others go on.  ``alive`` maps the batch's columns to the variants given.

The methods whose algebra does not vectorise here refuse by name (:func:`batch_master_class`): ``iterative``
(each variant's own fixed-point iteration, with its own count and convergence) and ``jacobian`` (interface
Jacobians estimated by rollback per variant).
"""
from __future__ import annotations

import time as _time

import numpy as np

from harness.errors import SimulationError, SystemDescriptionError
from harness.fmi.instance import RealBlock
from harness.master.clock import NS
from harness.master.explicit import GaussSeidel, Jacobi
from harness.master.extrapolation import History
from harness.master.loop import Master

REFUSED = {
    "iterative": "its fixed-point iteration runs per variant, with its own iteration count and convergence test, "
                 "and repeats steps by rollback",
    "jacobian": "its interface Jacobians are estimated per variant by rollback and extra FMU steps, and a step "
                "is halved where a contact is made",
}


class BatchEmpty(SimulationError):
    """Every variant of a batch has failed: the run stops (each variant's reason is in ``failures``)."""


class BatchInstance:
    """What the master's layout reads of an FMU instance (:class:`harness.fmi.FMUInstance`), for a
    :class:`fmus.batch.Batch` of variants: the model description of the component's FMU (the same the scalar run
    reads) and the value references of its variables."""

    can_get_set_state = True
    can_vary_step = True
    can_interpolate_inputs = False
    provides_directional_derivative = False
    path_kind = "batch"

    def __init__(self, name: str, md, unit):
        self.name, self.md, self.unit = name, md, unit
        self.variables = {v.name: v for v in md.modelVariables}
        self.advanced_positions = {unit.input_names[ip] for ip, _ in unit.advanced}
        self.time = None

    def var(self, name: str):
        v = self.variables.get(name)
        if v is None:
            raise SystemDescriptionError(f"instance {self.name}: FMU {self.md.modelName} has no variable {name!r}")
        return v

    def reals(self, names) -> RealBlock:
        return RealBlock(list(names), [self.var(n).valueReference for n in names])


class _Columns:
    """An instance's places in the batch: its connected inputs in its unit's order (``in_idx``), the outputs read
    (``out_idx`` in the unit's order, ``rows`` in the signals), its sources (``src``, and among the history's
    (signal, variant) columns ``srcN``), its outputs' history columns (``hist_slice``), the connections' factor and
    offset as columns (``unit``: every factor is 1, so ``factor * y`` is ``y`` itself, bit for bit)."""
    __slots__ = ("in_idx", "out_idx", "rows", "src", "srcN", "hist_slice", "fac", "off", "unit")

    def __init__(self, it, in_idx, out_idx, rows, srcN, hist_slice):
        self.in_idx, self.out_idx, self.rows, self.srcN, self.hist_slice = in_idx, out_idx, rows, srcN, hist_slice
        self.src = it.src
        self.fac, self.off = it.factor[:, None], it.offset[:, None]
        self.unit = bool(np.all(it.factor == 1.0))

    def linked(self, y: np.ndarray) -> np.ndarray:
        """``factor * y + offset`` (connections' values from their sources' ``y``, inputs x variants)."""
        return y + self.off if self.unit else self.fac * y + self.off


class BatchMaster(Master):
    """The scalar master's algebra on arrays over the variants (module docstring); a method sets
    :meth:`_step_impl` as its scalar class does."""

    def __init__(self, fmus: dict, connections, bonds=(), extrapolation=None, blowup: float = 1e12):
        super().__init__(fmus, connections, bonds, extrapolation, None, None, blowup)
        if self._discrete:
            raise SystemDescriptionError("a batch passes Real connections only; this system connects Integer, "
                                         "Boolean or String variables")
        self.n = next(iter(fmus.values())).unit.n
        self.alive = np.arange(self.n)          # the variants given, by column
        self.failures: dict[int, tuple[float, str]] = {}   # variant -> (time, one line)
        self._failing: dict[int, tuple[float, str]] = {}   # column -> (time, one line), within a step
        self.Y = np.zeros((len(self.signal_names), self.n))
        self.U = np.zeros((len(self.src), self.n))
        self.history = History(len(self.signal_names) * self.n, self.history_depth())
        self.bond_log = np.zeros((3, len(self._bonds), self.n))
        # the signals read: those that feed a connection or a power bond, and those declaring a range (checked);
        # :meth:`keep_signals` adds what is recorded (default: every signal)
        self.needed = set(range(len(self.signal_names)))
        self._unit_factor = bool(np.all(self.factor == 1.0))
        self._prepare_batch()
        self.costs: dict[str, float] = {it.name: 0.0 for it in self.insts}   # seconds in each component
        self.costs["master"] = 0.0

    def keep_signals(self, names) -> None:
        """Read only the signals that feed a connection or a bond, declare a range, or are named here (recorded):
        an output nobody reads is not computed (the vectorised physics leaves it out where it can)."""
        need = {int(k) for k in self.src} | {int(k) for b in self._bonds for k in (b[1], b[3])}
        if self._range is not None:
            need |= {int(k) for k in self._range[0]}
        need |= {self.signal_index[nm] for nm in names}
        self.needed = need
        self._prepare_batch()

    def _prepare_batch(self) -> None:
        """The index arrays over (signal, variant) columns for the present number of variants."""
        n = self.n
        cols = np.arange(n)
        self._srcN = (self.src[:, None] * n + cols).reshape(-1)
        self._fac, self._off = self.factor[:, None], self.offset[:, None]
        pos = self._advanced_positions
        self._posN = (self._advanced_positions_src[:, None] * n + cols).reshape(-1) if pos.size else pos
        self._c = {}
        self._needed_rows = np.array(sorted(self.needed), dtype=np.intp)
        for it in self.insts:
            unit = it.fmu.unit
            read = [k for k in range(it.output_slice.start, it.output_slice.stop) if k in self.needed]
            rows = (slice(read[0], read[-1] + 1) if read and read[-1] - read[0] + 1 == len(read) else
                    np.array(read, dtype=np.intp))
            out_idx = [unit.out_index[it.out.names[k - it.output_slice.start]] for k in read]
            self._c[it.name] = _Columns(it, [unit.in_index[nm] for nm in it.inp.names], out_idx, rows,
                                        (it.src[:, None] * n + cols).reshape(-1),
                                        slice(it.output_slice.start * n, it.output_slice.stop * n))
            unit.rows = sorted(out_idx) if len(out_idx) < len(unit.output_names) else None
        self.bond_power = self.bond_log[:2]
        self.bond_energy = self.bond_log[2]
        self._b = tuple(np.array([b[k] for b in self._bonds], dtype=np.intp) for k in range(4))

    # -- values ------------------------------------------------------------------------------------------------
    def _unit_set(self, it, values: np.ndarray) -> None:
        it.fmu.unit.set_inputs(self._c[it.name].in_idx, values)

    def _read(self, it) -> None:
        t0 = _time.process_time()
        c = self._c[it.name]
        if c.out_idx:
            self.Y[c.rows] = it.fmu.unit.outputs(c.out_idx)
        self.costs[it.name] += _time.process_time() - t0

    def _set_point_inputs_batch(self, it) -> None:
        c = self._c[it.name]
        if c.in_idx:
            self._unit_set(it, c.linked(self.Y[c.src]))

    def _exchange(self, t: float) -> None:
        for op, arg in self._plan:
            it = self.insts[arg]
            if op == "visit":
                self._set_point_inputs_batch(it)
            self._read(it)
        self.history.push_all(t, self.Y.reshape(-1))

    def _read_all(self, t: float) -> None:
        for it in self.insts:
            self._read(it)
        self.history.push_all(t, self.Y.reshape(-1))

    def _extrapolated(self, idx: np.ndarray, idxN: np.ndarray, t: float, h: float) -> np.ndarray:
        """:meth:`harness.master.extrapolation.Polynomial.held` of the sources ``idx`` (signals; ``idxN`` their
        (signal, variant) columns) over every variant, signals x variants.  Where every source has its full set of
        samples (the polynomial's fast path) the weights are computed once per signal from its sample times, the
        same for every variant, and applied to the variants' values: the same operations element by element."""
        hist, order, n = self.history, self.extrapolation.order, self.n
        cols = idx * n
        if order == 0:
            return hist.y[0].reshape(-1, n)[idx]
        if hist.n[cols].min() <= order:
            return self.extrapolation.held(hist, idxN, t, h).reshape(-1, n)
        te = t + 0.5 * h
        ts = hist.t[:order + 1, cols][:, :, None]
        y = hist.y[:order + 1].reshape(order + 1, -1, n)[:, idx]     # whole rows of variants: no element gather
        if order == 1:
            return y[0] + (te - ts[0]) / (ts[0] - ts[1]) * (y[0] - y[1])
        a, b, c = te - ts[0], te - ts[1], te - ts[2]
        return (y[0] * b * c / ((ts[0] - ts[1]) * (ts[0] - ts[2]))
                + y[1] * a * c / ((ts[1] - ts[0]) * (ts[1] - ts[2]))
                + y[2] * a * b / ((ts[2] - ts[0]) * (ts[2] - ts[1])))

    def _held(self, t: float, h: float) -> np.ndarray:
        """The held inputs of every instance (inputs x variants): :meth:`Master._hold_all_arrays`' values."""
        n = self.n
        hist = self.history
        held = self._extrapolated(self.src, self._srcN, t, h)
        U = held + self._off if self._unit_factor else self._fac * held + self._off
        pos = self._advanced_positions
        newest = hist.newest
        if pos.size and (self.extrapolation.order or newest is None or newest > t):
            newer = hist.t[0, self._posN] > t
            if self.extrapolation.order or newer.any():
                start = np.where(newer, hist.y[1, self._posN], hist.y[0, self._posN]).reshape(-1, n)
                U[pos] = start + self._off[pos] if self._unit_factor else self._fac[pos] * start + self._off[pos]
        return U

    def _hold_all(self, t: float, h: float) -> None:
        self.U = self._held(t, h)
        for it in self._batched:
            self._unit_set(it, self.U[it.input_slice])

    def _held_values_batch(self, it, t: float, h: float) -> np.ndarray:
        """:meth:`Master._held_values` of one instance, inputs x variants."""
        n, hist = self.n, self.history
        c = self._c[it.name]
        held = c.linked(self._extrapolated(c.src, c.srcN, t, h))
        if it.pos_idx.size:
            src = (it.src[it.pos_idx][:, None] * n + np.arange(n)).reshape(-1)
            newer = hist.t[0, src] > t
            if self.extrapolation.order == 0 and not newer.any():
                return held
            start = np.where(newer, hist.y[1, src], hist.y[0, src]).reshape(-1, n)
            held[it.pos_idx] = it.factor[it.pos_idx][:, None] * start + it.offset[it.pos_idx][:, None]
        return held

    # -- stepping ----------------------------------------------------------------------------------------------
    def _step_fmus(self, insts, t: float, h: float, *, no_prior_state: bool) -> None:
        for it in insts:
            t0 = _time.process_time()
            for k, why in it.fmu.unit.step(t, h):
                self._fail(k, t, f"instance {it.name}: {why}")
            self.costs[it.name] += _time.process_time() - t0
        self.fmu_steps += len(insts) * self.n

    def _fail(self, k: int, t: float, why: str) -> None:
        self._failing.setdefault(int(k), (t, why))

    def initialize(self, start_ns: int = 0, stop_ns: int | None = None, tolerance=None, parameters=None) -> None:
        """The scalar master's initialisation (:meth:`Master.initialize`) on the batch; the parameters are the
        units' own (each variant's, given when they were built)."""
        t = start_ns / NS
        self._failing: dict[int, tuple[float, str]] = {}
        for it in self.insts:
            it.fmu.unit.setup(t)
        self._exchange(t)
        for it in self.insts:
            self._set_point_inputs_batch(it)
        self._exchange(t)
        for it in self.insts:
            for k, why in it.fmu.unit.exit_initialization():
                self._fail(k, t, f"instance {it.name}: {why}")
        self.history = History(len(self.signal_names) * self.n, self.history_depth())
        self._exchange(t)
        self._check_batch(t)
        self._drop_failed()
        self.t_ns = start_ns

    def step(self, t_ns: int, h_ns: int) -> None:
        t, h, t_next = t_ns / NS, h_ns / NS, (t_ns + h_ns) / NS
        c0 = _time.process_time()
        spent = sum(self.costs.values())
        self._drop_failed()      # those an observer failed at the last point (the divergence screen)
        Y0 = self.Y.copy() if self._bonds else None
        self._step_impl(t, h, t_next)
        self._check_batch(t_next)
        if self._bonds:
            self._bond_step_batch(Y0, h)
        self.t_ns = t_ns + h_ns
        self._drop_failed()
        self.costs["master"] += (_time.process_time() - c0) - (sum(self.costs.values()) - spent)

    def _check_batch(self, t: float) -> None:
        """:meth:`Master._check` per variant: non-finite, beyond the blow-up limit, outside a declared range."""
        Y = self.Y
        rng = self._range
        if rng is not None:
            idx, lo, hi = rng
            out = (Y[idx] < lo[:, None]) | (Y[idx] > hi[:, None])
            for k in np.flatnonzero(out.any(axis=0)).tolist():
                j = int(np.argmax(out[:, k]))
                inst, var = self.signal_names[int(idx[j])].split(".", 1)
                self._fail(k, t, f"t = {t:.9g} s: instance {inst}: output {var} = {float(Y[idx[j], k])!r} is outside "
                                 f"the range [{lo[j]:g}, {hi[j]:g}] its FMU {self.fmus[inst].md.modelName} declares")
        rows = self._needed_rows
        if (np.abs(Y[rows]) <= self.blowup).all():      # finite and within the limit (NaN compares False)
            return
        bad = np.zeros(Y.shape, dtype=bool)
        bad[rows] = ~np.isfinite(Y[rows]) | (np.abs(Y[rows]) > self.blowup)
        for k in np.flatnonzero(bad.any(axis=0)).tolist():
            j = int(np.argmax(bad[:, k]))
            inst, var = self.signal_names[j].split(".", 1)
            what = "is not finite" if not np.isfinite(Y[j, k]) else f"exceeds the blow-up limit {self.blowup:g}"
            self._fail(k, t, f"t = {t:.9g} s: instance {inst}: output {var} = {float(Y[j, k])!r} {what}")

    def _bond_step_batch(self, Y0: np.ndarray, h: float) -> None:
        """:meth:`Master._bond_step` per variant."""
        tau_held, w_out, w_held, tau_out = self._b
        U, Y = self.U, self.Y
        p_out = U[tau_held] * 0.5 * (Y0[w_out] + Y[w_out])
        p_in = 0.5 * (Y0[tau_out] + Y[tau_out]) * U[w_held]
        self.bond_log[2] = self.bond_log[2] + (p_out - p_in) * h
        self.bond_log[0], self.bond_log[1] = p_out, p_in

    def _drop_failed(self) -> None:
        """Take the variants that failed in this step out of the batch (their reason and time kept)."""
        if not self._failing:
            return
        for k, why in self._failing.items():
            self.failures[int(self.alive[k])] = why
        keep = np.array([k for k in range(self.n) if k not in self._failing], dtype=np.intp)
        self._failing = {}
        if not keep.size:
            raise BatchEmpty(f"every variant of the batch failed (the last at t = "
                             f"{max(t for t, _ in self.failures.values()):.9g} s)")
        self.alive = self.alive[keep]
        old_n, self.n = self.n, len(keep)
        hist = self.history
        cols = (np.arange(len(self.signal_names))[:, None] * old_n + keep).reshape(-1)
        new = History(len(self.signal_names) * self.n, hist.depth)
        new.t[:] = hist.t[:, cols]
        new.y[:] = hist.y[:, cols]
        new.n[:] = hist.n[cols]
        new._newest, new._full = hist._newest, hist._full
        self.history = new
        self.Y, self.U = self.Y[:, keep], self.U[:, keep]
        self.bond_log = self.bond_log[:, :, keep]
        for it in self.insts:
            it.fmu.unit.keep(keep)
        self._prepare_batch()

    def refresh(self, t: float) -> None:
        self._exchange(t)

    def terminate(self) -> None:
        pass

    def free(self) -> None:
        pass


class BatchJacobi(BatchMaster):
    """``jacobi`` on the batch: :class:`harness.master.explicit.Jacobi`'s own step on the batch's arrays."""
    name = "jacobi"
    history_depth = Jacobi.history_depth
    _step_impl = Jacobi._step_impl
    _outputs_at = BatchMaster._exchange


class BatchJacobiSampled(BatchJacobi):
    """``jacobi-sampled`` on the batch (:class:`harness.master.explicit.JacobiSampled`)."""
    name = "jacobi-sampled"
    _outputs_at = BatchMaster._read_all


class BatchGaussSeidel(BatchMaster):
    """``gauss-seidel`` on the batch (:class:`harness.master.explicit.GaussSeidel`: its stepping order)."""
    name = "gauss-seidel"
    _prepare = GaussSeidel._prepare

    def _step_impl(self, t, h, t_next):
        point = self.extrapolation.order >= 1
        n = self.n
        for it in self.order:
            if len(self._c[it.name].in_idx):
                held = self._held_values_batch(it, t, h)
                self.U[it.input_slice] = held
                self._unit_set(it, held)
            self._step_fmus((it,), t, h, no_prior_state=True)
            if point and it.feedthrough and len(self._c[it.name].in_idx):
                value = self.extrapolation.value(self.history, self._c[it.name].srcN, t_next).reshape(-1, n)
                self._unit_set(it, it.factor[:, None] * value + it.offset[:, None])
            self._read(it)
            self.history.push(self._c[it.name].hist_slice, t_next, self.Y[it.output_slice].reshape(-1))
        self._exchange(t_next)


BATCH_MASTERS = {"jacobi": BatchJacobi, "jacobi-sampled": BatchJacobiSampled, "gauss-seidel": BatchGaussSeidel}


def batch_master_class(name: str) -> type[BatchMaster]:
    """The batch form of the master ``name`` (a name :func:`harness.master.master_class` takes); the methods
    whose algebra does not vectorise are refused in one line saying why."""
    from harness.master import master_class

    key = master_class(name).name
    if key in REFUSED:
        raise SystemDescriptionError(f"master {key!r} cannot step a batch of variants: {REFUSED[key]}; each variant "
                                     f"runs on its own (or use jacobi, jacobi-sampled or gauss-seidel)")
    return BATCH_MASTERS[key]


__all__ = ["BatchMaster", "BatchEmpty", "BatchInstance", "BatchJacobi", "BatchJacobiSampled", "BatchGaussSeidel",
           "BATCH_MASTERS", "REFUSED", "batch_master_class"]
