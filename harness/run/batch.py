"""Many variants of one system in one run: :func:`simulate_batch`.

The variants are start values over the system's (``{"Instance.param": value}``, as :func:`harness.run.simulate`
takes them).  Those with the same integer parameters (fidelity, law, mechanism, branch: the structure) are stepped
together by the batch form of the master (:mod:`harness.master.batch`), their components' physics on arrays over the
variants (:mod:`fmus.batch`), in chunks of at most ``BatchOptions.chunk`` variants; each variant's numbers are those
of its own scalar run, bit for bit.  What is kept of each variant is asked for with :class:`Keep`: the columns over
time (its result frame, as :func:`simulate` returns it), and quantities of interest reduced as the run goes
(:mod:`harness.reporting.qoi_stream`), so a thousand variants need not hold a thousand time series.

A variant that fails in the batch (a parameter its FMU refuses, a state or output that is not finite or beyond the
blow-up limit) is taken out of it, and run again on its own with :func:`simulate` (``BatchOptions.rerun``): its
result, error and message are then exactly its scalar run's.  So is one whose power bonds the batch's divergence
screen (:mod:`harness.master.batch_watch`) cannot clear: a run the scalar divergence detector might have stopped.

Where the batch does not apply (:func:`refusal`: an FMU the toolkit did not build, a method whose algebra does not
vectorise, variable step control, input signals, isolation, checkpoints, an instance at its own rate) the caller
runs each variant with :func:`simulate`.
"""
from __future__ import annotations

import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harness.errors import SimulationError, SystemDescriptionError
from harness.master.clock import NS
from harness.master.observers import Observer


MIN_VARIANTS = 8   # from about this many variants on a batch costs less than running them one by one (benchmarks)


@dataclass(frozen=True)
class Keep:
    """What a batch keeps of each variant: ``columns`` over time (None: every Real output; () none) as its
    result frame (``frames``), with the engineering quantities in ``attrs["quantities"]`` (``quantities``), and the
    quantities of interest ``reduce`` (name -> :mod:`harness.reporting.qoi` expression) as values."""
    columns: tuple[str, ...] | None = ()
    frames: bool = False
    quantities: bool = False
    reduce: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class BatchOptions:
    """``chunk``: most variants stepped at once (memory); ``vectorise``: the components' vectorised physics where
    they have it (False: each variant's scalar model in a loop, the same numbers); ``rerun``: a variant that fails,
    or that the divergence screen cannot clear, runs again on its own; ``blowup``: as :class:`RunOptions`;
    ``progress``: a callback ``(done, total)``."""
    chunk: int = 1024
    vectorise: bool = True
    rerun: bool = True
    blowup: float = 1e12
    screen: bool = True
    progress: object = None


@dataclass
class VariantResult:
    """One variant: ``start_values`` as given, ``complete``, ``error`` (one line, '' when complete), ``frame``
    (:class:`Keep` ``frames``), ``values`` (the reduced quantities, in :class:`Keep` ``reduce``'s order, up to the
    first that cannot be computed: ``value_error`` its one line), ``alone`` (True: the result of its own scalar run,
    after it failed in the batch or the screen could not clear it; ``reason`` why)."""
    start_values: dict
    complete: bool = True
    error: str = ""
    frame: pd.DataFrame | None = None
    values: dict = field(default_factory=dict)
    alone: bool = False
    reason: str = ""
    value_error: str = ""


@dataclass
class BatchRun:
    """The variants' results in the order given, and how the batch ran (``info``: groups, forms of each
    component's physics, CPU seconds by part, the vector math in use)."""
    results: list[VariantResult]
    info: dict


