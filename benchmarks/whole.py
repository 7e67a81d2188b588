"""One peer's whole run as a user of that tool writes it, for the whole-process scope of :mod:`benchmarks.scopes`:
``python -m benchmarks.whole TOOL SSP STOP STEP OUT COLUMN...`` loads the exported SSP, initialises, runs it to
STOP at the fixed STEP, writes COLUMN... ('Instance.variable') over time to the CSV file OUT with the tool's own
writer where it has one, and exits.  The parent times the process from outside (start to exit).

Each tool imports only what it needs (no harness, no pandas): this module's own imports are the standard
library's, so the process costs what the tool costs.

* ``omsimulator``: OMSimulator's Python API; its result file restricted to the columns
  (``removeSignalsFromResults(".*")``, then ``addSignalsToResults``);
* ``libcosim``: libcosimpy, a buffered time-series observer on the columns, one ``step(n)``, the samples read
  with the C call and written with :mod:`csv`;
* ``ecos``: ecospy with its own CSV writer (``add_csv_writer`` on the columns), ``init`` with the SSP's parameter
  set ``default``, one ``step(n)``;
* ``fmpy-ssp``: ``fmpy.ssp.simulation.simulate_ssp`` with the SSD's parameter bindings passed as a parameter
  set (as :mod:`benchmarks.host_accuracy` does), written with ``fmpy.util.write_csv``.

``python -m benchmarks.whole --sweep TOOL SSP STOP STEP PARAMETER VALUE...``: a sweep as that tool's user runs
one, each point in the same process with the archive loaded again (its FMUs too), no result file
(``omsimulator``, ``ecos``).
"""
from __future__ import annotations

import csv
import re
import sys
from pathlib import Path

TOOLS = ("omsimulator", "libcosim", "ecos", "fmpy-ssp")


def n_steps(stop: float, step: float) -> int:
    n = round(stop / step)
    if abs(n * step - stop) > 1e-9 * stop:
        raise ValueError(f"stop time {stop!r} s is not a whole number of steps of {step!r} s")
    return n


def run_omsimulator(ssp: str, stop: float, step: float, out: str, columns: list[str]) -> None:
    from OMSimulator import SSP

    im = SSP(ssp).instantiate()
    im.setFixedStepSize(step)
    im.setStopTime(stop)
    im.setResultFile(out)
    im.removeSignalsFromResults(".*")
    im.addSignalsToResults("|".join(".*\\." + re.escape(c) + "$" for c in columns))
    im.initialize()
    im.simulate()
    im.terminate()
    im.delete()


def run_libcosim(ssp: str, stop: float, step: float, out: str, columns: list[str]) -> None:
    from ctypes import POINTER, c_double, c_int, c_int64, c_size_t, c_uint32

    from libcosimpy import CosimEnums, CosimExecution, CosimLogging, CosimObserver
    from libcosimpy._internal import libcosimc, wrap_function

    CosimLogging.log_output_level(CosimLogging.CosimLogLevel.WARNING)
    n = n_steps(stop, step)
    execution = CosimExecution.CosimExecution.from_ssp_file(str(Path(ssp).resolve()), round(step * 1e9))
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    refs = {i: {v.name.decode(): v.reference for v in execution.slave_variables(i)} for i in slaves.values()}
    observer = CosimObserver.CosimObserver.create_time_series(buffer_size=n + 1)
    execution.add_observer(observer)
    targets = []
    for c in columns:
        inst = max((s for s in slaves if c.startswith(s + ".")), key=len)
        targets.append((slaves[inst], refs[slaves[inst]][c[len(inst) + 1:]]))
        observer.start_time_series(targets[-1][0], targets[-1][1], CosimEnums.CosimVariableType.REAL)
    if not execution.step(n) or execution.status().error_code != 0:
        raise RuntimeError(f"libcosim: stepping failed (error code {execution.status().error_code})")
    get = wrap_function(lib=libcosimc(), funcname="cosim_observer_slave_get_real_samples",
                        argtypes=[POINTER(CosimObserver.CosimObserver), c_int, c_uint32, c_int64, c_size_t,
                                  c_double * (n + 1), c_int64 * (n + 1), c_int64 * (n + 1)], restype=c_int64)
    data, times = [], None
    for index, reference in targets:
        values, steps, t_ns = (c_double * (n + 1))(), (c_int64 * (n + 1))(), (c_int64 * (n + 1))()
        if get(observer.ptr(), index, reference, 0, n + 1, values, steps, t_ns) != n + 1:
            raise RuntimeError(f"libcosim: fewer than {n + 1} samples of {index}:{reference}")
        data.append(values)
        times = times or [t / 1e9 for t in t_ns]
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", *columns])
        w.writerows([t, *(d[k] for d in data)] for k, t in enumerate(times))


