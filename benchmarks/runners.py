"""One timed run of one case in one tool.  Every runner returns ``{"seconds", "steps", "fmus", "final"}``:
``seconds`` covers initialisation and the stepping loop only (not loading/instantiating, which differ per
tool and do not scale with the run), ``final`` maps each check column to its value at the stop time.

Every tool runs the SAME exported SSP (the FMU files of its ``resources/``), at the same step, from t = 0,
and records only the check columns (libcosim: a last-value observer; Ecos: read after the run; the
harness: its recorder, every step, so the harness pays for recording and the peers do not).
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from harness.master.clock import NS

TOOLS = ("jacobi", "jacobi-sampled", "jacobi-sampled-fmi", "gauss-seidel", "iterative", "libcosim", "ecos",
         "cofmupy", "fmpy", "ctypes")
# the harness's masters; "-fmi": the same master calling every FMU through its C library (the plain FMI path)
# instead of the default in-process path for the toolkit's pythonfmu FMUs (harness.fmi.inprocess)
HARNESS_TOOLS = ("jacobi", "jacobi-sampled", "jacobi-sampled-fmi", "gauss-seidel", "iterative")
# tools that compute exactly what the harness computes with master "jacobi-sampled" (cofmupy: its Jacobi
# within one strongly connected group, the only systems benchmarks.cofmupy lets it run)
SAME_ALGORITHM = ("jacobi-sampled", "jacobi-sampled-fmi", "libcosim", "ecos", "cofmupy", "fmpy", "ctypes")


def _ssd(folder: Path) -> str:
    return str(Path(folder) / "SystemStructure.ssd")


def _split(column: str, instances) -> tuple[str, str]:
    for inst in sorted(instances, key=len, reverse=True):
        if column.startswith(inst + "."):
            return inst, column[len(inst) + 1:]
    raise ValueError(f"column {column!r} names no instance of {sorted(instances)}")


def run_harness(folder: Path, tool: str, step: float, n: int, columns: list[str], detector: bool = True) -> dict:
    """``detector``: False runs without the divergence detector (a case whose coupling is unstable)."""
    from harness import RunOptions, load, simulate

    system = load(_ssd(folder))
    master = tool.removesuffix("-fmi")
    options = RunOptions(in_process=False if tool.endswith("-fmi") else None)
    if not detector:
        options = dataclasses.replace(options, divergence=None)
    df = simulate(system, stop_time=n * step, step=step, master=master, extrapolation=0, output=columns,
                  options=options)
    if not df.attrs["complete"]:
        raise RuntimeError(f"harness {tool}: {df.attrs['error']}")
    return {"seconds": df.attrs["wall_time"], "steps": int(df.attrs["steps"]), "fmus": len(system.instances),
            "final": {c: float(df[c].iloc[-1]) for c in columns}}


def run_libcosim(folder: Path, step: float, n: int, columns: list[str]) -> dict:
    from libcosimpy import CosimEnums, CosimExecution, CosimLogging, CosimObserver

    from benchmarks.peers import step_nanoseconds

    CosimLogging.log_output_level(CosimLogging.CosimLogLevel.WARNING)
    step_ns = step_nanoseconds(step)
    execution = CosimExecution.CosimExecution.from_ssp_file(str(folder), step_ns)
    observer = CosimObserver.CosimObserver.create_last_value()
    execution.add_observer(observer)
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    refs = {i: {v.name.decode(): v.reference for v in execution.slave_variables(i)
                if v.type == CosimEnums.CosimVariableType.REAL.value} for i in slaves.values()}
    t0 = time.perf_counter()
    ok = execution.step(n)
    seconds = time.perf_counter() - t0
    status = execution.status()
    if not ok or status.error_code != 0 or status.current_time != n * step_ns:
        raise RuntimeError(f"libcosim: step failed (error code {status.error_code}, t = {status.current_time} ns)")
    final = {}
    for c in columns:
        inst, var = _split(c, slaves)
        final[c] = float(observer.last_real_values(slaves[inst], [refs[slaves[inst]][var]])[0])
    return {"seconds": seconds, "steps": n, "fmus": len(slaves), "final": final}


def run_ecos(folder: Path, step: float, n: int, columns: list[str], parameter_set: str | None) -> dict:
    import ecospy

    ecospy.EcosLib.set_log_level("warn")
    sim = ecospy.EcosSimulation(ssp_path=str(folder), step_size=step)
    with sim:
        t0 = time.perf_counter()
        if not sim.init(0.0, parameter_set):
            raise RuntimeError(f"ecos: init failed: {ecospy.EcosLib.get_last_error()}")
        t_end = sim.step(n)
        seconds = time.perf_counter() - t0
        if abs(t_end - n * step) > 1e-9 * n * step:
            raise RuntimeError(f"ecos: ended at t = {t_end!r} s, expected {n * step!r} s")
        final = {}
        for c in columns:
            inst, _, var = c.partition(".")
            final[c] = float(sim.get_real(f"{inst}::{var}"))
        sim.terminate()
    return {"seconds": seconds, "steps": n, "fmus": len(_instances(folder)), "final": final}


def _instances(folder: Path) -> list[str]:
    from harness import load

    return [i.name for i in load(_ssd(folder)).instances]


def _initialised_master(folder: Path, step: float, n: int):
    """The harness's jacobi-sampled master, built and initialised exactly as ``simulate`` does (so the floors
    start from the same consistent point); the floors then step it with their own loops."""
    from harness import load
    from harness.master.extrapolation import Polynomial
    from harness.fmi.fmu import FMU
    from harness.master import JacobiSampled
    from harness.model import model_description, resolve_fmu
    from harness.run import split_parameters

    system = load(_ssd(folder))
    params = split_parameters(system, None)
    paths = {inst.name: resolve_fmu(inst.fmu) for inst in system.instances}
    mds = {name: model_description(p) for name, p in paths.items()}
    connections = system.all_connections(mds)
    fmus = {inst.name: FMU(paths[inst.name], inst.name) for inst in system.instances}
    m = JacobiSampled(fmus, connections, system.bonds, Polynomial(0))
    step_ns = int(round(step * NS))
    return m, step_ns, params


# the time doubles each peer hands fmi2DoStep (benchmarks.peers.communication_points)
CONVENTIONS = {"libcosim": "libcosim", "ecos": "accumulate", "cofmupy": "accumulate"}


def run_floor(folder: Path, step: float, n: int, columns: list[str], kind: str, convention: str = "harness") -> dict:
    """``kind`` "fmpy": the bare fmpy loop (FMU2Slave.setReal / doStep / getReal, fmpy's status checks);
    "ctypes": value references and buffers prepared once, the FMI functions called directly, status
    ignored.  Both take the steps of jacobi-sampled, with the harness's time doubles t_k = k*step_ns/1e9
    unless ``convention`` names another tool's (:func:`benchmarks.peers.communication_points`: the fmpy loop
    then computes what that tool must compute, bit for bit)."""
    from benchmarks.peers import communication_points

    m, step_ns, params = _initialised_master(folder, step, n)
    times, steps = communication_points(n, step_ns / NS, convention)
    times, steps = times[:-1].tolist(), steps.tolist()
    t0 = time.perf_counter()
    m.initialize(0, n * step_ns, None, params)
    y = m.y
    insts = m.insts
    if kind == "fmpy":
        prep = []
        for it in insts:
            s = it.fmu._slave
            s.component = it.fmu.c
            prep.append((s, list(it.inp.vr)[: it.inp.n], it.src, it.factor, it.offset, list(it.out.vr)[: it.out.n],
                         it.output_slice))
        for t, h in zip(times, steps):
            for s, ivr, src, factor, offset, _ovr, _sl in prep:
                if ivr:
                    s.setReal(ivr, list(factor * y[src] + offset))
            for s, *_ in prep:
                s.doStep(t, h)
            for s, _ivr, _src, _fac, _off, ovr, sl in prep:
                y[sl] = s.getReal(ovr)
    else:
        prep = []
        for it in insts:
            dll = it.fmu._slave.dll   # the library's own ctypes functions (argument types set by FMPy)
            prep.append((dll.fmi2SetReal, dll.fmi2DoStep, dll.fmi2GetReal, it.fmu.c, it.inp, it.src, it.factor,
                         it.offset, it.out, it.output_slice))
        for t, h in zip(times, steps):
            for set_real, _ds, _gr, c, inp, src, factor, offset, _out, _sl in prep:
                if inp.n:
                    np.multiply(factor, y[src], out=inp.values)
                    inp.values += offset
                    set_real(c, inp.vr, inp.n, inp.buf)
            for _sr, do_step, _gr, c, *_ in prep:
                do_step(c, t, h, 1)
            for _sr, _ds, get_real, c, _inp, _src, _fac, _off, out, sl in prep:
                get_real(c, out.vr, out.n, out.buf)
                y[sl] = out.values
    seconds = time.perf_counter() - t0
    final = {c: float(y[m.signal_index[c]]) for c in columns}
    m.terminate()
    m.free()
    return {"seconds": seconds, "steps": n, "fmus": len(insts), "final": final}


def run_realtime(system_name: str, run: dict, quick: bool, repeats: int = 3, stand_in: str | None = None) -> dict:
    """A system in the harness as ``run`` says (``stop_time``, ``step``, ``master``, ``parameters``: a scene's
    chosen model, or the default experiment), ``repeats`` times in this process (once, over a 100th of it, with
    ``quick``): ``seconds`` is the least wall time of initialisation and stepping (as timeit takes the least:
    the others measure the machine's noise too), ``final`` holds ``stop_time`` (the real-time factor is
    stop_time / seconds).  ``stand_in``: a floor run instead (:mod:`benchmarks.floors`): the same run with the
    FMUs' physics, or all their calls, made free after initialisation."""
    from harness import load, simulate

    from benchmarks.floors import stand_ins

    system = load(system_name)
    stop = run["stop_time"] / 100 if quick else run["stop_time"]
    seconds = []
    for _ in range(1 if quick else repeats):
        with stand_ins(stand_in) as patched:
            df = simulate(system, stop_time=stop, step=run["step"], master=run["master"],
                          extrapolation=run.get("extrapolation"), start_values=run["parameters"],
                          output=check_columns_of(system)[:1])
        if not df.attrs["complete"]:
            raise RuntimeError(f"{system_name}: {df.attrs['error']}")
        if stand_in and len(patched) != len(system.instances):
            missing = sorted({i.name for i in system.instances} - set(patched))
            raise RuntimeError(f"{system_name}: no stand-in for {', '.join(missing)} (not on the in-process path)")
        seconds.append(df.attrs["wall_time"])
    return {"seconds": min(seconds), "repeats": len(seconds), "steps": int(df.attrs["steps"]),
            "fmus": len(system.instances), "final": {"stop_time": stop}}


