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

from harness.errors import FMUError, HarnessError, SimulationError, SystemError_
from harness.extrapolation import extrapolation as make_extrapolation
from harness.fmi import Instance, open_instance
from harness.masters import NS, ConvergenceError, IterationOptions, master_class
from harness.model import System, model_description, resolve_fmu
from harness.results import Recorder, to_csv
from harness.stepcontrol import StepOptions, step_control as make_step_control


class RunWarning(UserWarning):
    """A run that stopped early and returned a partial result."""


@dataclass
class RunOptions:
    """Options of :func:`simulate` beyond its keyword arguments.

    ``iteration``: the ``iterative`` master's solver; ``steps``: limits of the variable-step controllers;
    ``blowup``: an output whose magnitude exceeds it stops the run (amplitude blow-up); ``progress``: tqdm
    progress bar (None: only when stderr is a terminal, shown after 2 s); ``logging``: FMU debug logging;
    ``in_process``: how pythonfmu FMUs are called (:func:`harness.fmi.open_instance`: None runs the toolkit's
    own FMUs in this process and every other FMU through FMI; True runs every pythonfmu FMU in-process;
    False calls every FMU through FMI).  Results are the same bit for bit; only the cost differs."""
    iteration: IterationOptions = field(default_factory=IterationOptions)
    steps: StepOptions = field(default_factory=StepOptions)
    blowup: float = 1e12
    progress: bool | None = None
    logging: bool = True
    in_process: bool | None = None


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


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise SystemError_(f"{name} = {value!r} is not admissible: must be a positive finite number [s]")
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
    """Run ``system`` and return the result DataFrame (module docstring)."""
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
        _positive("tolerance", tolerance)
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
                    step_control=controller.name, step=step, stop_time=stop_time)
        return _run(m, controller, rec, params, stop_ns, step_ns, tolerance, on_error, opts, info)
    finally:
        if m is not None:
            m.terminate()
            m.free()
        else:
            for f in fmus.values():
                f.free()


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
    try:
        m.initialize(0, stop_ns, tolerance, params)
        rec.record(0.0)
        h_ns = step_ns
        shown = 0
        while t_ns < stop_ns:
            t_ns, h_ns = controller.advance(m, t_ns, h_ns, stop_ns)
            steps += 1
            rec.record(t_ns / NS)
            if bar is not None and (steps & 63) == 0:
                bar.update((t_ns - shown) / NS)
                shown = t_ns
    except (FMUError, SimulationError, ConvergenceError) as e:
        error = str(e).splitlines()[0] if str(e) else type(e).__name__
        err_obj = e
    finally:
        if bar is not None:
            bar.close()
    info.update(steps=steps, wall_time=_time.perf_counter() - wall, iterations=m.iterations,
                rejected=controller.rejected, max_error_estimate=controller.max_accepted_error)
    df = rec.frame(complete=not error, error=error, **info)
    if error:
        if on_error == "raise":
            raise SimulationError(error, partial=df, time=getattr(err_obj, "time", None),
                                  instance=getattr(err_obj, "instance", None),
                                  variable=getattr(err_obj, "variable", None)) from err_obj
        warnings.warn(f"run stopped early: {error}", RunWarning, stacklevel=3)
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
    p = subparsers.add_parser("run", help="run a system (module in systems/, or .ssp/.ssd) and write its result",
                              description="Run a co-simulation of a system and write the result as CSV.")
    p.add_argument("system", help="system module name in systems/, or an .ssp/.ssd file")
    p.add_argument("--stop-time", type=float, default=None, help="stop time [s] (default: the system's)")
    p.add_argument("--step", type=float, default=None, help="communication step [s] (default: the system's)")
    p.add_argument("--master", default=None, help="jacobi, gauss-seidel or iterative (default: the system's)")
    p.add_argument("--extrapolation", type=int, default=None, choices=(0, 1, 2), help="input extrapolation order")
    p.add_argument("--step-control", default=None, choices=("none", "richardson", "ecco"), help="step control")
    p.add_argument("--tolerance", type=float, default=None, help="tolerance of step control / iteration")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="set a parameter (repeatable)")
    p.add_argument("--output", action="append", default=None, metavar="Instance.variable",
                   help="record only these variables (repeatable; default: every output)")
    p.add_argument("--out", type=Path, default=None, help="write the result as CSV to this file")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="write a chart of the run (bond speeds and torques, scene quantities) as DIR/<system>.png/.svg")
    p.set_defaults(func=run_cli)


def run_cli(args) -> int:
    df = simulate(args.system, stop_time=args.stop_time, step=args.step, master=args.master,
                  extrapolation=args.extrapolation, step_control=args.step_control, tolerance=args.tolerance,
                  parameters=parse_sets(args.set), outputs=args.output,
                  options=RunOptions(progress=None), on_error="return")
    if args.out is not None:
        to_csv(df, args.out)
    a = df.attrs
    where = f"wrote {args.out}" if args.out is not None else "no --out given, result not written"
    if args.plot is not None and len(df):
        from harness.charts import plot_result

        where += "; chart " + str(plot_result(load(args.system), df, args.plot)[0])
    print(f"{a['system']}: {len(df)} points to t = {df.index[-1] if len(df) else 0:.6g} s, master {a['master']}, "
          f"{a['steps']} steps in {a['wall_time']:.3g} s; {where}")
    if not a["complete"]:
        print(f"error: {a['error']}", file=sys.stderr)
        return 1
    return 0


__all__ = ["load", "simulate", "RunOptions", "RunWarning", "register", "run_cli", "parse_sets", "HarnessError"]