def refusal(system, settings: dict) -> str | None:
    """Why the variants of ``system`` under ``settings`` (:func:`simulate`'s keyword arguments) cannot be run as a
    batch (one line), None when they can."""
    from harness.master.batch import REFUSED, BATCH_MASTERS
    from harness.master import master_class

    foreign = [i.name for i in system.instances if _component(i.fmu) is None]
    if foreign:
        return (f"instance {foreign[0]} is an FMU other than this toolkit's build of its components "
                f"({system.instance(foreign[0]).fmu})")
    exp = system.experiment
    master = settings.get("master") or (exp.master if exp else "jacobi")
    key = master_class(master).name
    if key in REFUSED:
        return f"master {key!r} does not step a batch: {REFUSED[key]}"
    if key not in BATCH_MASTERS:
        return f"master {key!r} has no batch form"
    control = settings.get("step_control", exp.step_control if exp else None)
    if control not in (None, "none"):
        return f"step control {control!r} chooses each variant's own steps"
    for name in ("input", "isolate", "tolerance", "checkpoint", "from_checkpoint"):
        if settings.get(name) is not None:
            return (f"{name} is given (a batch runs fixed steps from the start, with no input signals or "
                    f"checkpoints, in this process)")
    own = [i.name for i in system.instances if getattr(i, "step", None) is not None]
    step = settings.get("step", settings.get("step_size"))
    if not own and exp is not None and exp.rates and any(r > 1 for r in exp.rates.values()) \
            and master_class(master) is master_class(exp.master) and (step is None or step == exp.step):
        own = sorted(n for n, r in exp.rates.items() if r > 1)
    if own:
        return f"instance {own[0]} steps at its own rate (multirate: every variant's own run)"
    options = settings.get("options")
    if options is not None:
        from dataclasses import replace

        from harness.run.simulation import RunOptions

        if replace(options, progress=None, logging=True) != RunOptions(progress=None):
            return "run options other than the defaults are given"
    return None


def _experiment(system, settings: dict) -> dict:
    """The run's settings as :func:`simulate` resolves them (the system's default experiment for those not given),
    checked the same way."""
    from harness.run.parameters import _positive
    from harness.run.simulation import _output_interval

    exp = system.experiment
    if exp is None and (settings.get("stop_time") is None or settings.get("step") is None):
        raise SystemDescriptionError(f"system {system.name} has no default experiment: give stop_time and step")
    stop = _positive("stop_time", settings.get("stop_time") if settings.get("stop_time") is not None else exp.stop_time)
    step = _positive("step", settings.get("step") if settings.get("step") is not None else exp.step)
    start = settings.get("start_time")
    start = start if start is not None else (exp.start_time if exp else 0.0)
    start_ns, stop_ns, step_ns = int(round(start * NS)), int(round(stop * NS)), int(round(step * NS))
    if not 0 <= start_ns < stop_ns or step_ns < 1 or step_ns > stop_ns - start_ns:
        raise SystemDescriptionError(f"start_time {start!r}, stop_time {stop!r}, step {step!r}: not a run")
    sample_ns = _output_interval(settings.get("output_interval"), step, step_ns, None)
    return dict(master=settings.get("master") or (exp.master if exp else "jacobi"),
                extrapolation=settings.get("extrapolation") if settings.get("extrapolation") is not None else
                (exp.extrapolation if exp else 0),
                start_ns=start_ns, stop_ns=stop_ns, step_ns=step_ns, sample_ns=sample_ns,
                step=step, start_time=start, stop_time=stop)


