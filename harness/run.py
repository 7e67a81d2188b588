"""Running a system: :func:`load`, :func:`simulate` and the CLI command ``python -m harness run``.

``simulate(system, stop_time=None, step=None, master=None, extrapolation=None, step_control=None,
tolerance=None, start_values=None, output=None, *, start_time=None, output_interval=None, input=None,
on_error="return", options=None)`` returns the result DataFrame (see :mod:`harness.results`); FMPy's names
``step_size`` and ``relative_tolerance`` work too.  Arguments left at None come from the system's default
experiment (then: master ``jacobi``, extrapolation 0, fixed step).  Further options live in :class:`RunOptions`
(iteration of the ``iterative`` master, step-control limits, blow-up limit, progress bar, FMU logging).

(About 730 lines: loading a system, simulate's argument checks, the assembly of its result and the ``run``
command that exposes the same arguments read together; the loop is :meth:`harness.masters.Master.run`, input
signals live in :mod:`harness.signals`.)

Failures during the run (an FMU error, a non-finite output, an output beyond the blow-up limit, an iteration
that does not converge) stop it with a one-line message naming the time, the instance and the variable or
FMI call.  With ``on_error="return"`` (default) the result up to the last good communication point is
returned with ``attrs["complete"] = False`` and ``attrs["error"]`` (and a :class:`RunWarning` is issued);
``on_error="raise"`` raises :class:`~harness.errors.SimulationError` whose ``partial`` is that DataFrame.
Errors in the system description (:class:`~harness.errors.SystemError_`) are always raised before the run.

"""
from __future__ import annotations

import difflib
import importlib
import math
import sys
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.divergence import Diverged, DivergenceOptions, DivergenceWatch
from harness.errors import BlowUp, FMUError, HarnessError, SimulationError, SystemError_
from harness.errors import ParameterRefused  # an FMU refused a parameter value (typed, fmus.refusal)
from harness.errors import Terminated, interruption  # noqa: F401 (defined with the errors, re-exported)
from harness.extrapolation import extrapolation as make_extrapolation
from harness.fmi import Instance, open_instance, release
from harness.masters import MASTERS, NS, ConvergenceError, IterationOptions, master_class
from harness.model import System, model_description, resolve_fmu
from harness.observers import ProgressBar, Recording
from harness.quantities import json_path, quantities
from harness.results import Recorder
from harness.signals import Signals, full_name
from harness.stepcontrol import StepOptions, step_control as make_step_control


class RunWarning(UserWarning):
    """A run that stopped early and returned a partial result."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) or, under the command line, SIGTERM during a run: ``partial`` is the result up to the
    last finished communication point, marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``;
    ``status`` is the exit status a shell expects after that signal (130 or 143)."""

    def __init__(self, message: str, partial=None, status: int = 130):
        super().__init__(message)
        self.partial = partial
        self.status = status


