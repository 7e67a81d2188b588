"""Run FMUs and SSP systems in other FMI tools (libcosim, Ecos) and in a plain fmpy loop, for comparison.

Every ``run_*`` function returns the toolkit's one result type: a pandas DataFrame indexed by time (index
name ``time``, the times REPORTED BY THE TOOL, so a tool that does not step at the requested step shows it)
with columns ``<instance>.<variable>``; the first row is t = 0 after initialisation, then one row after every
communication step.  ``df.attrs`` carries ``peer`` and ``steps``.  Parameters and inputs are constants, set
once before initialisation (FMI start values, so they also hold in initialisation mode).

    from benchmarks.peers import available, run_fmu_fmpy, run_fmu_libcosim, run_fmu_ecos
    ref = run_fmu_fmpy("Inertia.fmu", 0.05, 1e-3, {"J": 0.5}, {"flange.tau": 2.0}, ["flange.w"])

Tools, and what was found about them (libcosimpy 0.0.6 / libcosim 0.11, ecospy 0.7.2, CoFmuPy 1.0.0):

* **GIL and threads.**  libcosim calls ``fmi2DoStep`` from a worker thread of its own pool (its log shows a
  thread id other than the caller's); Ecos steps in the calling thread.  Both bindings are ``ctypes.CDLL``
  libraries, and ctypes RELEASES the GIL for the duration of every foreign call, so the pythonfmu FMU, which
  takes the GIL itself (``PyGILState_Ensure``) around each FMI call, runs in the worker thread while the
  main thread waits in C: no deadlock, no subprocess needed (checked with every FMU of the toolkit, repeated
  loads in one process).  Any binding built with ``ctypes.PyDLL`` or a C extension that keeps the GIL while
  stepping would deadlock; Ecos also offers ``proxyfmu://localhost?file=<path>`` model URIs that run an FMU
  in a separate process, should that ever be needed.
* **Loading.**  libcosim unzips every FMU into its own temporary folder, and Ecos likewise; both
  ``dlclose`` the FMU library and DELETE the folder when the run ends.  The toolkit's FMUs survive that:
  each carries its code under its build's package name (``fmus_<hash>``, one import for the FMUs of one build;
  its declaration found in its own folder) and imports all of it when instantiated, so nothing is imported
  later from a deleted folder (``tests/test_hosts.py`` runs whole SSPs
  one after the other in one process under both tools).  Our fmpy loop never unloads a library
  (``fmi2FreeInstance`` only; fmpy's ``freeInstance()`` would unload it) and never frees an instance
  after an error: pythonfmu reports any Python exception as fmi2Fatal, after which FMI allows no call, and
  ``fmi2FreeInstance`` there corrupts memory (segfault in the next garbage collection).
* **Time.**  libcosim counts time in integer nanoseconds: the step must be a whole number of ns, and the
  FMU receives ``t_k = ns_k / 1e9`` and ``h_k = t_k+1 - t_k`` (not always equal to ``step``); Ecos (and
  CoFmuPy) accumulate ``t += h``; fmpy here uses ``t_k = k * h``.  Only these doubles differ: fmpy given a
  tool's convention (:func:`communication_points`) reproduces it bit for bit, for every FMU of the toolkit.
* **Failures.**  An FMU that fails in initialisation ABORTS the process under libcosim and SEGFAULTS it
  under Ecos (details in :func:`run_isolated`, which runs a peer in a subprocess and reports an error).
* **libcosimpy quirks worked around here:** ``CosimObserver.time_series_real_samples`` trims its result by
  counting zero step numbers, so it drops one sample when reading from step 0 (we call
  ``cosim_observer_slave_get_real_samples`` directly); the default time-series buffer holds 10 000 samples
  (we size it to the run); ``real_initial_value`` returns False for unknown references without a message.
* **CoFmuPy** (``pip install cofmupy``, not installed in this environment on purpose): it pins
  ``pythonfmu==0.6.3``, ``fmpy==0.3.20``, ``networkx==3.2.1`` and ``streamlit==1.12``, which would DOWNGRADE
  the pythonfmu that builds our FMUs: install it in a separate virtual environment.  Its API: a JSON (or
  dict) config ``{"fmus": [{"id", "path", "initialization": {var: value}}], "connections": [{"source":
  {"id", "variable", "type": "fmu"}, "target": [...]}], "cosim_method": "jacobi"|"gauss-seidel",
  "iterative": false}`` (see :func:`cofmupy_config`), then ``c = cofmupy.Coordinator(); c.start(conf_path=
  cfg)`` and ``c.do_step(h)`` / ``c.run_simulation(h, t_end)``, results via ``c.get_results()`` (dict keyed
  by ``"time"`` and ``(fmu_id, variable)``).  Each FMU is extracted again per handler (``fmpy.extract``),
  the instance name is the file name, time is accumulated (``t += h``), inputs and outputs go through
  fmpy's per-variable ``setReal``/``getReal`` lists, and the recorded ``time`` is the time at the START of
  the step whose outputs it stores (one step behind the other tools).
"""
from __future__ import annotations