def run_sweep_overhead(system_name: str, quick: bool, points: int = 7) -> dict:
    """Wall time of :func:`harness.studies.sweep.run_point` for one-step runs of ``system_name`` (so nearly all
    of it is what a point costs besides stepping): the first point of this process (cold: imports, FMU
    extraction) and the median of ``points`` further points, each with another parameter value."""
    import statistics

    from harness import load
    from harness.studies.sweep import parse_spec, run_point

    step = load(system_name).experiment.step
    spec = parse_spec({"grid": {"feeder.clearance": [1e-5]}, "stop_time": step}, f"<{system_name} overhead>")
    n = 2 if quick else points
    rows = [run_point(system_name, spec, {"feeder.clearance": 1e-5 + 1e-6 * k}) for k in range(n + 1)]
    bad = [r["error"] for r in rows if r["error"]]
    if bad:
        raise RuntimeError(f"{system_name} sweep point: {bad[0]}")
    warm = [r["wall_time"] for r in rows[1:]]
    return {"seconds": sum(warm), "overhead_s": statistics.median(warm), "first_point_s": rows[0]["wall_time"],
            "points": n}


def check_columns_of(system):
    from benchmarks.cases import check_columns

    return check_columns(system)


def run(tool: str, folder: Path, step: float, n: int, columns: list[str], parameter_set: str | None,
        detector: bool = True) -> dict:
    if tool in HARNESS_TOOLS:
        return run_harness(folder, tool, step, n, columns, detector)
    if tool == "libcosim":
        return run_libcosim(folder, step, n, columns)
    if tool == "ecos":
        return run_ecos(folder, step, n, columns, parameter_set)
    if tool in ("fmpy", "ctypes"):
        return run_floor(folder, step, n, columns, tool)
    if tool.startswith("reference-"):  # the fmpy loop with another tool's time doubles (result check only)
        return run_floor(folder, step, n, columns, "fmpy", tool.removeprefix("reference-"))
    if tool == "cofmupy":
        raise ValueError("cofmupy runs in its own virtual environment: benchmarks.cofmupy.run_config, not here")
    raise ValueError(f"tool = {tool!r} is not one of {', '.join(TOOLS)}")
