"""Running a system: :func:`load`, :func:`simulate` and the CLI command ``python -m harness run``.

``simulate(system, stop_time=None, step=None, master=None, extrapolation=None, step_control=None,
tolerance=None, parameters=None, outputs=None, *, on_error="return", options=None)`` returns the result
DataFrame (see :mod:`harness.results`).  Arguments left at None come from the system's default experiment
(then: master ``jacobi``, extrapolation 0, fixed step).  Further options live in :class:`RunOptions`
(iteration of the ``iterative`` master, step-control limits, blow-up limit, progress bar, FMU logging).

Failures during the run (an FMU error, a non-finite output, an output beyond the blow-up limit, an iteration
that does not converge) stop it with a one-line message naming the time, the instance and the variable or
FMI call.  With ``on_error="return"`` (default) the result up to the last good communication point is
returned with ``attrs["complete"] = False`` and ``attrs["error"]`` (and a :class:`RunWarning` is issued);
``on_error="raise"`` raises :class:`~harness.errors.SimulationError` whose ``partial`` is that DataFrame.
Errors in the system description (:class:`~harness.errors.SystemError_`) are always raised before the run.
"""
from __future__ import annotations

import argparse
import importlib
import math
import sys
import time as _time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.divergence import Diverged, DivergenceOptions, for_master as _detector
from harness.errors import FMUError, HarnessError, SimulationError, SystemError_
from harness.extrapolation import extrapolation as make_extrapolation
from harness.fmi import Instance, open_instance
from harness.masters import NS, ConvergenceError, IterationOptions, master_class
from harness.model import System, model_description, resolve_fmu
from harness.results import Recorder, to_csv
from harness.stepcontrol import StepOptions, step_control as make_step_control


class RunWarning(UserWarning):
    """A run that stopped early and returned a partial result."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) during a run: ``partial`` is the result up to the last finished communication point,
    marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``."""

    def __init__(self, message: str, partial=None):
        super().__init__(message)
        self.partial = partial


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
    None switches it off."""
    iteration: IterationOptions = field(default_factory=IterationOptions)
    steps: StepOptions = field(default_factory=StepOptions)
    blowup: float = 1e12
    progress: bool | None = None
    logging: bool = True
    in_process: bool | None = None
    divergence: DivergenceOptions | None = field(default_factory=DivergenceOptions)


def load(x) -> System:
    """A :class:`System` from a module name in ``systems/`` (its ``SYSTEM``), an .ssp/.ssd file, or itself."""
    if isinstance(x, System):
        return x
    s = str(x)
    if s.lower().endswith((".ssp", ".ssd")):
        from harness.ssp import load_ssp

        return load_ssp(s)
    name = s[len("systems."):] if s.startswith("systems.") else s
    try:
        module = importlib.import_module(f"systems.{name}")
    except ModuleNotFoundError as e:
        if e.name in (f"systems.{name}", "systems"):
            raise SystemError_(f"unknown system {s!r}: no module systems/{name}.py and not an .ssp/.ssd file") from None
        raise
    system = getattr(module, "SYSTEM", None)
    if not isinstance(system, System):
        raise SystemError_(f"system module systems/{name}.py defines no SYSTEM = System(...)")
    return system


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
    """Instance name -> {parameter: value}: the system's values overridden by ``{"Instance.param": value}``."""
    out = {inst.name: dict(inst.parameters) for inst in system.instances}
    for ref, value in (parameters or {}).items():
        inst, dot, var = str(ref).partition(".")
        if not dot or not var:
            raise SystemError_(f"parameter {ref!r} must be written 'Instance.parameter'")
        if inst not in out:
            raise SystemError_(f"parameter {ref}: unknown instance {inst!r}")
        out[inst][var] = value
    return out