@dataclass
class RunOptions:
    """Options of :func:`simulate` beyond its keyword arguments.

    ``iteration``: the ``iterative`` master's solver; ``steps``: limits of the variable-step controllers;
    ``blowup``: an output whose magnitude exceeds it stops the run (amplitude blow-up); ``progress``: tqdm
    progress bar (None: only when stderr is a terminal, shown after 2 s); ``logging``: FMU debug logging;
    ``in_process``: how pythonfmu FMUs are called (:func:`harness.fmi.open_instance`: None runs every
    pythonfmu FMU whose script imports here in this process, the others through FMI with one warning; True
    requires it; False calls every FMU through FMI).  Results are the same bit for bit; only the cost differs.
    ``divergence``: thresholds of the divergence detector on the power bonds (:mod:`harness.divergence`);
    None switches it off.  ``isolate``: run FMUs in child processes of their own (:mod:`harness.fmi.isolated`:
    True or "foreign" every FMU not built by the toolkit, "all" every FMU, or an ``Isolation`` with its
    per-call timeout), so a crash or hang inside an FMU call stops the run in one line and keeps its rows;
    None/False (default) runs every FMU in this process.  ``observers``: further
    :class:`harness.observers.Observer` objects the run loop calls, after the recording and the divergence watch
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


def load(x) -> System:
    """A :class:`System` from a module name in ``systems/`` (its ``SYSTEM``; ``"bed_drive"``, also written
    ``"bed_drive.py"`` or ``"systems/bed_drive.py"``), the path of any Python file that defines ``SYSTEM``, an
    .ssp/.ssd file or an SSP unpacked into a folder (holding SystemStructure.ssd), a bare .fmu (run alone,
    :func:`_fmu_system`), or itself.  Anything else is a :class:`~harness.errors.SystemError_` in one line naming
    what was given and the known systems (with the closest name when it looks misspelt)."""
    if isinstance(x, System):
        return x
    s = str(x)
    if s.lower().endswith((".ssp", ".ssd")) or (Path(s) / "SystemStructure.ssd").is_file():
        from harness.ssp import load_ssp

        return load_ssp(s)
    if s.lower().endswith(".py"):
        return _load_file(Path(s))
    if s.lower().endswith(".fmu"):
        return _fmu_system(Path(s))
    name = s[len("systems."):] if s.startswith("systems.") else s
    if not name.isidentifier():  # a file of another kind, a folder, a path: no module name at all
        raise SystemError_(f"system {s!r} is neither a system name nor a .py, .ssp or .ssd file; "
                           f"{_known_systems()}")
    try:
        module = importlib.import_module(f"systems.{name}")
    except ModuleNotFoundError as e:
        if e.name in (f"systems.{name}", "systems"):
            raise SystemError_(f"unknown system {s!r}{_close_match(name)}; {_known_systems()}") from None
        raise
    return _system_of(module, f"systems/{name}.py")


def _fmu_system(path: Path) -> System:
    """One FMU run alone, as ``fmpy.simulate_fmu`` runs it: one instance named after the model (``.`` made
    ``_``), the FMU's DefaultExperiment as the default experiment (no step there: the run asks for one)."""
    from harness.model import Experiment, Instance as Component  # (Instance here is the FMU wrapper's name)

    if not path.is_file():
        raise SystemError_(f"{path}: no such FMU file")
    md = model_description(path)
    name = (md.modelName or path.stem).replace(".", "_")
    de = md.defaultExperiment
    experiment = None
    if de is not None and de.stopTime is not None:
        experiment = Experiment(stop_time=float(de.stopTime), step=float(de.stepSize) if de.stepSize else None,
                                start_time=float(de.startTime or 0.0))
    return System(name, [Component(name, path)], experiment=experiment)


