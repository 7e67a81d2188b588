"""Running a system: :func:`simulate` (:mod:`harness.run`; loading is :mod:`harness.run.systems`, the command
line :mod:`harness.run.cli`).

``simulate(system, stop_time=None, step=None, master=None, extrapolation=None, step_control=None,
tolerance=None, start_values=None, output=None, *, start_time=None, output_interval=None, input=None,
on_error="return", options=None)`` returns the result DataFrame (see :mod:`harness.results`); FMPy's names
``step_size`` and ``relative_tolerance`` work too.  Arguments left at None come from the system's default
experiment (then: master ``jacobi``, extrapolation 0, fixed step).  Further options live in :class:`RunOptions`
(iteration of the ``iterative`` master, step-control limits, blow-up limit, progress bar, FMU logging).

(:func:`simulate`'s argument checks and the assembly of its result; the loop is
:meth:`harness.master.Master.run`, input signals live in :mod:`harness.signals`.)

Failures during the run (an FMU error, a non-finite output, an output beyond the blow-up limit, an iteration
that does not converge) stop it with a one-line message naming the time, the instance and the variable or
FMI call.  With ``on_error="return"`` (default) the result up to the last good communication point is
returned with ``attrs["complete"] = False`` and ``attrs["error"]`` (and a :class:`RunWarning` is issued);
``on_error="raise"`` raises :class:`~harness.errors.SimulationError` whose ``partial`` is that DataFrame.
Errors in the system description (:class:`~harness.errors.SystemDescriptionError`) are always raised before the run.

"""

from __future__ import annotations

import math
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.master.divergence import Diverged, DivergenceOptions, DivergenceWatch
from harness.errors import BlowUp, FMUError, SimulationError, SystemDescriptionError
from harness.errors import ParameterRefused  # an FMU refused a parameter value (typed, fmus.refusal)
from harness.errors import interruption
from harness.master.extrapolation import extrapolation as make_extrapolation
from harness.fmi import FMUInstance, open_instance, release
from harness.master import ConvergenceError, IterationOptions, master_class
from harness.master.clock import NS
from harness.master.multirate import rates_of
from harness.model import model_description, resolve_fmu
from harness.master.observers import ProgressBar, Recording
from harness.reporting.quantities import quantities
from harness.results import Recorder
from harness.signals import Signals, full_name
from harness.master.stepcontrol import StepOptions, step_control as make_step_control
from harness.run.checkpoint import (Checkpoint, Resume, Resumed, Writer, manifest, refuse_unserializable,
                                    signals_digest)
from harness.run.interrupts import RunInterrupted, RunWarning
from harness.run.systems import load
from harness.run.parameters import _positive, _renamed, split_parameters


@dataclass
class RunOptions:
    """Options of :func:`simulate` beyond its keyword arguments.

    ``iteration``: the ``iterative`` master's solver; ``steps``: limits of the variable-step controllers;
    ``blowup``: an output whose magnitude exceeds it stops the run (amplitude blow-up); ``progress``: tqdm
    progress bar (None: only when stderr is a terminal, shown after 2 s); ``logging``: FMU debug logging;
    ``in_process``: how pythonfmu FMUs are called (:func:`harness.fmi.open_instance`: None runs every
    pythonfmu FMU whose script imports here in this process, the others through FMI with one warning; True
    requires it; False calls every FMU through FMI).  Results are the same bit for bit; only the cost differs.
    ``divergence``: thresholds of the divergence detector on the power bonds (:mod:`harness.master.divergence`);
    None switches it off.  ``isolate``: run FMUs in child processes of their own (:mod:`harness.fmi.isolated`:
    True or "foreign" every FMU not built by the toolkit, "all" every FMU, or an ``Isolation`` with its
    per-call timeout), so a crash or hang inside an FMU call stops the run in one line and keeps its rows;
    None/False (default) runs every FMU in this process.  ``observers``: further
    :class:`harness.master.observers.Observer` objects the run loop calls, after the recording and the divergence watch
    (docs/howto/add-an-observer.md)."""
    iteration: IterationOptions = field(default_factory=IterationOptions)
    steps: StepOptions = field(default_factory=StepOptions)
    blowup: float = 1e12
    progress: bool | None = None
    logging: bool = True
    in_process: bool | None = None
    divergence: DivergenceOptions | None = field(default_factory=DivergenceOptions)
    isolate: object = None
    observers: tuple = ()