def simulate(system, stop_time: float | None = None, step: float | None = None, master: str | None = None,
             extrapolation=None, step_control: str | None = None, tolerance: float | None = None,
             parameters: dict | None = None, outputs: list[str] | None = None, *, on_error: str = "return",
             options: RunOptions | None = None) -> pd.DataFrame:
    """Co-simulate ``system`` and return its result: a DataFrame indexed by time [s], one column per
    ``Instance.variable`` (in the FMU's declared unit, ``df.attrs["units"]``).

    Arguments (None: the system's default experiment, then the fallback named):

    * ``system``: a module name in ``systems/`` (``"bed_drive"``), an .ssp/.ssd file, or a :class:`System`.
    * ``stop_time`` [s]: end of the run (positive).  ``step`` [s]: communication step (positive, >= 1 ns, at
      most ``stop_time``; the first step of a variable-step run).
    * ``master``: ``"jacobi"`` (fallback), ``"jacobi-sampled"``, ``"gauss-seidel"`` or ``"iterative"``.
    * ``extrapolation``: order of the held inputs, 0 (hold, fallback), 1 or 2 (polynomial at the step midpoint).
    * ``step_control``: None/``"none"`` (fixed step, fallback), ``"richardson"`` or ``"ecco"``.
    * ``tolerance`` [-]: relative tolerance of step control and of the iterative master (positive; fallback
      none, the iteration then uses 1e-10).
    * ``parameters``: ``{"Instance.parameter": value}`` in the parameter's declared unit, over the system's
      values (default: none).  A value the FMU refuses returns an empty result, ``attrs["bad_input"]`` True,
      with a one-line error naming the instance, parameter, value, unit and admissible range.
    * ``outputs``: ``["Instance.variable", ...]`` to record (default: every Real output).
    * ``on_error``: ``"return"`` (default): a run that stops early (divergence, FMU failure, non-finite
      output) returns what it computed with ``attrs["complete"] = False`` and a one-line ``attrs["error"]``
      (``attrs["diverged"]`` if the divergence detector stopped it) and warns :class:`RunWarning`; a run
      that ends while the power on a bond is still growing geometrically stays complete and carries the
      detector's one line in ``attrs["suspect"]`` (also warned; '' otherwise);
      ``"raise"``: raises :class:`~harness.errors.SimulationError` whose ``partial`` is that result.
    * ``options``: :class:`RunOptions` (iteration, step-control limits, blow-up limit, divergence detector,
      progress bar, FMU logging, in-process calls); default ``RunOptions()``.

    Ctrl-C raises :class:`RunInterrupted` (a KeyboardInterrupt) whose ``partial`` is the result so far,
    marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``.  Errors in the description or the
    arguments raise :class:`~harness.errors.SystemError_` before the run."""
    system = load(system)
    opts = options or RunOptions()
    if on_error not in ("return", "raise"):
        raise SystemError_(f"on_error = {on_error!r} is not admissible: must be 'return' or 'raise'")
    exp = system.experiment
    if stop_time is None:
        if exp is None:
            raise SystemError_(f"system {system.name} has no default experiment: give stop_time")
        stop_time = exp.stop_time
    if step is None:
        if exp is None:
            raise SystemError_(f"system {system.name} has no default experiment: give step")
        step = exp.step
    master = master if master is not None else (exp.master if exp else "jacobi")
    extrapolation = extrapolation if extrapolation is not None else (exp.extrapolation if exp else 0)
    step_control = step_control if step_control is not None else (exp.step_control if exp else None)
    tolerance = tolerance if tolerance is not None else (exp.tolerance if exp else None)
    stop_time, step = _positive("stop_time", stop_time), _positive("step", step)
    if tolerance is not None:
        _positive("tolerance", tolerance, unit="")
    stop_ns, step_ns = int(round(stop_time * NS)), int(round(step * NS))
    if step_ns < 1:
        raise SystemError_(f"step = {step!r} is not admissible: master time has a resolution of 1 ns")
    if step_ns > stop_ns:
        raise SystemError_(f"step = {step!r} s is longer than stop_time = {stop_time!r} s")
    cls = master_class(master)
    extra = make_extrapolation(extrapolation)
    params = split_parameters(system, parameters)

    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    system.validate(mds, {f"{i}.{k}": v for i, d in params.items() for k, v in d.items()})
    connections = system.all_connections(mds)

    fmus: dict[str, Instance] = {}
    m = None
    try:
        for inst in system.instances:
            fmus[inst.name] = open_instance(paths[inst.name], inst.name, opts.logging, opts.in_process)
        m = cls(fmus, connections, system.bonds, extra, opts.iteration, tolerance, opts.blowup)
        controller = make_step_control(step_control, m, step_ns, tolerance, opts.steps)
        if not controller.variable and stop_ns % step_ns:
            for name, f in fmus.items():
                if not f.can_vary_step:
                    raise SystemError_(f"stop_time = {stop_time!r} s is not a multiple of step = {step!r} s and "
                                       f"instance {name} cannot take a shorter last step")
        n_rows = -(-stop_ns // step_ns) + 1 if not controller.variable else 1024
        rec = Recorder(m, outputs, n_rows)
        info = dict(system=system.name, master=cls.name, extrapolation=extra.order,
                    step_control=controller.name, step=step, stop_time=stop_time,
                    units=column_units(fmus, rec.columns))
        return _run(m, controller, rec, params, stop_ns, step_ns, tolerance, on_error, opts, info)
    finally:
        if m is not None:
            m.terminate()
            m.free()
        else:
            for f in fmus.values():
                f.free()


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


def _progress(total_ns: int, enabled: bool | None):
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(total=total_ns / NS, unit="s", delay=2.0, file=sys.stderr, leave=False,
                bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")


def _run(m, controller, rec: Recorder, params, stop_ns, step_ns, tolerance, on_error, opts, info):
    wall = _time.perf_counter()
    steps = 0
    t_ns = 0
    bar = _progress(stop_ns, opts.progress)
    error = ""
    err_obj: Exception | None = None
    interrupted = False
    bad_input = False
    suspect = ""
    detector = _detector(m, opts.divergence) if opts.divergence is not None and m.bond_labels else None
    try:
        m.initialize(0, stop_ns, tolerance, params)
        rec.record(0.0)
        h_ns = step_ns
        shown = 0
        while t_ns < stop_ns:
            t_prev = t_ns
            t_ns, h_ns = controller.advance(m, t_ns, h_ns, stop_ns)
            steps += 1
            rec.record(t_ns / NS)
            if detector is not None:
                detector.update(t_ns / NS, m.bond_log, (t_ns - t_prev) / NS)
            if bar is not None and (steps & 63) == 0:
                bar.update((t_ns - shown) / NS)
                shown = t_ns
        if detector is not None:
            suspect = detector.finish(t_ns / NS)
    except (FMUError, SimulationError, ConvergenceError) as e:
        error = str(e).splitlines()[0] if str(e) else type(e).__name__
        err_obj = e
        if rec.rows == 0 and isinstance(e, FMUError) and "is not admissible" in (e.log or ""):
            # the FMU refused a parameter value before the run: bad input, said in the user's words (no FMI call)
            log = e.log.strip().splitlines()[0]
            error = f"system {info['system']}: " + (log if log.startswith(f"{e.instance} ") else
                                                    f"instance {e.instance}: {log}")
            bad_input = True
    except KeyboardInterrupt:
        interrupted = True
        error = f"interrupted (Ctrl-C) at t = {rec.time[rec.rows - 1] if rec.rows else 0.0:.9g} s"
    finally:
        if bar is not None:
            bar.close()
    info.update(steps=steps, wall_time=_time.perf_counter() - wall, iterations=m.iterations,
                rejected=controller.rejected, max_error_estimate=controller.max_accepted_error)
    df = rec.frame(complete=not error, error=error, **info)
    df.attrs["diverged"] = isinstance(err_obj, Diverged)
    df.attrs["interrupted"] = interrupted
    df.attrs["bad_input"] = bad_input
    df.attrs["suspect"] = suspect
    if interrupted:
        raise RunInterrupted(error, partial=df)
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
        "run", help="run a system (module in systems/, or .ssp/.ssd) and write its result",
        description="Co-simulate a system and write the result as CSV (time in s, one column per "
                    "Instance.variable). A run that stops early (divergence, FMU failure, Ctrl-C) writes what it "
                    "computed to OUT.partial.csv instead of OUT, says so on stderr in one line and exits 1 (130 "
                    "after Ctrl-C).")
    p.add_argument("system", help="system module name in systems/ (e.g. bed_drive), or an .ssp/.ssd file")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] (default: the system's default experiment)")
    p.add_argument("--step", type=float, default=None, metavar="SECONDS",
                   help="communication step [s] (default: the system's default experiment)")
    p.add_argument("--master", default=None, metavar="NAME",
                   help="jacobi, jacobi-sampled, gauss-seidel or iterative (default: the system's, else jacobi)")
    p.add_argument("--extrapolation", type=int, default=None, choices=(0, 1, 2),
                   help="input extrapolation order (default: the system's, else 0 = hold)")
    p.add_argument("--step-control", default=None, choices=("none", "richardson", "ecco"),
                   help="step control (default: the system's, else none = fixed step)")
    p.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                   help="relative tolerance [-] of step control and iteration (default: the system's, else none)")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="set a parameter in its declared unit (repeatable; default: the system's values)")
    p.add_argument("--output", action="append", default=None, metavar="Instance.variable",
                   help="record only these variables (repeatable; default: every output)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE.csv",
                   help="write the result as CSV to this file (default: not written)")
    p.add_argument("--units", action="store_true",
                   help="write a second header row with each column's unit (read it with "
                        "pandas.read_csv(FILE, header=[0, 1], index_col=0)); default: names only")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="write a chart of the run (bond speeds and torques, scene quantities) as "
                        "DIR/<system>.png/.svg (default: no chart)")
    p.add_argument("--fmi-only", action="store_true",
                   help="call every FMU through its FMI library (default: pythonfmu FMUs, the toolkit's and "
                        "others', are called in this process: the same results bit for bit, faster)")
    p.set_defaults(func=run_cli)