def run_ecos(ssp: str, stop: float, step: float, out: str, columns: list[str]) -> None:
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    n = n_steps(stop, step)
    with ecospy.EcosSimulation(ssp_path=str(Path(ssp).resolve()), step_size=step) as sim:
        sim.add_csv_writer(out, identifiers=["{}::{}".format(*c.split(".", 1)) for c in columns])
        if not sim.init(0.0, "default"):
            raise RuntimeError(f"ecos init: {ecospy.EcosLib.get_last_error()}")
        sim.step(n)
        sim.terminate()


def run_fmpy_ssp(ssp: str, stop: float, step: float, out: str, columns: list[str]) -> None:
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssd
    from fmpy.util import write_csv

    bound = ParameterSet(name="bindings")
    for element in read_ssd(ssp).system.elements:
        for binding in element.parameterBindings:
            for values in binding.parameterValues:
                for p in values.parameters:
                    bound.parameters.append(Parameter(name=f"{element.name}.{p.name}", type=p.type, value=p.value))
    result = simulate_ssp(ssp, stop_time=stop, step_size=step, parameter_set=bound)
    names = result.dtype.names
    write_csv(out, result, columns=[next(x for x in names if x == c or x.endswith("." + c)) for c in columns])


RUNNERS = {"omsimulator": run_omsimulator, "libcosim": run_libcosim, "ecos": run_ecos, "fmpy-ssp": run_fmpy_ssp}


def sweep_omsimulator(ssp: str, stop: float, step: float, parameter: str, values: list[float]) -> None:
    """One point per value: the SSP instantiated again (its FMUs loaded again), the parameter set, initialised,
    run to the stop time without a result file, deleted."""
    from OMSimulator import SSP, CRef

    archive = SSP(ssp)
    system = Path(ssp).stem
    for value in values:
        im = archive.instantiate()
        im.setFixedStepSize(step)
        im.setStopTime(stop)
        im.setResultFile("")
        im.setValue(CRef(system, *parameter.split(".", 1)), value)
        im.initialize()
        im.simulate()
        im.terminate()
        im.delete()


def sweep_ecos(ssp: str, stop: float, step: float, parameter: str, values: list[float]) -> None:
    """One point per value: a new simulation of the SSP (its FMUs loaded again), the parameter set before
    ``init``, run to the stop time without a writer."""
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    n = n_steps(stop, step)
    for value in values:
        with ecospy.EcosSimulation(ssp_path=str(Path(ssp).resolve()), step_size=step) as sim:
            sim.set_real("{}::{}".format(*parameter.split(".", 1)), value)
            if not sim.init(0.0, "default"):
                raise RuntimeError(f"ecos init: {ecospy.EcosLib.get_last_error()}")
            sim.step(n)
            sim.terminate()


SWEEPS = {"omsimulator": sweep_omsimulator, "ecos": sweep_ecos}


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--sweep"]:   # --sweep TOOL SSP STOP STEP PARAMETER VALUE...
        tool, ssp, stop, step, parameter, *values = argv[1:]
        SWEEPS[tool](ssp, float(stop), float(step), parameter, [float(v) for v in values])
        return 0
    tool, ssp, stop, step, out, *columns = argv
    RUNNERS[tool](ssp, float(stop), float(step), out, columns)
    return 0


if __name__ == "__main__":
    sys.exit(main())