import importlib
import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness.errors import FMUError, SystemDescriptionError

PEERS = {"fmpy": "fmpy.fmi2", "libcosim": "libcosimpy.CosimExecution", "ecos": "ecospy",
         "cofmupy": "cofmupy"}


def available() -> dict[str, str | None]:
    """For each peer tool: None if it imports, else the reason (one line) why not."""
    reasons: dict[str, str | None] = {}
    for peer, module in PEERS.items():
        try:
            importlib.import_module(module)
            reasons[peer] = None
        except Exception as e:  # ImportError, or OSError from a missing shared library (e.g. libtbb12)
            reasons[peer] = f"{peer} unavailable: {type(e).__name__}: {' '.join(str(e).split())}"
    return reasons


# -- shared checks ---------------------------------------------------------------------------------------------
def n_steps(stop_time: float, step: float) -> int:
    """Number of communication steps; stop_time must be a whole number of steps."""
    if not (isinstance(step, (int, float)) and math.isfinite(step) and step > 0):
        raise SystemDescriptionError(f"step = {step!r} must be a finite number > 0 s")
    if not (isinstance(stop_time, (int, float)) and math.isfinite(stop_time) and stop_time > 0):
        raise SystemDescriptionError(f"stop_time = {stop_time!r} must be a finite number > 0 s")
    n = round(stop_time / step)
    if n < 1 or abs(n * step - stop_time) > 1e-9 * stop_time:
        raise SystemDescriptionError(f"stop_time = {stop_time!r} s is not a whole number of steps of step = {step!r} s")
    return n


def _variables(fmu_path) -> tuple[object, dict]:
    """(model description, name -> ModelVariable), from the once-per-process extraction cache."""
    from harness.fmi.fmu import extracted

    md, _ = extracted(fmu_path)
    return md, {v.name: v for v in md.modelVariables}


def _check_start(md, variables: dict, parameters: dict, inputs: dict) -> None:
    """Every parameter/input exists with that causality; inputs are Real; Real values finite."""
    wanted = [(n, "parameter", v) for n, v in parameters.items()] + [(n, "input", v) for n, v in inputs.items()]
    for name, causality, value in wanted:
        var = variables.get(name)
        if var is None:
            raise SystemDescriptionError(f"{md.modelName}: no {causality} {name!r}")
        if var.causality != causality:
            raise SystemDescriptionError(f"{md.modelName}: {name} has causality {var.causality}, not {causality}")
        if causality == "input" and var.type != "Real":
            raise SystemDescriptionError(f"{md.modelName}: input {name} is {var.type}; only Real inputs are supported")
        if var.type == "Real" and not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise SystemDescriptionError(f"{md.modelName}: {causality} {name} = {value!r} is not a finite number")