def partial_path(path: Path) -> Path:
    """Where an incomplete result is written instead of ``path``: ``x.csv`` -> ``x.partial.csv``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix or '.csv'}")


def run_cli(args) -> int:
    interrupted = False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RunWarning)  # the CLI reports a stop itself, in one line
            df = simulate(args.system, stop_time=args.stop_time, step=args.step, master=args.master,
                          extrapolation=args.extrapolation, step_control=args.step_control,
                          tolerance=args.tolerance, parameters=parse_sets(args.set), outputs=args.output,
                          options=RunOptions(progress=None, in_process=False if args.fmi_only else None),
                          on_error="return")
    except RunInterrupted as e:
        df, interrupted = e.partial, True
    a = df.attrs
    if a.get("bad_input"):  # a refused parameter: nothing was computed, nothing is written
        print(f"error: {a['error']}", file=sys.stderr)
        return 1
    out = args.out
    if out is not None and not a["complete"]:
        out = partial_path(out)
    if out is not None:
        to_csv(df, out, units=getattr(args, "units", False))
    where = f"wrote {out}" if out is not None else "no --out given, result not written"
    if args.plot is not None and len(df):
        from harness.charts import plot_result

        where += "; chart " + str(plot_result(load(args.system), df, args.plot)[0])
    if not a["complete"]:
        print(f"error: {a['error']}; {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s kept, "
              f"{'INCOMPLETE result ' + where if out is not None else where}", file=sys.stderr)
        return 130 if interrupted else 1
    if a.get("suspect"):
        print(f"warning: {a['suspect']}", file=sys.stderr)
    print(f"{a['system']}: {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s, master {a['master']}, "
          f"{a['steps']} steps in {a['wall_time']:.3g} s; {where}")
    return 0


__all__ = ["load", "simulate", "RunOptions", "RunWarning", "RunInterrupted", "column_units", "partial_path", "register", "run_cli", "parse_sets", "HarnessError"]