def simulate(system, stop_time: float | None = None, step: float | None = None, master: str | None = None,
             extrapolation=None, step_control: str | None = None, tolerance: float | None = None,
             start_values: dict | None = None, output: list[str] | None = None, *, start_time: float | None = None,
             output_interval: float | None = None, input=None, on_error: str = "return",
             options: RunOptions | None = None, isolate=None, checkpoint=None, from_checkpoint=None,
             **other_names) -> pd.DataFrame:
    """Co-simulate ``system`` and return its result: a DataFrame indexed by time [s], one column per
    ``Instance.variable`` (in the FMU's declared unit, ``df.attrs["units"]``).

    The arguments of ``fmpy.simulate_fmu`` work here with the same meaning: ``start_time``, ``stop_time``,
    ``step_size`` (the communication step, also written ``step`` as on the command line), ``relative_tolerance``
    (also ``tolerance``), ``output_interval``, ``start_values``, ``output``, ``input``.  A system of one FMU (a
    bare .fmu) takes the FMU's own variable names as FMPy does; the columns stay ``Instance.variable``.
    FMPy's other arguments are a TypeError saying what takes their place (docs/fmpy.md).

    Arguments (None: the system's default experiment, then the fallback named):

    * ``system``: a module name in ``systems/`` (``"bed_drive"``), a .py file defining ``SYSTEM``, an
      .ssp/.ssd file, an .fmu file (run alone), or a :class:`System`.
    * ``start_time`` [s]: start of the run (default: the default experiment's, else 0; finite, before
      ``stop_time``).
    * ``stop_time`` [s]: end of the run (positive).
    * ``step`` or ``step_size`` [s]: communication step (positive, >= 1 ns, at most ``stop_time -
      start_time``; the first step of a variable-step run; default: the default experiment's, else
      ``output_interval``, as FMPy steps a co-simulation FMU).
    * ``output_interval`` [s]: record every this often (a whole multiple of the step, fixed step only;
      default: every communication point); the end of the run is always recorded.
    * ``master``: ``"jacobi"`` (fallback), ``"jacobi-sampled"``, ``"gauss-seidel"``, ``"iterative"`` or
      ``"jacobian"`` (:data:`harness.master.MASTERS`).
    * ``extrapolation``: order of the held inputs, 0 (hold, fallback), 1 or 2 (polynomial at the step midpoint).
    * ``step_control``: None/``"none"`` (fixed step, fallback), ``"richardson"`` or ``"ecco"``.
    * ``tolerance`` or ``relative_tolerance`` [-]: passed to the FMUs (fmi2SetupExperiment), and the
      tolerance of step control and of the iterative master (positive; fallback none, the iteration then
      uses 1e-10).
    * ``start_values``: ``{"Instance.parameter": value}`` in the parameter's declared unit, over the system's
      values (default: none; the command line's ``--set``).  A value the FMU refuses returns an empty result,
      ``attrs["bad_input"]`` True, with a one-line error naming the instance, parameter, value, unit and
      admissible range.
    * ``output``: ``["Instance.variable", ...]`` to record (default: every Real output; ``--output``).
    * ``input``: signals for free inputs: a structured numpy array (FMPy's ``input``), a DataFrame or a CSV
      file with a ``time`` column and one column per ``Instance.variable`` input, interpolated as FMPy does
      (continuous Real linearly, the others held; two rows at one time are a step), set at each
      communication point before the step (:mod:`harness.signals`; ``--input``).
    * ``on_error``: ``"return"`` (default): a run that stops early (divergence, FMU failure, non-finite
      output) returns what it computed with ``attrs["complete"] = False`` and a one-line ``attrs["error"]``
      (``attrs["diverged"]`` if the divergence detector stopped it) and warns :class:`RunWarning`; a run
      that ends while the power on a bond is still growing geometrically stays complete and carries the
      detector's one line in ``attrs["suspect"]`` (also warned; '' otherwise);
      ``"raise"``: raises :class:`~harness.errors.SimulationError` whose ``partial`` is that result.
    * ``options``: :class:`RunOptions` (iteration, step-control limits, blow-up limit, divergence detector,
      progress bar, FMU logging, in-process calls, isolation); default ``RunOptions()``.
    * ``isolate``: ``RunOptions.isolate`` given here (True: every foreign FMU in a child process of its own).
    * ``checkpoint``: a file, or (file, time [s]): write the whole run's state there at the first communication
      point at or after that time (default: the stop time) and run on (:mod:`harness.run.checkpoint`;
      ``--checkpoint``, ``--checkpoint-at``); ``df.attrs["checkpoint"]`` says where and when.
    * ``from_checkpoint``: a checkpoint file to continue from, to ``stop_time`` (``--from-checkpoint``): the
      result is the run that was never interrupted, bit for bit; parameters that differ from the checkpoint's
      are set at its time.
    * ``other_names``: FMPy's ``step_size`` and ``relative_tolerance``; ``parameters=`` and ``outputs=``, this
      function's former names of ``start_values`` and ``output``, still accepted with a DeprecationWarning.

    Ctrl-C raises :class:`RunInterrupted` (a KeyboardInterrupt) whose ``partial`` is the result so far,
    marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``.  Errors in the description or the
    arguments raise :class:`~harness.errors.SystemDescriptionError` before the run."""
    if other_names:
        moved = _renamed(other_names, dict(step=step, tolerance=tolerance, start_values=start_values,
                                           output=output))
        step, tolerance = moved.get("step", step), moved.get("tolerance", tolerance)
        start_values, output = moved.get("start_values", start_values), moved.get("output", output)
    system = load(system)
    opts = options or RunOptions()
    if isolate is not None:
        import dataclasses

        opts = dataclasses.replace(opts, isolate=isolate)
    if opts.isolate is not None:
        from harness.fmi.isolated import Isolation

        Isolation.of(opts.isolate)   # a bad value in one line before anything runs
    if on_error not in ("return", "raise"):
        raise SystemDescriptionError(f"on_error = {on_error!r} is not admissible: must be 'return' or 'raise'")
    exp = system.experiment
    if stop_time is None:
        if exp is None:
            raise SystemDescriptionError(f"system {system.name} has no default experiment: give stop_time")
        stop_time = exp.stop_time
    if step is None and (exp is None or exp.step is None) and output_interval is not None:
        step = output_interval  # as fmpy.simulate_fmu steps a co-simulation FMU: one step per output interval
    if step is None:
        if exp is None:
            raise SystemDescriptionError(f"system {system.name} has no default experiment: give step")
        if exp.step is None:  # an SSP's DefaultExperiment without a step (OSP's annotation gives one)
            raise SystemDescriptionError(f"system {system.name}: its default experiment declares no step: give step "
                                         f"(--step on the command line)")
        step = exp.step
    master = master if master is not None else (exp.master if exp else "jacobi")
    extrapolation = extrapolation if extrapolation is not None else (exp.extrapolation if exp else 0)
    step_control = step_control if step_control is not None else (exp.step_control if exp else None)
    tolerance = tolerance if tolerance is not None else (exp.tolerance if exp else None)
    start_time = start_time if start_time is not None else (exp.start_time if exp else 0.0)
    stop_time, step = _positive("stop_time", stop_time), _positive("step", step)
    if tolerance is not None:
        _positive("tolerance", tolerance, unit="")
    if (isinstance(start_time, bool) or not isinstance(start_time, (int, float)) or not math.isfinite(start_time)
            or not 0.0 <= start_time < stop_time):
        raise SystemDescriptionError(f"start_time = {start_time!r} is not admissible: must be a finite number in "
                                     f"[0, stop_time = {stop_time!r}) [s]")
    start_ns, stop_ns, step_ns = int(round(start_time * NS)), int(round(stop_time * NS)), int(round(step * NS))
    if step_ns < 1:
        raise SystemDescriptionError(f"step = {step!r} is not admissible: master time has a resolution of 1 ns")
    if step_ns > stop_ns - start_ns:
        raise SystemDescriptionError(f"step = {step!r} s is longer than the run from start_time = {start_time!r} s to "
                                     f"stop_time = {stop_time!r} s" if start_ns else
                                     f"step = {step!r} s is longer than stop_time = {stop_time!r} s")
    sample_ns = _output_interval(output_interval, step, step_ns, step_control)
    rates = {**_declared_rates(system, master, step_ns), **rates_of(system.instances, step_ns,
                                                                      f"system {system.name}")}   # own rates
    request = Checkpoint.of(checkpoint)
    resume = Resume(from_checkpoint) if from_checkpoint is not None else None
    cls = master_class(master)
    extra = make_extrapolation(extrapolation)
    params = split_parameters(system, start_values)
    output = None if output is None else [full_name(system, c) for c in output]

    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    signals = None
    if input is not None:
        signals = (input.for_run(system, mds, system.all_connections(mds)) if hasattr(input, "for_run") else
                   Signals(system, mds, system.all_connections(mds), input))   # a table, or a libcosim scenario
        for inst, values in signals.start_values(start_ns).items():  # set before the FMUs initialize
            params[inst].update(values)
    system.validate(mds, {f"{i}.{k}": v for i, d in params.items() for k, v in d.items()})
    connections = system.all_connections(mds)

    fmus: dict[str, FMUInstance] = {}
    m = None
    try:
        for inst in system.instances:
            fmus[inst.name] = open_instance(paths[inst.name], inst.name, opts.logging, opts.in_process,
                                            isolate=opts.isolate)
        m = cls(fmus, connections, system.bonds, extra, opts.iteration, tolerance, opts.blowup)
        m.use_rates(rates, step_ns)
        if hasattr(signals, "attach"):   # a libcosim scenario acts on the master's coupling (harness.osp.scenario)
            signals.attach(m)
        controller = make_step_control(step_control, m, step_ns, tolerance, _step_options(opts, exp))
        if m.rates is not None and controller.variable:
            raise SystemDescriptionError(f"step_control = {controller.name!r} varies the step, but instances "
                                         f"{', '.join(rates)} step at their own rates (a whole multiple of a fixed "
                                         f"base step): use a fixed step, or give every instance the base step")
        if not controller.variable and (stop_ns - start_ns) % step_ns:
            for name, f in fmus.items():
                if not f.can_vary_step:
                    raise SystemDescriptionError(f"stop_time = {stop_time!r} s is not a multiple of step = {step!r} "
                                                 f"s and instance {name} cannot take a shorter last step")
        n_rows = -(-(stop_ns - start_ns) // sample_ns) + 1 if not controller.variable else 1024
        rec = Recorder(m, output, n_rows)
        if signals is not None:
            signals.bind(fmus)
        info = dict(system=system.name, master=cls.name, extrapolation=extra.order,
                    step_control=controller.name, step=step, start_time=start_time, stop_time=stop_time,
                    tolerance=tolerance, output_interval=sample_ns / NS, inputs=signals.names if signals else [],
                    units=column_units(fmus, rec.columns))
        info["start_values"] = {k: (v.item() if hasattr(v, "item") else v) for k, v in (start_values or {}).items()}
        writer = None
        if request is not None or resume is not None:
            refuse_unserializable(fmus, f"system {system.name}")
            if hasattr(signals, "attach"):
                raise SystemDescriptionError(f"system {system.name}: a checkpoint does not keep where a libcosim "
                                             f"scenario is (its events run, its actions): run it from the start")
            settings = dict(master=cls.name, extrapolation=extra.order, step_ns=step_ns, step_control=controller.name,
                            tolerance=tolerance, start_ns=start_ns, sample_ns=sample_ns, output=list(rec.columns),
                            inputs=None if signals is None else [signals.names, signals_digest(signals)],
                            options=repr((opts.iteration, opts.steps, opts.blowup, opts.divergence)),
                            rates=dict(rates))
            head = manifest(system, paths, settings, params)
            if resume is not None:
                resume.check(head, stop_ns)
            if request is not None:
                writer = Writer(request, head, {}, stop_ns)
        if m.rates is not None:
            info["rates"] = dict(rates)   # instance -> its step as a multiple of the base step
        return _run(m, controller, rec, params, (start_ns, stop_ns, step_ns, sample_ns), tolerance, on_error, opts,
                    info, system, signals, (writer, resume))
    finally:
        release(m, fmus)


def _declared_rates(system, master: str, step_ns: int) -> dict:
    """The rates of the system's experiment (``Experiment.rates``) when the run takes its master and step."""
    exp = system.experiment
    if exp is None or not exp.rates or master_class(master) is not master_class(exp.master) \
            or step_ns != int(round(exp.step * NS)):
        return {}
    names = {i.name for i in system.instances}
    for name, rate in exp.rates.items():
        if name not in names or isinstance(rate, bool) or not isinstance(rate, int) or rate < 1:
            raise SystemDescriptionError(f"system {system.name}: experiment rates {name}={rate!r}: must name an "
                                         f"instance ({', '.join(sorted(names))}) with a whole number >= 1")
    return {n: r for n, r in exp.rates.items() if r > 1}


def _step_options(opts: RunOptions, exp):
    """The step-control options: the run's, or where it leaves them at their defaults those the system's
    experiment declares (an OSP EccoConfiguration, :mod:`harness.osp`)."""
    declared = getattr(exp, "step_options", None) if exp is not None else None
    if declared and opts.steps == StepOptions():
        return StepOptions(**declared)
    return opts.steps


def column_units(fmus: dict, columns: list[str]) -> dict[str, str]:
    """``{column: unit}`` of result columns ``Instance.variable`` from the FMUs' declared units ('' if none);
    the index ``time`` is in s."""
    from harness.model import _unit

    out = {}
    for c in columns:
        inst, _, var = c.partition(".")
        f = fmus.get(inst)
        v = f.variables.get(var) if f is not None else None
        out[c] = _unit(v) if v is not None else ""
    return out


def _output_interval(output_interval, step: float, step_ns: int, step_control) -> int:
    """The recording interval [ns]: ``output_interval``, a whole multiple of the step (fixed step only), or
    the step itself (every communication point)."""
    if output_interval is None:
        return step_ns
    interval = _positive("output_interval", output_interval)
    if step_control not in (None, "none"):
        raise SystemDescriptionError(f"output_interval = {interval!r} s needs a fixed step: under step_control = "
                                     f"{step_control!r} the communication points are the controller's; leave "
                                     f"output_interval out (every accepted point is recorded)")
    sample_ns = int(round(interval * NS))
    if sample_ns < step_ns or sample_ns % step_ns:
        raise SystemDescriptionError(f"output_interval = {interval!r} s is not a whole multiple of step = {step!r} "
                                     f"s: the result holds communication points (values between them are not "
                                     f"computed); give a multiple of the step, or a step that divides it")
    return sample_ns


def _run(m, controller, rec: Recorder, params, span, tolerance, on_error, opts, info, system, signals=None,
         checkpoints=(None, None)):
    """Initialize ``m`` and run it over ``span`` = (start, stop, step, recording interval) [ns] in the one run
    loop (:meth:`harness.master.Master.run`), with the recording, the divergence watch and the progress bar as
    its observers and ``signals`` (a :class:`~harness.signals.Signals`) as its inputs; the result, marked as it
    ended, with the ``system``'s engineering quantities."""
    wall, cpu = _time.perf_counter(), _time.process_time()
    start_ns, stop_ns, step_ns, sample_ns = span
    error = ""
    err_obj: Exception | None = None
    interrupted = False
    bad_input = False
    # (a row at t keeps the values recorded at the end of the step, as FMPy records them)
    observers = [Recording(rec, start_ns, stop_ns, None if sample_ns == step_ns else sample_ns)]
    watch = DivergenceWatch(m, opts.divergence) if opts.divergence is not None and m.bond_labels else None
    if watch is not None:
        observers.append(watch)
    observers += list(opts.observers)
    observers.append(ProgressBar(stop_ns - start_ns, opts.progress))
    writer, resume = checkpoints
    if writer is not None:
        writer.parts.update(controller=controller, recorder=rec, watch=watch)
        observers.append(writer)
    first_ns = None
    init_time = math.nan  # the initialisation's share of wall_time (NaN: it did not finish)
    try:
        m.initialize(start_ns, stop_ns, tolerance, params)
        if resume is not None:   # the checkpoint's state; its rows and detector saw their start already
            resume.restore(m, controller, rec, watch, params)
            observers = [Resumed(o) if o is observers[0] or o is watch else o for o in observers]
            first_ns = resume.first_ns(controller)
        init_time = _time.perf_counter() - wall
        m.run(controller, stop_ns, observers, inputs=signals, first_ns=first_ns)
    except (FMUError, SimulationError, ConvergenceError) as e:
        error = str(e).splitlines()[0] if str(e) else type(e).__name__
        err_obj = e
        if rec.rows == 0 and isinstance(e, ParameterRefused):
            # the FMU refused a parameter value before the run: bad input, said in the user's words (no FMI call)
            log = e.log.strip().splitlines()[0]
            error = f"system {info['system']}: " + (log if log.startswith(f"{e.instance} ") else
                                                    f"instance {e.instance}: {log}")
            bad_input = True
    except KeyboardInterrupt as e:
        interrupted, how = interruption(e)
        error = f"{how} at t = {rec.time[rec.rows - 1] if rec.rows else 0.0:.9g} s"
    suspect = watch.suspect if watch is not None else ""
    info.update(steps=m.steps, wall_time=_time.perf_counter() - wall, init_time=init_time,
                cpu_time=_time.process_time() - cpu,
                iterations=m.iterations,
                fmu_steps=m.fmu_steps, halved_steps=m.halvings,
                rejected=controller.rejected, max_error_estimate=controller.max_accepted_error)
    if writer is not None:
        info["checkpoint"] = {"path": str(writer.request.path), "time": writer.written}
    if resume is not None:
        info["resumed_from"] = {"path": str(resume.path), "time": resume.t_ns / NS}
    df = rec.frame(complete=not error, error=error, **info)
    df.attrs["diverged"] = isinstance(err_obj, Diverged)
    df.attrs["blew_up"] = isinstance(err_obj, BlowUp)
    df.attrs["interrupted"] = bool(interrupted)
    df.attrs["bad_input"] = bad_input
    df.attrs["suspect"] = suspect
    df.attrs["quantities"] = quantities(system, df)  # the engineering quantities, also of a partial result
    if interrupted:
        raise RunInterrupted(error, partial=df, status=interrupted)
    if error:
        if on_error == "raise":
            raise SimulationError(error, partial=df, time=getattr(err_obj, "time", None),
                                  instance=getattr(err_obj, "instance", None),
                                  variable=getattr(err_obj, "variable", None)) from err_obj
        warnings.warn(f"run stopped early: {error}", RunWarning, stacklevel=3)
    elif suspect:
        warnings.warn(suspect, RunWarning, stacklevel=3)
    return df


def simulate_scenario(system, scenario, **options) -> pd.DataFrame:
    """Co-simulate ``system`` through ``scenario`` (one of the system's by name, a
    :class:`~harness.specs.Scenario` or a .yaml/.json file; :mod:`harness.scenarios`): :func:`simulate` with
    ``options``, the scenario's parameters under the ``start_values`` given, its changes as the input signals and
    its stop time unless given.  ``df.attrs["scenario"]`` is its name, ``df.attrs["transient"]`` its quantities."""
    from harness import scenarios
    from harness.osp.scenario import LibcosimScenario, is_libcosim_scenario

    system = load(system)
    if is_libcosim_scenario(scenario):   # libcosim's format: its events act as libcosim's scenario manager has them
        sc = LibcosimScenario(scenario)
        if options.get("input") is not None:
            raise SystemDescriptionError(f"scenario file {scenario} acts on the variables itself: give input signals "
                                         f"or a scenario, not both")
        if options.get("stop_time") is None and sc.end is not None:
            options["stop_time"] = sc.end
        df = simulate(system, **{**options, "input": sc})
        df.attrs["scenario"] = Path(str(scenario)).stem
        return df
    sc, options = scenarios.prepare(system, scenario, options)
    asked = options["stop_time"]
    if sc.kind in ("stop", "jam") and sc.changes and system.quantities is not None:
        options = _until_settled(system, sc, options)
    df = simulate(system, **options)
    df.attrs["scenario"] = sc.name
    df.attrs["stop_time_asked"] = asked
    if sc.kind == "stop" and sc.changes:
        df.attrs["stop_command"] = min(c.time for c in sc.changes)
    if sc.kind != "startup" and sc.changes and len(df):   # the steady cycles are those before the first change
        first = min(c.time for c in sc.changes)
        df.attrs["quantities"] = quantities(system, df.loc[:first],
                                            scope=f"before the scenario's first change at t = {first:g} s")
    df.attrs["transient"] = scenarios.transient(system, sc, df)
    return df


def _until_settled(system, sc, options: dict) -> dict:
    """A stop's (a jam's) run options: on past its stop time until the drive has settled at rest, up to its limit
    (:mod:`harness.run.settling`)."""
    import dataclasses

    from harness.run.settling import HOLD, LIMIT, Settling

    asked = options["stop_time"]
    limit = max(asked, sc.settle_limit if sc.settle_limit is not None else LIMIT * sc.stop_time)
    command = min(c.time for c in sc.changes)
    watch = Settling(system.quantities.shaft_speed, round(command * NS), round(asked * NS),
                     sc.settle_hold if sc.settle_hold is not None else HOLD)
    opts = options.get("options") or RunOptions()
    return {**options, "stop_time": limit, "options": dataclasses.replace(opts, observers=(*opts.observers, watch))}


def partial_path(path: Path) -> Path:
    """Where an incomplete result is written instead of ``path``: ``x.csv`` -> ``x.partial.csv``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix or '.csv'}")