def simulate_batch(system, variants: list[dict], settings: dict | None = None, keep: Keep | None = None,
                   options: BatchOptions | None = None) -> BatchRun:
    """Run every variant (start values over the system's) of ``system`` under ``settings`` (:func:`simulate`'s
    stop_time, step, master, extrapolation, start_time, output_interval) and keep of each what ``keep`` asks
    (module docstring).  Raises :class:`SystemDescriptionError` where the batch does not apply (:func:`refusal`)."""
    from fmus.physics.mathns import VECTOR
    from harness.run.systems import load

    system = load(system)
    settings = dict(settings or {})
    keep = keep or Keep(columns=None, frames=True)
    options = options or BatchOptions()
    why = refusal(system, settings)
    if why is not None:
        raise SystemDescriptionError(f"system {system.name}: no batch: {why}")
    run = _experiment(system, settings)
    math_status = VECTOR.check()
    wall, cpu = _time.perf_counter(), _time.process_time()
    results = [VariantResult(dict(v)) for v in variants]
    groups, refused, built = _groups(system, variants)
    info = dict(system=system.name, master=run["master"], variants=len(variants), vector_math=math_status,
                groups=[], costs={}, rerun=0)
    for i, why in refused.items():
        results[i].complete, results[i].error = False, why
    done = len(refused)
    for key, members in groups:
        for start in range(0, len(members), max(1, options.chunk)):
            chunk = members[start:start + options.chunk]
            _run_chunk(system, run, [built[i] for i in chunk], [results[i] for i in chunk], keep, options, info)
            done += len(chunk)
            if options.progress is not None:
                options.progress(done, len(variants))
    if options.rerun:
        for r in results:
            if not r.complete or r.reason:
                _alone(system, settings, r, keep)
                info["rerun"] += 1
    info.update(wall_time=_time.perf_counter() - wall, cpu_time=_time.process_time() - cpu)
    return BatchRun(results, info)


def _groups(system, variants: list[dict]):
    """The variants by structure: ([(structure, [variant indices])] in the order first seen, {variant: why it cannot
    be built}, {variant: its models by instance}).  Each value is checked against the FMUs' declarations as
    :func:`simulate` checks it (the system itself once)."""
    from fmus.batch import build_model, model_structure
    from harness.model import model_description, resolve_fmu
    from harness.run.parameters import split_parameters

    mds = {inst.name: model_description(resolve_fmu(inst.fmu)) for inst in system.instances}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        system.validate(mds)
    check = system.values_check(mds)
    groups: dict = {}
    refused: dict[int, str] = {}
    built: dict[int, dict] = {}
    declarations = _declarations(system)
    for i, v in enumerate(variants):
        try:
            check(v)
            params = split_parameters(system, v)
        except SystemDescriptionError as e:
            refused[i] = str(e)
            continue
        key, models, why = [], {}, None
        for inst in system.instances:
            model, why = build_model(declarations[inst.name], params[inst.name])
            if model is None:
                why = f"system {system.name}: instance {inst.name}: {why}"
                break
            models[inst.name] = model
            key.append(model_structure(model))
        if why is not None:
            refused[i] = why
            continue
        built[i] = models
        groups.setdefault(tuple(key), []).append(i)
    return list(groups.items()), refused, built


def _declarations(system) -> dict:
    """Instance name -> its component's declaration class."""
    import importlib

    out = {}
    for inst in system.instances:
        model, script = _component(inst.fmu)
        out[inst.name] = getattr(importlib.import_module(f"fmus.components.{script}"), model)
    return out


def _component(fmu) -> tuple[str, str] | None:
    """(model name, declaration module) of an instance's FMU when it is this toolkit's build of one of its
    components: a model name of the catalog, or an FMU file (an SSP's, an exported one) whose bundled code is the
    component's present code (its module ``pd_<name>_<hash>``, the hash over the declaration and the runtime,
    :func:`fmus.build.code_hash`); None for any other FMU, whose numbers a batch cannot promise."""
    import zipfile

    from fmus.build import catalog, code_hash

    cat = catalog()
    name = str(fmu)
    if name in cat:
        return name, cat[name].stem
    path = Path(name)
    if path.suffix.lower() != ".fmu" or not path.is_file():
        return None
    known = _CODE.get(path)
    if known is None or known[0] != path.stat().st_mtime_ns:
        found = None
        try:
            with zipfile.ZipFile(path) as z:
                names = z.namelist()
        except (OSError, zipfile.BadZipFile):
            names = []
        for model, script in cat.items():
            if f"resources/{script.stem}_{code_hash(script)}.py" in names:
                found = (model, script.stem)
                break
        known = _CODE[path] = (path.stat().st_mtime_ns, found)
    return known[1]