def _check_request(fmu_path, parameters: dict, inputs: dict, outputs: list) -> tuple[object, dict]:
    """The FMU's model description and variables, after checking every name.  One-line errors."""
    md, variables = _variables(fmu_path)
    _check_start(md, variables, parameters, inputs)
    if not outputs:
        raise SystemDescriptionError(f"{md.modelName}: no outputs requested")
    for name in outputs:
        var = variables.get(name)
        if var is None or var.type != "Real":
            raise SystemDescriptionError(f"{md.modelName}: no Real variable {name!r} to record")
    return md, variables


def _frame(times, columns: list[str], values, peer: str) -> pd.DataFrame:
    df = pd.DataFrame(np.asarray(values, dtype=float).reshape(len(times), len(columns)), columns=columns,
                      index=pd.Index(np.asarray(times, dtype=float), name="time"))
    df.attrs.update(peer=peer, steps=len(times) - 1)
    return df


def _check_times(peer: str, times, step: float) -> None:
    """The tool's reported communication points must be k * step (to 1e-9 of a step)."""
    t = np.asarray(times, dtype=float)
    k = np.arange(len(t))
    bad = np.flatnonzero(np.abs(t - k * step) > 1e-9 * step)
    if bad.size:
        i = int(bad[0])
        raise FMUError(peer, "time check", float(t[i]), None,
                       detail=f"row {i} is at t = {float(t[i])!r} s, expected {i * step!r} s (step {step!r} s)")