def _load_file(path: Path) -> System:
    """The ``SYSTEM`` of a Python file: a shipped one by its module (``systems/x.py`` or just ``x.py``, so it
    is the same object as ``load("x")``), any other by its path."""
    import importlib.util

    shipped = Path(importlib.import_module("systems").__path__[0]).resolve()
    if path.is_file() and path.resolve().parent != shipped:
        module_name = f"_pressdrive_system_{path.stem}"
        spec = importlib.util.spec_from_file_location(module_name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[module_name] = module  # dataclasses defined in the file look their module up here
        try:
            spec.loader.exec_module(module)
        except Exception:
            sys.modules.pop(module_name, None)
            raise
        return _system_of(module, str(path))
    if path.stem in system_names() and (path.is_file() or len(path.parts) == 1 or path.parent.name == "systems"):
        return load(path.stem)
    raise SystemError_(f"system file {str(path)!r} does not exist{_close_match(path.stem)}; {_known_systems()}")


def _system_of(module, where: str) -> System:
    system = getattr(module, "SYSTEM", None)
    if not isinstance(system, System):
        raise SystemError_(f"system module {where} defines no SYSTEM = System(...)")
    return system


def _known_systems() -> str:
    return "known systems: " + ", ".join(system_names()) + " (or a .py file defining SYSTEM, or .ssp/.ssd)"


def _close_match(name: str) -> str:
    import difflib

    close = difflib.get_close_matches(name, system_names(), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def system_names() -> list[str]:
    """The names of the system modules in ``systems/`` (each defines ``SYSTEM``), sorted."""
    import pkgutil

    import systems

    return sorted(m.name for m in pkgutil.iter_modules(systems.__path__) if not m.ispkg)


def declared(spec: str) -> dict:
    """System name -> its ``spec`` field (``"precision"`` or ``"stability"``), for every system in ``systems/``
    that declares one."""
    out = {}
    for name in system_names():
        value = getattr(load(name), spec)
        if value is not None:
            out[name] = value
    return out


def _positive(name: str, value, unit: str = "s") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        text = repr(float(value)) if isinstance(value, (int, float)) and not isinstance(value, bool) else repr(value)
        raise SystemError_(f"{name} = {text} is not admissible: must be a positive finite number"
                           + (f" [{unit}]" if unit else ""))
    return float(value)


def split_parameters(system: System, parameters: dict | None) -> dict[str, dict]:
    """Instance name -> {parameter: value}: the system's values overridden by ``{"Instance.param": value}`` (in
    a system of one FMU also by the FMU's own names, as FMPy takes them: :func:`harness.signals.full_name`)."""
    out = {inst.name: dict(inst.parameters) for inst in system.instances}
    for ref, value in (parameters or {}).items():
        inst, dot, var = full_name(system, ref).partition(".")
        if not dot or not var:
            raise SystemError_(f"parameter {ref!r} must be written 'Instance.parameter'")
        if inst not in out:
            close = difflib.get_close_matches(inst, list(out), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SystemError_(f"parameter {ref}: unknown instance {inst!r}{hint} (instances: {', '.join(out)})")
        out[inst][var] = value
    return out


# FMPy's names (fmpy.simulate_fmu) and this function's older ones, each mapped to its one spelling here
_ALIASES = {"step_size": "step", "relative_tolerance": "tolerance"}  # FMPy's, the same meaning (docs/fmpy.md)
_DEPRECATED = {"parameters": "start_values", "outputs": "output"}    # still accepted, with a DeprecationWarning
# FMPy's other arguments: what takes their place here (one line each, raised as a TypeError)
_FMPY_ONLY = {
    "solver": "a model exchange FMU is integrated by CVODE inside the master (harness.fmi.me)",
    "fmi_type": "a co-simulation FMU runs as one; a model exchange-only FMU is integrated by CVODE",
    "validate": "the system is always validated against the FMUs before the run",
    "record_events": "results hold the communication points (or every output_interval)",
    "apply_default_start_values": "an FMU keeps its declared start values unless start_values sets them",
    "timeout": "Ctrl-C or SIGTERM ends a run and keeps what it computed (RunInterrupted.partial)",
    "debug_logging": "use options=RunOptions(logging=...)",
    "logger": "an FMU's log goes into the one-line error of a failed call",
    "fmi_call_logger": "an FMU's log goes into the one-line error of a failed call",
    "step_finished": "the result is returned whole; a stopped run returns what it computed",
    "set_input_derivatives": "input derivatives are set from extrapolation >= 1 for FMUs that can interpolate",
    "visible": "FMUs run in batch mode", "remote_platform": "FMUs run on this platform",
    "model_description": "the modelDescription is read once and cached (harness.fmi.cache)",
    "fmu_instance": "the master instantiates every FMU itself", "fmu_state": "runs start from initialization",
    "initialize": "runs start from initialization", "terminate": "every run ends with fmi2Terminate",
    "early_return_allowed": "FMI 3.0 early return is not used", "use_event_mode": "FMI 3.0 event mode is not used",
    "set_stop_time": "the stop time is always passed to the FMUs",
}


def _renamed(given: dict, canonical: dict) -> dict:
    """The keyword arguments of :func:`simulate` given under FMPy's name or an old one (``given``), under
    their name here; ``canonical`` holds the values given under that name.  The same argument given twice
    (``step`` and ``step_size``), an FMPy argument without a counterpart or an unknown name is a TypeError
    in one line."""
    out = {}
    for name, value in given.items():
        if name in _DEPRECATED:
            warnings.warn(f"simulate(): {name}= is now {_DEPRECATED[name]}= (the name fmpy.simulate_fmu uses)",
                          DeprecationWarning, stacklevel=3)
            here = _DEPRECATED[name]
        elif name in _ALIASES:
            here = _ALIASES[name]
        elif name in _FMPY_ONLY:
            raise TypeError(f"simulate() has no argument {name!r} (fmpy.simulate_fmu's): {_FMPY_ONLY[name]}")
        else:
            raise TypeError(f"simulate() got an unexpected keyword argument {name!r}")
        if value is None:
            continue
        if canonical.get(here) is not None or here in out:
            raise TypeError(f"simulate(): {name}= and {here}= are the same argument ({name} is FMPy's or the "
                            f"former name of {here}): give one")
        out[here] = value
    return out


def simulate(system, stop_time: float | None = None, step: float | None = None, master: str | None = None,
             extrapolation=None, step_control: str | None = None, tolerance: float | None = None,
             start_values: dict | None = None, output: list[str] | None = None, *, start_time: float | None = None,
             output_interval: float | None = None, input=None, on_error: str = "return",
             options: RunOptions | None = None, isolate=None, **other_names) -> pd.DataFrame:
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
      ``"jacobian"`` (:data:`harness.masters.MASTERS`).
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
    * ``other_names``: FMPy's ``step_size`` and ``relative_tolerance``; ``parameters=`` and ``outputs=``, this
      function's former names of ``start_values`` and ``output``, still accepted with a DeprecationWarning.

    Ctrl-C raises :class:`RunInterrupted` (a KeyboardInterrupt) whose ``partial`` is the result so far,
    marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``.  Errors in the description or the
    arguments raise :class:`~harness.errors.SystemError_` before the run."""
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
        raise SystemError_(f"on_error = {on_error!r} is not admissible: must be 'return' or 'raise'")
    exp = system.experiment
    if stop_time is None:
        if exp is None:
            raise SystemError_(f"system {system.name} has no default experiment: give stop_time")
        stop_time = exp.stop_time
    if step is None and (exp is None or exp.step is None) and output_interval is not None:
        step = output_interval  # as fmpy.simulate_fmu steps a co-simulation FMU: one step per output interval
    if step is None:
        if exp is None:
            raise SystemError_(f"system {system.name} has no default experiment: give step")
        if exp.step is None:  # an SSP's DefaultExperiment without a step (OSP's annotation gives one)
            raise SystemError_(f"system {system.name}: its default experiment declares no step: give step "
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
        raise SystemError_(f"start_time = {start_time!r} is not admissible: must be a finite number in "
                           f"[0, stop_time = {stop_time!r}) [s]")
    start_ns, stop_ns, step_ns = int(round(start_time * NS)), int(round(stop_time * NS)), int(round(step * NS))
    if step_ns < 1:
        raise SystemError_(f"step = {step!r} is not admissible: master time has a resolution of 1 ns")
    if step_ns > stop_ns - start_ns:
        raise SystemError_(f"step = {step!r} s is longer than the run from start_time = {start_time!r} s to "
                           f"stop_time = {stop_time!r} s" if start_ns else
                           f"step = {step!r} s is longer than stop_time = {stop_time!r} s")
    sample_ns = _output_interval(output_interval, step, step_ns, step_control)
    cls = master_class(master)
    extra = make_extrapolation(extrapolation)
    params = split_parameters(system, start_values)
    output = None if output is None else [full_name(system, c) for c in output]

    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    signals = None
    if input is not None:
        signals = Signals(system, mds, system.all_connections(mds), input)
        for inst, values in signals.start_values(start_ns).items():  # set before the FMUs initialize
            params[inst].update(values)
    system.validate(mds, {f"{i}.{k}": v for i, d in params.items() for k, v in d.items()})
    connections = system.all_connections(mds)

    fmus: dict[str, Instance] = {}
    m = None
    try:
        for inst in system.instances:
            fmus[inst.name] = open_instance(paths[inst.name], inst.name, opts.logging, opts.in_process,
                                            isolate=opts.isolate)
        m = cls(fmus, connections, system.bonds, extra, opts.iteration, tolerance, opts.blowup)
        controller = make_step_control(step_control, m, step_ns, tolerance, opts.steps)
        if not controller.variable and (stop_ns - start_ns) % step_ns:
            for name, f in fmus.items():
                if not f.can_vary_step:
                    raise SystemError_(f"stop_time = {stop_time!r} s is not a multiple of step = {step!r} s and "
                                       f"instance {name} cannot take a shorter last step")
        n_rows = -(-(stop_ns - start_ns) // sample_ns) + 1 if not controller.variable else 1024
        rec = Recorder(m, output, n_rows)
        if signals is not None:
            signals.bind(fmus)
        info = dict(system=system.name, master=cls.name, extrapolation=extra.order,
                    step_control=controller.name, step=step, start_time=start_time, stop_time=stop_time,
                    tolerance=tolerance, output_interval=sample_ns / NS, inputs=signals.names if signals else [],
                    units=column_units(fmus, rec.columns))
        info["start_values"] = {k: (v.item() if hasattr(v, "item") else v) for k, v in (start_values or {}).items()}
        return _run(m, controller, rec, params, (start_ns, stop_ns, step_ns, sample_ns), tolerance, on_error, opts,
                    info, system, signals)
    finally:
        release(m, fmus)


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
        raise SystemError_(f"output_interval = {interval!r} s needs a fixed step: under step_control = "
                           f"{step_control!r} the communication points are the controller's; leave "
                           f"output_interval out (every accepted point is recorded)")
    sample_ns = int(round(interval * NS))
    if sample_ns < step_ns or sample_ns % step_ns:
        raise SystemError_(f"output_interval = {interval!r} s is not a whole multiple of step = {step!r} s: the "
                           f"result holds communication points (values between them are not computed); give "
                           f"a multiple of the step, or a step that divides it")
    return sample_ns


def _run(m, controller, rec: Recorder, params, span, tolerance, on_error, opts, info, system, signals=None):
    """Initialize ``m`` and run it over ``span`` = (start, stop, step, recording interval) [ns] in the one run
    loop (:meth:`harness.masters.Master.run`), with the recording, the divergence watch and the progress bar as
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
    init_time = math.nan  # the initialisation's share of wall_time (NaN: it did not finish)
    try:
        m.initialize(start_ns, stop_ns, tolerance, params)
        init_time = _time.perf_counter() - wall
        m.run(controller, stop_ns, observers, inputs=signals)
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


# -- CLI ----------------------------------------------------------------------------------------------------------
def _value(text: str):
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    try:
        return int(t)
    except ValueError:
        pass
    try:
        return float(t)
    except ValueError:
        return t


def parse_sets(items: list[str] | None) -> dict:
    out = {}
    for item in items or []:
        name, eq, value = item.partition("=")
        if not eq or not name.strip() or not value.strip():
            raise SystemError_(f"--set {item!r}: expected Instance.param=VALUE")
        out[name.strip()] = _value(value)
    return out


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "run", help="run a system (name in systems/, a .py file defining SYSTEM, or .ssp/.ssd) and write its result",
        description="Co-simulate a system and write the result as CSV or Parquet (time in s, one column per "
                    "Instance.variable). --out and --plot are checked before the run. A run that stops early "
                    "(divergence, FMU failure, Ctrl-C, SIGTERM) writes what it computed to OUT.partial.csv and "
                    "its chart to DIR/<system>.partial.png instead, never over a complete result, says so on "
                    "stderr in one line and exits 1 (130 after Ctrl-C, 143 after SIGTERM). The options are "
                    "those of harness.simulate(): --start-time is start_time, --set fills start_values, "
                    "--output is output, --input is input.")
    p.add_argument("system", help="system name in systems/ (e.g. bed_drive; `list` shows them), a .py file "
                                  "defining SYSTEM, or an .ssp/.ssd file")
    p.add_argument("--start-time", type=float, default=None, metavar="SECONDS",
                   help="start time [s] (default: the system's default experiment, else 0)")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] (default: the system's default experiment)")
    p.add_argument("--step", "--step-size", type=float, default=None, metavar="SECONDS",
                   help="communication step [s] (default: the system's default experiment, else "
                        "--output-interval)")
    p.add_argument("--output-interval", type=float, default=None, metavar="SECONDS",
                   help="record the result every this often, a whole multiple of the step (default: every "
                        "communication step)")
    p.add_argument("--master", default=None, metavar="NAME",
                   help=f"{', '.join(MASTERS)} (default: the system's, else jacobi)")
    p.add_argument("--extrapolation", type=int, default=None, choices=(0, 1, 2),
                   help="input extrapolation order (default: the system's, else 0 = hold)")
    p.add_argument("--step-control", default=None, choices=("none", "richardson", "ecco"),
                   help="step control (default: the system's, else none = fixed step)")
    p.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                   help="relative tolerance [-] of step control and iteration (default: the system's, else none)")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="start value of a parameter, in its declared unit (repeatable; `show SYSTEM` lists "
                        "them; default: the system's values)")
    p.add_argument("--output", action="append", default=None, metavar="Instance.variable",
                   help="record only these variables (repeatable; default: every output)")
    p.add_argument("--input", "--input-file", type=Path, default=None, metavar="FILE.csv",
                   help="input signals: a CSV file with a 'time' column [s] and one column per free input "
                        "Instance.variable, interpolated as FMPy does (continuous Real inputs linearly, others "
                        "held; two rows at one time are a step); checked before the run (default: none, free "
                        "inputs keep their start values)")
    p.add_argument("--scenario", default=None, metavar="NAME|FILE",
                   help="run a transient: one of the drive's scenarios (`show SYSTEM` lists them: startup, "
                        "speed_change, estop, jam) or a .yaml/.json scenario file; its parameters, input changes "
                        "and stop time apply (--set and --stop-time override them) and its transient quantities "
                        "are printed and written beside the result as FILE.transient.json (default: none)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="write the result to this file: .csv, or .parquet when pyarrow or fastparquet is "
                        "installed, and the drive's engineering quantities beside it (FILE.quantities.json, "
                        "x.csv -> x.quantities.json); its folder is made if missing, and checked before the run "
                        "(default: not written)")
    p.add_argument("--units", action="store_true",
                   help="CSV: write a second header row with each column's unit (read it with "
                        "pandas.read_csv(FILE, header=[0, 1], index_col=0); Parquet keeps the units in its "
                        "metadata); default: names only")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="write charts of the run: DIR/<system>.png (the system's signals over time) and, "
                        "where the system declares its crank angle, DIR/<system>_cycle.png (over the last "
                        "complete crank revolution); <name>.partial.png for a run that stopped early "
                        "(default: no chart)")
    p.add_argument("--svg", action="store_true",
                   help="with --plot: also write each chart as SVG (vector, for a document) beside its PNG "
                        "(default: PNG only; the SVG is a second drawing of each chart)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE.html",
                   help="write one self-contained HTML page of the run to hand on: its engineering quantities, "
                        "charts (inline), the drive (instances, fidelities, parameters changed from their "
                        "defaults), the method with the drive's declared accuracy, versions and run time; checked "
                        "before the run (default: none)")
    p.add_argument("--quiet-quantities", action="store_true",
                   help="do not print the table of the drive's engineering quantities after the run (default: "
                        "printed; with --out they are written beside the result as FILE.quantities.json "
                        "either way)")
    p.add_argument("--fmi-only", action="store_true",
                   help="call every FMU through its FMI library (default: pythonfmu FMUs, the toolkit's and "
                        "others', are called in this process: the same results bit for bit, faster)")
    p.add_argument("--isolate", nargs="?", const="foreign", default=None, choices=("foreign", "all"),
                   help="run every foreign FMU (not built by this toolkit; 'all': every FMU) in a child process "
                        "of its own: a crash or a hang inside one of its calls stops the run in one line naming "
                        "the instance, the FMI call and the time, and the rows computed so far are kept "
                        "(default: every FMU in this process)")
    p.add_argument("--isolate-timeout", type=float, default=None, metavar="SECONDS",
                   help="with --isolate: the longest one FMU call may take before its process is killed and "
                        "the run stops (default: 60 s)")
    p.set_defaults(func=run_cli)