_CODE: dict = {}   # FMU file -> (modification time, its component or None)


def _run_chunk(system, run: dict, models: list[dict], results: list[VariantResult], keep: Keep,
               options: BatchOptions, info: dict) -> None:
    """Step one chunk of variants of one structure (``models``: each variant's models by instance) together and
    fill their results."""
    from fmus.batch import Batch
    from harness.master.batch import BatchEmpty, BatchInstance, batch_master_class
    from harness.master.extrapolation import extrapolation as make_extrapolation
    from harness.model import model_description, resolve_fmu

    declarations = _declarations(system)
    fmus = {}
    for inst in system.instances:
        unit = Batch(declarations[inst.name], inst.name, [m[inst.name] for m in models], options.vectorise)
        fmus[inst.name] = BatchInstance(inst.name, model_description(resolve_fmu(inst.fmu)), unit)
    mds = {n: f.md for n, f in fmus.items()}
    cls = batch_master_class(run["master"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = cls(fmus, system.all_connections(mds), system.bonds, make_extrapolation(run["extrapolation"]),
                options.blowup)
    info["groups"].append({"variants": len(models), "forms": {n: f.unit.form for n, f in fmus.items()}})
    rec = BatchRecording(m, keep, run, system)
    m.keep_signals(rec.columns + rec.reducers.columns())
    observers = [rec]
    screen = None
    if options.screen and m.bond_labels:
        from harness.master.batch_watch import DivergenceScreen

        screen = DivergenceScreen(m)
        observers.append(screen)
    from harness.master.stepcontrol import FixedStep

    controller = FixedStep(run["step_ns"])
    error = None
    try:
        with np.errstate(all="ignore"):   # a failing variant's NaN and inf are found by the checks, not warned
            m.initialize(run["start_ns"], run["stop_ns"])
            m.run(controller, run["stop_ns"], observers)
    except BatchEmpty:
        pass
    except SimulationError as e:     # the batch itself stopped: every variant left runs on its own
        error = str(e).splitlines()[0]
    for k, cost in m.costs.items():
        info["costs"][k] = info["costs"].get(k, 0.0) + cost
    flagged = screen.flagged() if screen is not None else {}
    for k, r in enumerate(results):
        if k in m.failures:
            t, why = m.failures[k]
            r.complete, r.error = False, why
        elif error is not None:
            r.complete, r.error = False, error
        elif k in flagged:
            r.reason = flagged[k]
        rec.fill(k, r)


class BatchRecording(Observer):
    """What :class:`Keep` asks of every variant, at the rows a scalar run records: the start, every
    ``sample_ns`` and the stop (rows x columns x variants; a variant's rows end where it failed)."""

    def __init__(self, master, keep: Keep, run: dict, system):
        from harness.reporting.qoi_stream import Reducers

        self.master, self.keep, self.run, self.system = master, keep, run, system
        n0 = master.n
        every = keep.columns is None or keep.quantities     # the quantities read what the drive declares
        columns = list(master.signal_names) if every else list(keep.columns)
        unknown = [c for c in columns if c not in master.signal_index]
        if unknown:
            raise SystemDescriptionError(f"output {unknown[0]!r}: not a Real output of system {system.name}")
        self.columns = columns
        self.reducers = Reducers(dict(keep.reduce), master.signal_index, n0)
        self._frame_idx = np.array([master.signal_index[c] for c in columns], dtype=np.intp)
        self.sample_ns, self.start_ns, self.stop_ns = run["sample_ns"], run["start_ns"], run["stop_ns"]
        rows = -(-(self.stop_ns - self.start_ns) // self.sample_ns) + 1
        self.time = np.empty(rows)
        self.data = np.full((rows, len(columns), n0), np.nan) if columns else None
        self.rows = 0
        self.last = np.full(n0, -1)
        self.batch_size = n0          # the variants stepped together (a frame's attrs["batch"])

    def _record(self, t_ns: int) -> None:
        m, k = self.master, self.rows
        t = t_ns / NS
        self.time[k] = t
        alive = m.alive
        whole = len(alive) == self.last.size
        if self.data is not None:
            values = m.Y[self._frame_idx]
            if whole:
                self.data[k] = values
            else:
                self.data[k][:, alive] = values
        self.last[alive] = k
        self.rows = k + 1
        self.reducers.row(t, m.Y, alive, k, self.stop_ns == t_ns)

    def on_start(self, master, t_ns):
        self._record(t_ns)

    def on_step(self, master, t_prev_ns, t_ns):
        if (t_ns - self.start_ns) % self.sample_ns == 0 or t_ns >= self.stop_ns:
            self._record(t_ns)

    def fill(self, k: int, result: VariantResult) -> None:
        """Result ``result`` of variant ``k`` from what was recorded."""
        n = int(self.last[k]) + 1
        if self.keep.frames and self.data is not None:
            df = pd.DataFrame(self.data[:n, :, k].copy(), columns=self.columns,
                              index=pd.Index(self.time[:n].copy(), name="time"))
            from harness.run.simulation import column_units

            m = self.master
            df.attrs.update(system=self.system.name, master=m.name, extrapolation=m.extrapolation.order,
                            step_control="none", step=self.run["step"], start_time=self.run["start_time"],
                            stop_time=self.run["stop_time"], tolerance=None, output_interval=self.sample_ns / NS,
                            inputs=[], units=column_units(m.fmus, self.columns),
                            start_values=dict(result.start_values), steps=max(0, n - 1), fmu_steps=max(0, n - 1) *
                            len(m.insts), complete=result.complete, error=result.error, suspect=result.reason,
                            diverged=False, blew_up=False, interrupted=False, bad_input=False,
                            batch=self.batch_size)
            if self.keep.quantities:
                from harness.reporting.quantities import quantities

                df.attrs["quantities"] = quantities(self.system, df)
            result.frame = df
        if self.keep.reduce and result.complete:
            from harness.reporting.qoi import QoIError

            try:
                self.reducers.values(k, self.time[:n], result.values)
            except QoIError as e:    # as a sweep's point reports it: the values before it kept
                result.value_error = f"QoIError: {e}".splitlines()[0]


def _alone(system, settings: dict, result: VariantResult, keep: Keep) -> None:
    """``result`` from the variant's own scalar run (:func:`simulate`)."""
    from harness.reporting import qoi
    from harness.run.simulation import simulate

    columns = None if keep.columns is None or keep.quantities else (list(keep.columns) + [
        c for e in dict(keep.reduce).values() for c in qoi.columns(e)]) or None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            df = simulate(system, start_values=dict(result.start_values), output=columns,
                          **{k: v for k, v in settings.items() if v is not None})
    except Exception as e:   # noqa: BLE001 (the variant's own error, as a scalar run reports it)
        result.complete, result.frame, result.alone = False, None, True
        result.error = f"{type(e).__name__}: {e}".splitlines()[0]
        return
    result.complete = bool(df.attrs.get("complete", True))
    result.error = "" if result.complete else str(df.attrs.get("error") or "incomplete run").splitlines()[0]
    result.frame = df if keep.frames else None
    result.alone = True
    result.values = {}
    if result.complete:
        for name, expr in keep.reduce:
            try:
                result.values[name] = qoi.evaluate(expr, df)
            except qoi.QoIError as e:
                result.value_error = f"QoIError: {e}".splitlines()[0]
                break


__all__ = ["simulate_batch", "refusal", "Keep", "BatchOptions", "VariantResult", "BatchRun"]