def run_isolated(function, *args, timeout: float = 300.0, **kwargs):
    """``function(*args, **kwargs)`` in a fresh (spawned) process; its result or exception comes back.

    Use it for libcosim and Ecos when the FMU may fail.  libcosim 0.11 throws ``cosim::error`` from its worker
    thread when an FMU fails in initialisation, which ends in ``std::terminate``: it ABORTS THE WHOLE PROCESS.
    Ecos 0.7.2 ignores the error status of ``fmi2EnterInitializationMode`` (``init`` returns True) and then
    SEGFAULTS in the first step.  Here either becomes an :class:`FMUError` naming the exit code."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        future = pool.submit(function, *args, **kwargs)
        try:
            return future.result(timeout=timeout)
        except BrokenProcessPool as e:
            codes = [p.exitcode for p in getattr(pool, "_processes", {}).values()]
            raise FMUError(getattr(function, "__name__", str(function)), "isolated run", None, None,
                           detail=f"the process died (exit code {codes[0] if codes else '?'}); "
                                  "see its stderr for the tool's last message") from e


def _fmpy_set(slave, var, value) -> None:
    vr = [var.valueReference]
    if var.type == "Real":
        slave.setReal(vr, [float(value)])
    elif var.type in ("Integer", "Enumeration"):
        slave.setInteger(vr, [int(value)])
    elif var.type == "Boolean":
        slave.setBoolean(vr, [bool(value)])
    else:
        slave.setString(vr, [str(value)])


TIME_CONVENTIONS = ("exact", "harness", "libcosim", "accumulate")


def communication_points(n: int, step: float, convention: str = "exact") -> tuple[np.ndarray, np.ndarray]:
    """(t_0 .. t_n, h_0 .. h_n-1): the doubles a tool hands ``fmi2DoStep``, by its time convention.

    * ``exact`` (the fmpy loop here): t_k = k * step, h_k = step;
    * ``harness`` (our master's integer nanoseconds): t_k = (k * step_ns) / 1e9, h_k = step_ns / 1e9;
    * ``libcosim``: the same t_k, and h_k = t_k+1 - t_k;
    * ``accumulate`` (Ecos, CoFmuPy): t_k+1 = t_k + step, h_k = step."""
    if convention == "exact":
        return np.arange(n + 1) * step, np.full(n, float(step))
    if convention in ("harness", "libcosim"):
        step_ns = step_nanoseconds(step)
        t = (np.arange(n + 1, dtype=np.int64) * step_ns) / 1e9
        return t, (np.full(n, step_ns / 1e9) if convention == "harness" else np.diff(t))
    if convention == "accumulate":
        t = np.empty(n + 1)
        t[0] = acc = 0.0
        for k in range(1, n + 1):
            acc += step
            t[k] = acc
        return t, np.full(n, float(step))
    raise SystemDescriptionError(f"time convention {convention!r} is not one of {', '.join(TIME_CONVENTIONS)}")


def run_fmu_fmpy(fmu_path, stop_time: float, step: float, parameters: dict, inputs: dict, outputs: list,
                 instance: str | None = None, convention: str = "exact") -> pd.DataFrame:
    """A plain fmpy ``FMU2Slave`` loop: start values, initialisation, then ``doStep(t_k, h_k)`` with the
    communication points of ``convention`` (see :func:`communication_points`; pass another tool's
    convention to reproduce its doubles bit for bit)."""
    from fmpy.fmi2 import FMU2Slave
    from harness.fmi.fmu import extracted

    n = n_steps(stop_time, step)
    md, variables = _check_request(fmu_path, parameters, inputs, outputs)
    grid, steps = communication_points(n, step, convention)
    name = instance or md.modelName
    _, unzip_dir = extracted(fmu_path)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip_dir),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(loggingOn=False)
    try:
        slave.setupExperiment(startTime=0.0)
        for key, value in {**parameters, **inputs}.items():
            _fmpy_set(slave, variables[key], value)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        vrs = [variables[o].valueReference for o in outputs]
        values = np.empty((n + 1, len(outputs)))
        values[0] = slave.getReal(vrs)
        for k in range(n):
            slave.doStep(currentCommunicationPoint=float(grid[k]), communicationStepSize=float(steps[k]))
            values[k + 1] = slave.getReal(vrs)
        slave.terminate()
    except Exception as e:
        # FMI 2.0: after fmi2Error/fmi2Fatal no further call is allowed (pythonfmu reports every Python
        # exception as fatal), so the instance is NOT freed: fmi2FreeInstance here corrupts pythonfmu's
        # objects and the next garbage collection segfaults.  The instance leaks.
        raise FMUError(name, "fmpy run", None, None, detail=f"{type(e).__name__}: {e}") from e
    slave.fmi2FreeInstance(slave.component)   # NOT freeInstance(): that also unloads the library
    return _frame(grid, [f"{name}.{o}" for o in outputs], values, "fmpy")


# -- libcosim (libcosimpy) -------------------------------------------------------------------------------------
_LIBCOSIM_QUIET = []


def _libcosim():
    """The libcosimpy modules, with libcosim's own log reduced to warnings (once)."""
    from libcosimpy import CosimExecution, CosimLogging, CosimObserver, CosimSlave, CosimEnums

    if not _LIBCOSIM_QUIET:
        CosimLogging.log_output_level(CosimLogging.CosimLogLevel.WARNING)
        _LIBCOSIM_QUIET.append(True)
    return CosimExecution.CosimExecution, CosimSlave.CosimLocalSlave, CosimObserver.CosimObserver, CosimEnums


def step_nanoseconds(step: float) -> int:
    """libcosim's step in integer nanoseconds; the step must be one (to 1e-9 relative)."""
    ns = round(step * 1e9)
    if ns < 1 or abs(ns - step * 1e9) > 1e-9 * step * 1e9:
        raise SystemDescriptionError(f"libcosim: step = {step!r} s is not a whole number of nanoseconds")
    return ns


def _libcosim_error(what: str, detail: str = "") -> FMUError:
    from libcosimpy._internal import get_last_error_message

    return FMUError("libcosim", what, None, None, detail=" ".join(f"{detail} {get_last_error_message()}".split()))


def _libcosim_set_initial(execution, index: int, var, value) -> None:
    setter = {"Real": execution.real_initial_value, "Integer": execution.integer_initial_value,
              "Enumeration": execution.integer_initial_value, "Boolean": execution.boolean_initial_value,
              "String": execution.string_initial_value}[var.type]
    cast = {"Real": float, "Integer": int, "Enumeration": int, "Boolean": bool, "String": str}[var.type]
    if not setter(index, var.valueReference, cast(value)):
        raise _libcosim_error("set initial value", f"{var.name} = {value!r}:")


def _libcosim_samples(observer, index: int, reference: int, count: int,
                      integer: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(time points [ns], values) of one Real (``integer``: Integer) variable from step 0, read with the C call
    directly (the libcosimpy wrapper drops a sample, see the module docstring)."""
    from ctypes import POINTER, c_double, c_int, c_int64, c_size_t, c_uint32

    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy._internal import libcosimc, wrap_function

    c_value = c_int if integer else c_double
    get = wrap_function(lib=libcosimc(),
                        funcname=f"cosim_observer_slave_get_{'integer' if integer else 'real'}_samples",
                        argtypes=[POINTER(CosimObserver), c_int, c_uint32, c_int64, c_size_t,
                                  c_value * count, c_int64 * count, c_int64 * count], restype=c_int64)
    values, steps, times = (c_value * count)(), (c_int64 * count)(), (c_int64 * count)()
    got = get(observer.ptr(), index, reference, 0, count, values, steps, times)
    if got != count:
        raise _libcosim_error("read samples", f"got {got} of {count} samples of reference {reference}:")
    if list(steps) != list(range(count)):
        raise FMUError("libcosim", "read samples", None, None, detail="step numbers are not 0, 1, 2, ...")
    return np.frombuffer(times, dtype=np.int64).copy(), np.array(values[:], dtype=float)


def _libcosim_record(execution, observer_cls, enums, targets: list[tuple], n: int):
    """A buffered time-series observer started for each (slave index, value reference[, integer]): Real
    variables unless the third item is True."""
    observer = observer_cls.create_time_series(buffer_size=n + 1)
    if not execution.add_observer(observer):
        raise _libcosim_error("add observer")
    for index, reference, *integer in targets:
        kind = enums.CosimVariableType.INTEGER if integer and integer[0] else enums.CosimVariableType.REAL
        if not observer.start_time_series(index, reference, kind):
            raise _libcosim_error("start time series", f"slave {index} reference {reference}:")
    return observer


def _libcosim_run(execution, observer, targets, n: int, step: float, columns: list[str]) -> pd.DataFrame:
    """Step n times in one call, check the status and the time grid, collect the samples."""
    if not execution.step(n):
        raise _libcosim_error("step", f"{n} steps of {step!r} s:")
    status = execution.status()
    if status.error_code != 0:
        raise _libcosim_error("step", f"error code {status.error_code}:")
    data, times = [], None
    for index, reference in targets:
        t_ns, v = _libcosim_samples(observer, index, reference, n + 1)
        times = t_ns if times is None else times
        data.append(v)
    t = times / 1e9
    _check_times("libcosim", t, step)
    return _frame(t, columns, np.column_stack(data), "libcosim")


def run_fmu_libcosim(fmu_path, stop_time: float, step: float, parameters: dict, inputs: dict, outputs: list,
                     instance: str | None = None) -> pd.DataFrame:
    """One FMU in a libcosim fixed-step execution (``cosim_execution_create``, a local slave, initial values
    for parameters and inputs, a buffered time-series observer, one ``step(n)`` call)."""
    n = n_steps(stop_time, step)
    md, variables = _check_request(fmu_path, parameters, inputs, outputs)
    name = instance or md.modelName
    execution_cls, slave_cls, observer_cls, enums = _libcosim()
    execution = execution_cls.from_step_size(step_nanoseconds(step))
    slave = slave_cls(fmu_path=str(Path(fmu_path).resolve()), instance_name=name)
    index = execution.add_local_slave(slave)
    if index < 0:
        raise _libcosim_error("add slave", f"{fmu_path}:")
    for key, value in {**parameters, **inputs}.items():
        _libcosim_set_initial(execution, index, variables[key], value)
    targets = [(index, variables[o].valueReference) for o in outputs]
    observer = _libcosim_record(execution, observer_cls, enums, targets, n)
    return _libcosim_run(execution, observer, targets, n, step, [f"{name}.{o}" for o in outputs])


def _split(column: str, instances: list[str]) -> tuple[str, str]:
    """'Instance.variable' -> (instance, variable), matching the longest instance name (variables have dots)."""
    for inst in sorted(instances, key=len, reverse=True):
        if column.startswith(inst + "."):
            return inst, column[len(inst) + 1:]
    raise SystemDescriptionError(f"output {column!r} names no instance of the system ({', '.join(sorted(instances))})")


def libcosim_targets(execution, enums, outputs: list) -> list[tuple[int, int]]:
    """(slave index, value reference) of each 'Instance.variable' of ``outputs`` in a libcosim execution (Real
    variables only; another name is refused in one line)."""
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    refs = {i: {v.name.decode(): v.reference for v in execution.slave_variables(i)
                if v.type == enums.CosimVariableType.REAL.value} for i in slaves.values()}
    targets = []
    for column in outputs:
        inst, var = _split(column, list(slaves))
        if var not in refs[slaves[inst]]:
            raise SystemDescriptionError(f"{inst}: no Real variable {var!r} to record")
        targets.append((slaves[inst], refs[slaves[inst]][var]))
    return targets


def run_ssp_libcosim(ssp_path, stop_time: float, step: float, outputs: list) -> pd.DataFrame:
    """A whole SSP system (``.ssp`` archive, folder, or ``SystemStructure.ssd``) in libcosim, with the given
    fixed step (which overrides the OSP ``FixedStepMaster`` annotation).  ``outputs``: 'Instance.variable'."""
    n = n_steps(stop_time, step)
    execution_cls, _, observer_cls, enums = _libcosim()
    path = Path(ssp_path).resolve()
    if not path.exists():
        raise SystemDescriptionError(f"no SSP file or folder {path}")
    try:
        execution = execution_cls.from_ssp_file(str(path), step_nanoseconds(step))
    except AssertionError as e:
        raise _libcosim_error("load SSP", f"{path}:") from e
    targets = libcosim_targets(execution, enums, outputs)
    observer = _libcosim_record(execution, observer_cls, enums, targets, n)
    return _libcosim_run(execution, observer, targets, n, step, list(outputs))


# -- Ecos (ecospy) ---------------------------------------------------------------------------------------------
def _ecos():
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    return ecospy


def _ecos_parameters(name: str, variables: dict, values: dict) -> dict:
    """'instance::variable' -> value with the Python type ecospy maps to the FMI type."""
    cast = {"Real": float, "Integer": int, "Enumeration": int, "Boolean": bool, "String": str}
    return {f"{name}::{key}": cast[variables[key].type](value) for key, value in values.items()}


def _ecos_run(sim, n: int, step: float, identifiers: list[str], columns: list[str],
              parameter_set: str | None) -> pd.DataFrame:
    """Initialise, then step one step at a time, reading every identifier after each step."""
    if not sim.init(0.0, parameter_set):
        raise FMUError("ecos", "init", 0.0, None, detail=_ecos().EcosLib.get_last_error())
    values = np.empty((n + 1, len(identifiers)))
    times = np.empty(n + 1)
    times[0] = sim.get_time()
    try:
        values[0] = [sim.get_real(i) for i in identifiers]
        for k in range(1, n + 1):
            times[k] = sim.step(1)
            values[k] = [sim.get_real(i) for i in identifiers]
    except Exception as e:  # ecospy raises bare Exception with the library's last error
        raise FMUError("ecos", "step", float(times[k - 1]) if n else 0.0, None, detail=str(e)) from e
    finally:
        sim.terminate()
    _check_times("ecos", times, step)
    return _frame(times, columns, values, "ecos")


def run_fmu_ecos(fmu_path, stop_time: float, step: float, parameters: dict, inputs: dict, outputs: list,
                 instance: str | None = None) -> pd.DataFrame:
    """One FMU in Ecos (a simulation structure with one model; parameters AND the constant inputs go in a
    parameter set applied by ``init``, i.e. before initialisation, as start values)."""
    n = n_steps(stop_time, step)
    md, variables = _check_request(fmu_path, parameters, inputs, outputs)
    name = instance or md.modelName
    ecospy = _ecos()
    structure = ecospy.EcosSimulationStructure()
    try:
        structure.add_model(name, str(Path(fmu_path).resolve()))
    except Exception as e:
        raise FMUError(name, "ecos add_model", None, None, detail=str(e)) from e
    start = _ecos_parameters(name, variables, {**parameters, **inputs})
    if start and not structure.add_parameter_set("start", start):
        raise FMUError(name, "ecos add_parameter_set", None, None, detail=ecospy.EcosLib.get_last_error())
    with ecospy.EcosSimulation(structure=structure, step_size=step) as sim:
        return _ecos_run(sim, n, step, [f"{name}::{o}" for o in outputs], [f"{name}.{o}" for o in outputs],
                         "start" if start else None)


def run_ssp_ecos(ssp_path, stop_time: float, step: float, outputs: list,
                 parameter_set: str | None = None) -> pd.DataFrame:
    """A whole SSP system in Ecos at the given fixed step; ``parameter_set`` names an ``ssv:ParameterSet`` of
    the SSP to apply at initialisation (the toolkit's exporter writes one named ``default``)."""
    n = n_steps(stop_time, step)
    path = Path(ssp_path).resolve()
    if not path.exists():
        raise SystemDescriptionError(f"no SSP file or folder {path}")
    ecospy = _ecos()
    try:
        sim = ecospy.EcosSimulation(ssp_path=str(path), step_size=step)
    except Exception as e:
        raise FMUError("ecos", "load SSP", None, None, detail=f"{path}: {e}") from e
    with sim:
        identifiers = []
        for column in outputs:
            inst, _, var = column.partition(".")
            identifiers.append(f"{inst}::{var}")
        return _ecos_run(sim, n, step, identifiers, list(outputs), parameter_set)


# -- CoFmuPy (not installed here: see the module docstring) ---------------------------------------------------
def cofmupy_config(fmu_path, parameters: dict, inputs: dict, instance: str | None = None) -> dict:
    """A CoFmuPy configuration (the dict form of its JSON file) for one FMU; parameters and constant inputs
    are ``initialization`` values (set before ``fmi2EnterInitializationMode``)."""
    md, variables = _variables(fmu_path)
    _check_start(md, variables, parameters, inputs)
    return {"fmus": [{"id": instance or md.modelName, "path": str(Path(fmu_path).resolve()),
                      "initialization": {**parameters, **inputs}}],
            "connections": [], "cosim_method": "jacobi", "iterative": False}


def run_fmu_cofmupy(fmu_path, stop_time: float, step: float, parameters: dict, inputs: dict, outputs: list,
                    instance: str | None = None) -> pd.DataFrame:
    """One FMU in CoFmuPy's Coordinator (needs ``cofmupy`` importable in THIS interpreter).  CoFmuPy's own
    results hold outputs only, labelled with the time at the START of each step, without a t = 0 row: here
    every variable is read after initialisation and after each ``do_step``, at the coordinator's time."""
    from cofmupy import Coordinator

    n = n_steps(stop_time, step)
    md, _ = _check_request(fmu_path, parameters, inputs, outputs)
    name = instance or md.modelName
    coordinator = Coordinator()
    coordinator.start(conf_path=cofmupy_config(fmu_path, parameters, inputs, name))
    keys = [(name, o) for o in outputs]
    values = np.empty((n + 1, len(outputs)))
    times = np.empty(n + 1)
    for k in range(n + 1):
        if k:
            coordinator.do_step(step)
        times[k] = coordinator.master.current_time
        values[k] = [coordinator.get_variable(key)[0] for key in keys]
    _check_times("cofmupy", times, step)
    return _frame(times, [f"{name}.{o}" for o in outputs], values, "cofmupy")