def simulate_scenario(system, scenario, **options) -> pd.DataFrame:
    """Co-simulate ``system`` through ``scenario`` (one of the system's by name, a
    :class:`~harness.specs.Scenario` or a .yaml/.json file; :mod:`harness.scenarios`): :func:`simulate` with
    ``options``, the scenario's parameters under the ``start_values`` given, its changes as the input signals and
    its stop time unless given.  ``df.attrs["scenario"]`` is its name, ``df.attrs["transient"]`` its quantities."""
    from harness import scenarios

    system = load(system)
    sc, options = scenarios.prepare(system, scenario, options)
    df = simulate(system, **options)
    df.attrs["scenario"] = sc.name
    df.attrs["transient"] = scenarios.transient(system, sc, df)
    return df


def partial_path(path: Path) -> Path:
    """Where an incomplete result is written instead of ``path``: ``x.csv`` -> ``x.partial.csv``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix or '.csv'}")


def _check_targets(args) -> None:
    """Every file the run will write, checked before it starts (format, folder made, writable): a run is
    never computed for a result that could not be kept."""
    from harness.results import check_writable, result_format

    if args.out is not None:
        result_format(args.out)
        check_writable(args.out, "--out")
    if args.plot is not None:
        check_writable(args.plot, "--plot", folder=True)
    elif getattr(args, "svg", False):
        raise HarnessError("--svg needs --plot DIR: the SVG is written beside each chart's PNG")
    if getattr(args, "report", None) is not None:
        from harness.htmlreport import check_report_path

        check_report_path(args.report)


def _plot(system, df, folder: Path, svg: bool = False) -> list[Path]:
    """The run's charts in ``folder`` (the PNGs are returned; ``svg``: also as SVG); an incomplete run's under
    ``<name>.partial.png`` (``.svg``), so they never replace the charts of a complete run (drawn beside,
    renamed)."""
    import os
    import tempfile

    from harness.charts import plot_result

    if df.attrs.get("complete", True):
        return [p for p in plot_result(system, df, folder, svg) if p.suffix == ".png"]
    with tempfile.TemporaryDirectory(dir=folder, prefix=".partial-chart-") as tmp:
        paths = []
        for drawn in plot_result(system, df, tmp, svg):
            paths.append(Path(folder) / f"{drawn.stem}.partial{drawn.suffix}")
            os.replace(drawn, paths[-1])
    return [p for p in paths if p.suffix == ".png"]


def _divergence_hint(a: dict) -> str:
    """What to change after a diverged run, from the run itself: a smaller step (or tolerance, under step
    control) and the interface-Jacobian master, whose implicit coupling is stable where a stiff mode spans FMUs
    (it needs FMUs that can roll back; it says so in one line if one cannot)."""
    if a.get("step_control") not in (None, "none") and a.get("tolerance") is not None:
        first = f"lower the tolerance (now {a['tolerance']:g})"
    else:
        first = f"reduce the step (now {a['step']:g} s)"
    better = {m: "jacobian" for m in ("jacobi", "jacobi-sampled", "gauss-seidel", "iterative")}  # implicit
    nxt = better.get(a.get("master"))
    return first + (f" or use --master {nxt}" if nxt else "")


def run_cli(args) -> int:
    system = load(args.system)  # a wrong name first: no folder is made for it
    _check_targets(args)
    status = 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RunWarning)  # the CLI reports a stop itself, in one line
            settings = dict(start_time=args.start_time, stop_time=args.stop_time, step=args.step,
                            output_interval=getattr(args, "output_interval", None),
                            input=getattr(args, "input", None), master=args.master,
                            extrapolation=args.extrapolation, step_control=args.step_control,
                            tolerance=args.tolerance, start_values=parse_sets(args.set), output=args.output,
                            options=RunOptions(progress=None, in_process=False if args.fmi_only else None,
                                               isolate=_isolation(args)),
                            on_error="return")
            if getattr(args, "scenario", None):
                df = simulate_scenario(system, args.scenario, **settings)
            else:
                df = simulate(system, **settings)
    except RunInterrupted as e:
        df, status = e.partial, e.status
    a = df.attrs
    if a.get("bad_input"):  # a refused parameter: nothing was computed, nothing is written
        print(f"error: {a['error']}", file=sys.stderr)
        return 1
    out = args.out
    if out is not None and not a["complete"]:
        out = partial_path(out)
    if out is not None:
        from harness.results import write_result

        write_result(df, out, units=getattr(args, "units", False))
        if a["quantities"].rows:
            a["quantities"].write_json(json_path(out))
        if a.get("transient") is not None and a["transient"].rows:
            a["transient"].write_json(out.with_name(f"{out.stem}.transient.json"))
    where = f"wrote {out}" if out is not None else "no --out given, result not written"
    charts = None
    if args.plot is not None and len(df):
        if a.get("scenario"):  # a transient's charts beside the plain run's, not over them
            import dataclasses

            system = dataclasses.replace(system, name=f"{system.name}_{a['scenario']}")
        charts = _plot(system, df, args.plot, getattr(args, "svg", False))
        where += "; chart " + ", ".join(str(p) for p in charts)
        from harness.charts import cycle_chart_missing

        missing = cycle_chart_missing(system, df) if system.chart is not None else ""
        if missing:  # a drive that has a cycle chart says why this run has none
            where += f"; no cycle chart: {missing}"
    if getattr(args, "report", None) is not None:
        from harness.htmlreport import write_run_report

        page = args.report if a["complete"] else partial_path(args.report)   # never over a complete run's page
        where += f"; report {write_run_report(system, df, page, charts)}"
    if not a["complete"]:
        hint = f"; {_divergence_hint(a)}" if a.get("diverged") or a.get("blew_up") else ""
        print(f"error: {a['error']}; {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s kept, "
              f"{'INCOMPLETE result ' + where if out is not None else where}{hint}", file=sys.stderr)
        return status or 1
    if a.get("suspect"):
        print(f"warning: {a['suspect']}", file=sys.stderr)
    print(f"{a['system']}: {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s, master {a['master']}, "
          f"{a['steps']} steps{_halved(a)} in {a['wall_time']:.3g} s; {where}")
    if not getattr(args, "quiet_quantities", False) and a["quantities"].rows:
        print(a["quantities"].table())
    if a.get("transient") is not None:
        print(a["transient"].table())
    return 0


def _isolation(args):
    """The run's isolation from ``--isolate [foreign|all]`` and ``--isolate-timeout`` (None: none)."""
    which = getattr(args, "isolate", None)
    timeout = getattr(args, "isolate_timeout", None)
    if which is None:
        if timeout is not None:
            raise SystemError_(f"--isolate-timeout {timeout:g} needs --isolate")
        return None
    from harness.fmi.isolated import DEFAULT_TIMEOUT, Isolation

    return Isolation(which, DEFAULT_TIMEOUT if timeout is None else timeout)


def _halved(a: dict) -> str:
    """' (N taken in halves, ...)' where the jacobian master halved steps (harness.jacobian.needs_halving)."""
    n = a.get("halved_steps") or 0
    return f" ({n} taken again in halves where the coupling's correction did not converge)" if n else ""


__all__ = ["load", "simulate", "simulate_scenario", "RunOptions", "RunWarning", "RunInterrupted", "Terminated", "column_units", "partial_path", "register", "run_cli", "parse_sets", "HarnessError"]
