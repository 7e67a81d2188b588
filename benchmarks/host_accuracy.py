"""Are the shipped drives, exported as SSP, as accurate in other hosts as in ours?

``python -m benchmarks.host_accuracy [--systems bed_drive feeder_gto52] [--hosts ...] [--steps 1e-4 5e-5]``

Each shipped drive that declares an accuracy (``System.accuracy``; :func:`drives`) is exported (:func:`harness.ssp.export_ssp`) and
the archive is run, as a user of each tool would run it, in every available host at the step the SSP
declares (the OSP ``FixedStepAlgorithm`` annotation, read back with :func:`harness.ssp.load_ssp`) and at the
extra steps asked for.  Every run is judged with :func:`harness.studies.accuracy.check` against the
monolithic reference (:func:`harness.studies.reference.reference`) over the drive's accuracy span.

Hosts (each with its own algorithm; nothing here changes it):

* ``libcosim`` and ``ecos`` (``benchmarks.peers.run_ssp_libcosim`` / ``run_ssp_ecos``): fixed-step Jacobi,
  outputs sampled after ``fmi2DoStep`` (a direct feed-through output is not refreshed with the new inputs);
* ``fmpy-ssp`` (``fmpy.ssp.simulate_ssp``): the same algorithm, in Python.  It applies no parameter binding
  of the SSD by itself (only a ``parameter_set`` passed to it, names prefixed with the component): the
  runner passes the SSD's own bindings that way, as a user must (without them the FMUs run their defaults).
  Its rows carry the time at the START of the step whose outputs they hold: they are put at the step's end;
* ``omsimulator`` (OMSimulator 3.0's Python API): refreshes feed-through outputs after each step, zero-order
  hold; it ignores the OSP step annotation, so the step is set with ``setFixedStepSize``;
* ``harness:<master>``: the toolkit's own masters on the same archive (``harness:jacobi-sampled`` reproduces
  libcosim and Ecos, ``harness:jacobi`` with hold OMSimulator), to tell the algorithm from the tool.

Every host run goes in a subprocess of its own (``python -m benchmarks.host_accuracy --worker``) with a time
limit, because a diverging drive can make a host hang (libcosim) or abort the process: a run is ``complete``,
``hung`` (killed at the limit), ``died`` (the process ended without a result), ``failed`` (the tool reported
an error) or ``diverged`` (non-finite values).  Only a complete run is judged; anything else meets nothing.
"""
from __future__ import annotations

import argparse
import math
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
HOSTS = ("libcosim", "ecos", "fmpy-ssp", "omsimulator", "harness:jacobi-sampled", "harness:jacobi")


def drives() -> tuple[str, ...]:
    """Every shipped system (``systems/``) that declares an accuracy: the drives this runner judges."""
    from harness import load
    from harness.run import system_names

    return tuple(n for n in system_names() if getattr(load(n), "accuracy", None) is not None)
TIMEOUT = 600.0   # s per host run; the slowest complete run measured here (fmpy-ssp, bed_drive, 1 s at 50 us) is below


# -- which hosts exist ----------------------------------------------------------------------------------------
def unavailable(host: str) -> str | None:
    """None if ``host`` can run here, else one line saying why not."""
    from benchmarks import peers

    if host in ("libcosim", "ecos"):
        return peers.available()[host]
    if host in ("fmpy-ssp", "fmpy-fmu", "fmpy-ssp-bare"):
        try:
            import fmpy.ssp.simulation  # noqa: F401
        except Exception as e:
            return f"fmpy-ssp unavailable: fmpy.ssp.simulation does not import ({type(e).__name__}: {e})"
        return None
    if host == "omsimulator":
        try:
            import OMSimulator  # noqa: F401
        except Exception as e:
            return (f"omsimulator unavailable: its Python API does not import ({type(e).__name__}: {e}); install "
                    "it with ../shared/tools/omsimulator/install where that folder exists")
        return None
    if host.startswith("harness:"):
        from harness.master import MASTERS

        return None if host.split(":", 1)[1] in MASTERS else f"{host}: no such master"
    return f"{host}: unknown host (one of {', '.join(HOSTS)})"


# -- one run in one host (called in the worker process) ------------------------------------------------------
def _run_fmpy_ssp(ssp: Path, stop: float, step: float, columns: list[str], bindings: bool = True) -> pd.DataFrame:
    """``bindings``: pass the SSD's own bindings as the ``parameter_set`` (host ``fmpy-ssp``), else nothing
    (host ``fmpy-ssp-bare``: what a user who calls ``simulate_ssp(path)`` gets)."""
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssd

    system = read_ssd(str(ssp)).system
    bound = ParameterSet(name="bindings")
    for element in system.elements:
        for binding in element.parameterBindings:
            for values in binding.parameterValues:
                for p in values.parameters:
                    bound.parameters.append(Parameter(name=f"{element.name}.{p.name}", type=p.type, value=p.value))
    result = simulate_ssp(str(ssp), stop_time=stop, step_size=step, parameter_set=bound if bindings else None)
    names = result.dtype.names
    frame = {}
    for c in columns:
        hits = [n for n in names if n.endswith("." + c) or n == c]
        if not hits:
            raise KeyError(f"fmpy-ssp: no column for {c} among {len(names)} connectors")
        frame[c] = np.asarray(result[hits[0]], dtype=float)
    # each row holds the outputs after the step that STARTS at its time; FMPy adds the step to its time and
    # steps while that sum is below the stop time, so round-off can add a step past it (the bed 63 um off at
    # 0.3 s in 0.1 ms steps, against libcosim's 2.7 um): rows after the stop time are not the run asked for
    df = pd.DataFrame(frame, index=pd.Index(np.asarray(result["time"]) + step, name="time"))
    return df[df.index <= stop + 0.5 * step]


def _run_ecos(ssp: Path, stop: float, step: float, columns: list[str]) -> pd.DataFrame:
    """Ecos as ``benchmarks.peers.run_ssp_ecos`` drives it, but its times checked to 1e-6 of a step: Ecos adds
    the step to its time (t += h), which drifts from k*h by round-off (5e-14 s at 0.53 s in 50 us steps, which
    the peers' check to 1e-9 of a step refuses); anything coarser is a real difference in stepping."""
    from benchmarks import peers

    n = peers.n_steps(stop, step)
    ecospy = peers._ecos()
    with ecospy.EcosSimulation(ssp_path=str(Path(ssp).resolve()), step_size=step) as sim:
        if not sim.init(0.0, "default"):
            raise RuntimeError(f"ecos init: {ecospy.EcosLib.get_last_error()}")
        ids = ["{}::{}".format(*c.split(".", 1)) for c in columns]
        times, values = np.empty(n + 1), np.empty((n + 1, len(ids)))
        times[0] = sim.get_time()
        values[0] = [sim.get_real(i) for i in ids]
        for k in range(1, n + 1):
            times[k] = sim.step(1)
            values[k] = [sim.get_real(i) for i in ids]
        sim.terminate()
    off = np.abs(times - np.arange(n + 1) * step)
    if off.max() > 1e-6 * step:
        k = int(np.argmax(off))
        raise RuntimeError(f"ecos: row {k} is at t = {times[k]!r} s, expected {k * step!r} s (step {step!r} s)")
    return pd.DataFrame(values, columns=list(columns), index=pd.Index(np.arange(n + 1) * step, name="time"))


def _run_omsimulator(ssp: Path, stop: float, step: float, columns: list[str], system_name: str) -> pd.DataFrame:
    from OMSimulator import SSP

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "oms.csv"
        im = SSP(str(ssp)).instantiate()
        im.setFixedStepSize(step)
        im.setStopTime(stop)
        im.setResultFile(str(out))
        im.initialize()
        im.simulate()
        im.terminate()
        im.delete()
        raw = pd.read_csv(out, skipinitialspace=True)
    raw.columns = [c.strip().strip('"') for c in raw.columns]
    raw = raw.groupby("time").last()       # each point is written twice (before and after the input update)
    df = raw[[f"{system_name}.{c}" for c in columns]].astype(float)
    df.columns = list(columns)
    df.index.name = "time"
    return df


def _run_fmpy_fmu(fmu: Path, stop: float, step: float, columns: list[str]) -> pd.DataFrame:
    """FMPy's ``simulate_fmu`` on one FMU (a drive FMU: ``python -m harness export DRIVE X.fmu``), its outputs
    recorded at every communication step of ``step``."""
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu), stop_time=stop, step_size=step, output_interval=step, output=list(columns))
    times = np.asarray(result["time"], dtype=float)
    return pd.DataFrame({c: np.asarray(result[c], dtype=float) for c in columns},
                        index=pd.Index(times, name="time"))


def _run_harness(ssp: Path, stop: float, step: float, columns: list[str], master: str) -> pd.DataFrame:
    from harness.studies.trial import quiet_simulate
    from harness.ssp import load_ssp

    df = quiet_simulate(load_ssp(ssp), stop_time=stop, step=step, master=master, extrapolation=0,
                        output=list(columns))
    if df.attrs.get("complete") is False:
        raise RuntimeError(str(df.attrs.get("error") or "incomplete run"))
    return df[list(columns)]


def run_host(host: str, ssp: Path, stop: float, step: float, columns: list[str], system_name: str) -> pd.DataFrame:
    """One run of the archive in ``host``, IN THIS PROCESS (see :func:`run_guarded` for the safe way); for
    ``fmpy-fmu`` the "archive" is one FMU (``fmpy.simulate_fmu``)."""
    from benchmarks import peers

    if host == "libcosim":
        return peers.run_ssp_libcosim(ssp, stop, step, columns)
    if host == "ecos":
        return _run_ecos(ssp, stop, step, columns)
    if host == "fmpy-ssp":
        return _run_fmpy_ssp(ssp, stop, step, columns)
    if host == "omsimulator":
        return _run_omsimulator(ssp, stop, step, columns, system_name)
    if host == "fmpy-fmu":
        return _run_fmpy_fmu(ssp, stop, step, columns)
    if host == "fmpy-ssp-bare":
        return _run_fmpy_ssp(ssp, stop, step, columns, bindings=False)
    if host.startswith("harness:"):
        return _run_harness(ssp, stop, step, columns, host.split(":", 1)[1])
    raise ValueError(f"{host}: unknown host (one of {', '.join(HOSTS)})")


@dataclass
class HostRun:
    """``status``: complete, hung, died, failed or diverged; ``result`` only when complete.  ``wall_time``: the
    whole guarded run (a fresh process: its start-up and imports too); ``run_time``: the tool's own run inside
    it (loading the archive and stepping: what a user of the tool waits for), NaN unless complete."""
    host: str
    step: float
    status: str
    wall_time: float
    result: pd.DataFrame | None = None
    error: str = ""
    run_time: float = math.nan


def run_guarded(host: str, ssp: Path, stop: float, step: float, columns: list[str], system_name: str,
                timeout: float = TIMEOUT) -> HostRun:
    """:func:`run_host` in a fresh Python process, killed after ``timeout`` s; never raises for the host's sake."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.pkl"
        cmd = [sys.executable, "-m", "benchmarks.host_accuracy", "--worker", host, str(ssp), repr(stop), repr(step),
               system_name, str(out), *columns]
        t0 = time.perf_counter()
        try:
            r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout,
                               env={**os.environ, "PRESSDRIVE_NORMAL_EXIT": "1"})
        except subprocess.TimeoutExpired:
            return HostRun(host, step, "hung", time.perf_counter() - t0,
                           error=f"no result after {timeout:g} s: killed")
        wall = time.perf_counter() - t0
        if not out.exists():
            tail = " ".join((r.stderr or r.stdout or "").split())[-300:]
            return HostRun(host, step, "died", wall, error=f"exit code {r.returncode}: {tail}")
        with open(out, "rb") as f:
            kind, payload = pickle.load(f)
    if kind == "error":
        return HostRun(host, step, "failed", wall, error=payload)
    df, seconds = payload
    if not np.isfinite(df.to_numpy(dtype=float)).all():
        bad = df.index[~np.isfinite(df.to_numpy(dtype=float)).all(axis=1)][0]
        return HostRun(host, step, "diverged", wall, error=f"non-finite values from t = {bad:g} s")
    return HostRun(host, step, "complete", wall, result=df, run_time=seconds)


def _worker(argv: list[str]) -> int:
    host, ssp, stop, step, system_name, out, *columns = argv
    try:
        t0 = time.perf_counter()
        df = run_host(host, Path(ssp), float(stop), float(step), columns, system_name)
        payload = ("ok", (pd.DataFrame(df), time.perf_counter() - t0))
    except Exception as e:  # the tool's error, as one line
        payload = ("error", " ".join(f"{type(e).__name__}: {e}".split())[:500])
    with open(out, "wb") as f:
        pickle.dump(payload, f)
    sys.stdout.flush()
    sys.stderr.flush()
    # leave without tearing down the interpreter: pythonfmu instances a host still references have aborted
    # the interpreter's exit (tests/conftest.py)
    os._exit(0)


# -- what to record and how to judge it ----------------------------------------------------------------------
def columns_of(system) -> list[str]:
    """The 'Instance.variable' columns the drive's accuracy requirements read (``r["..."]`` in a quantity or
    its ``where``)."""
    from harness.studies.accuracy import accuracy_spec

    from harness.reporting import qoi

    found: list[str] = []
    for req in accuracy_spec(system).requirements:
        for text in (req.quantity, req.where or ""):
            for name in (qoi.columns(text) if text else []):
                if name not in found:
                    found.append(name)
    return found


def declared_step(ssp: Path) -> float:
    """The step the exported SSP declares to other hosts: its OSP ``FixedStepAlgorithm`` annotation, which libcosim
    takes (the harness takes its own from the ``pd:Experiment`` annotation: :func:`harness.ssp.host_step`)."""
    import zipfile
    from xml.etree import ElementTree as ET

    from harness.ssp import NS

    with zipfile.ZipFile(ssp) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    for info in root.iter(f"{{{NS['osp']}}}FixedStepAlgorithm"):
        return float(info.get("baseStepSize"))
    raise ValueError(f"{ssp}: declares no step (no DefaultExperiment with an OSP FixedStepAlgorithm)")


@dataclass
class Verdict:
    """A host run judged: ``checks`` from :func:`harness.studies.accuracy.check` (empty unless complete)."""
    system: str
    run: HostRun
    checks: list = field(default_factory=list)

    @property
    def meets(self) -> bool:
        return self.run.status == "complete" and bool(self.checks) and all(c.ok for c in self.checks)


def judge(system, run: HostRun, reference: pd.DataFrame) -> Verdict:
    from harness.studies.accuracy import check

    if run.status != "complete":
        return Verdict(system.name, run)
    return Verdict(system.name, run, check(system, run.result, reference))


def measure(system_name: str, hosts, extra_steps=(), out_dir: Path | None = None, timeout: float = TIMEOUT,
            progress=None) -> list[Verdict]:
    """Export ``system_name``, run it in each host at its declared step and at ``extra_steps``, judge each."""
    from harness import load
    from harness.ssp import export_ssp
    from harness.studies.accuracy import accuracy_spec
    from harness.studies.reference import reference

    system = load(system_name)
    spec = accuracy_spec(system)
    folder = Path(out_dir or tempfile.mkdtemp(prefix="host_accuracy_"))
    ssp = export_ssp(system, folder / f"{system_name}.ssp")
    steps = [declared_step(ssp)] + [h for h in extra_steps if not math.isclose(h, declared_step(ssp))]
    ref = reference(system, stop_time=spec.stop_time, step=spec.reference_step)
    columns = columns_of(system)
    verdicts = []
    for host in hosts:
        reason = unavailable(host)
        if reason:
            if progress:
                progress(f"{system_name} {host}: skipped: {reason}")
            continue
        for h in steps:
            v = judge(system, run_guarded(host, ssp, spec.stop_time, h, columns, system_name, timeout), ref)
            verdicts.append(v)
            if progress:
                progress(describe(v))
    return verdicts


def describe(v: Verdict) -> str:
    r = v.run
    head = f"{v.system} {r.host} step {r.step:g} s: {r.status} ({r.wall_time:.1f} s)"
    if r.status != "complete":
        return f"{head}: {r.error}"
    return f"{head}: " + ("meets" if v.meets else "misses") + "; " + "; ".join(
        f"{c.name} {c.error:.3g}/{c.tolerance:g} {c.unit}" + (f" ({c.note})" if c.note else "") for c in v.checks)


def table(verdicts: list[Verdict]) -> pd.DataFrame:
    """One row per run: system, host, step, status, wall time, every requirement's error and tolerance."""
    rows = []
    for v in verdicts:
        row = dict(system=v.system, host=v.run.host, step=v.run.step, status=v.run.status,
                   wall_time=round(v.run.wall_time, 1), meets=v.meets, error=v.run.error)
        for c in v.checks:
            row[c.name] = c.error
            row[f"{c.name} tolerance"] = c.tolerance
            if c.note:
                row["error"] = (row["error"] + "; " if row["error"] else "") + f"{c.name}: {c.note}"
        rows.append(row)
    return pd.DataFrame(rows)


def markdown(verdicts: list[Verdict]) -> str:
    """The table for docs/howto/export.md: per drive, host and step, each requirement's error / tolerance."""
    lines = ["| drive | host | step | run | " + "requirement: error / tolerance | meets |", "|---|---|---|---|---|---|"]
    for v in verdicts:
        r = v.run
        if r.status != "complete":
            cells = r.error
        else:
            cells = "; ".join(f"{c.name}: " + (f"{c.error:.3g} / {c.tolerance:g} {c.unit}" if not c.note
                                               else f"not judged ({c.note})") for c in v.checks)
        lines.append(f"| {v.system} | {r.host} | {r.step * 1e3:g} ms | {r.status} | {cells} | "
                     f"{'yes' if v.meets else 'no'} |")
    return "\n".join(lines)


# -- the whole drive as one FMU (python -m harness export DRIVE X.fmu) against the drive's SSP ----------------------
DRIVE_FMU_HOSTS = ("fmpy", "libcosim", "ecos", "omsimulator")
IMPORTER_STEP = 1e-3    # s: the host's own step around a drive FMU (the drive's master sub-steps inside)


def wrap_fmu(fmu: Path, out: Path, stop: float) -> Path:
    """One FMU as the one component ``drive`` of an SSP (how libcosim, Ecos and OMSimulator's API take an FMU
    here), its OSP step the importer's."""
    from harness.model import Experiment, Instance, System
    from harness.ssp import export_ssp

    return export_ssp(System(f"{Path(fmu).stem}_fmu", [Instance("drive", Path(fmu))],
                             experiment=Experiment(stop_time=stop, step=IMPORTER_STEP)), out)


def drive_fmu_runs(system_name: str, hosts=DRIVE_FMU_HOSTS, out_dir: Path | None = None,
                   timeout: float = TIMEOUT, progress=None, ssp: bool = True) -> list[tuple[str, Verdict, Verdict | None]]:
    """Per host: (host, the drive FMU at IMPORTER_STEP, the drive's SSP at its declared host step), each judged by
    the drive's accuracy against the monolithic reference; ``run_time`` is the tool's own run.  The SSP in FMPy
    runs through ``simulate_ssp`` (host ``fmpy-ssp``), the drive FMU through ``simulate_fmu``.  ``ssp=False``: the
    drive FMU alone (the SSP's verdict None; the SSPs in the hosts are the main table's)."""
    from harness import export_fmu, load
    from harness.ssp import export_ssp
    from harness.studies.accuracy import accuracy_spec
    from harness.studies.reference import reference

    system = load(system_name)
    spec = accuracy_spec(system)
    out = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="drive_fmu_"))
    fmu = export_fmu(system, out / f"{system_name}.fmu")
    wrapped = wrap_fmu(fmu, out / f"{system_name}_fmu.ssp", spec.stop_time)
    ssp_file = export_ssp(system, out / f"{system_name}.ssp") if ssp else None
    ref = reference(system, stop_time=spec.stop_time, step=spec.reference_step)
    columns = columns_of(system)
    # an event counter's instant on the drive's own step, which the drive FMU offers beside it (qoi.rise_times)
    fmu_columns = columns + [f"{c}.rise_time" for c in columns if c.endswith("_count")]
    rows = []
    for host in hosts:
        if host == "fmpy":
            run = run_guarded("fmpy-fmu", fmu, spec.stop_time, IMPORTER_STEP, fmu_columns, system_name, timeout)
        else:
            run = run_guarded(host, wrapped, spec.stop_time, IMPORTER_STEP, [f"drive.{c}" for c in fmu_columns],
                              f"{system_name}_fmu", timeout)
            if run.result is not None:
                run.result = run.result.rename(columns=lambda c: c.removeprefix("drive."))
        as_fmu = judge(system, run, ref)
        ssp_host = "fmpy-ssp" if host == "fmpy" else host
        as_ssp = judge(system, run_guarded(ssp_host, ssp_file, spec.stop_time, declared_step(ssp_file), columns,
                                           system_name, timeout), ref) if ssp else None
        rows.append((host, as_fmu, as_ssp))
        if progress:
            progress(f"{describe(as_fmu)} | SSP: {describe(as_ssp) if as_ssp is not None else 'not run'}")
    return rows


def drive_fmu_markdown(rows) -> str:
    lines = ["| drive | host | drive FMU (1 ms importer step) | its run | drive SSP (declared step) | its run |",
             "|---|---|---|---|---|---|"]
    for host, f, s in rows:
        def cell(v):
            if v.run.status != "complete":
                return v.run.status + ": " + v.run.error[:80], ""
            return ("meets" if v.meets else "misses") + "; " + "; ".join(f"{c.error:.2g} {c.unit}" for c in v.checks), \
                f"{v.run.run_time:.1f} s"
        a, ta = cell(f)
        b, tb = cell(s) if s is not None else ("not run", "")
        step = f" ({s.run.step * 1e3:g} ms)" if s is not None else ""
        lines.append(f"| {f.system} | {host} | {a} | {ta} | {b}{step} | {tb} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--worker"]:
        return _worker(argv[1:])
    p = argparse.ArgumentParser(prog="python -m benchmarks.host_accuracy", description=__doc__.splitlines()[0])
    p.add_argument("--systems", nargs="+", default=None, help="default: every drive with a declared accuracy")
    p.add_argument("--hosts", nargs="+", default=list(HOSTS))
    p.add_argument("--steps", nargs="*", type=float, default=[], help="steps [s] besides the SSP's declared one")
    p.add_argument("--timeout", type=float, default=TIMEOUT, help="s per host run before it counts as hung")
    p.add_argument("--out", default="results", help="folder of host_accuracy.csv and the exported SSPs")
    p.add_argument("--drive-fmu", action="store_true",
                   help="the drives exported as one FMU (python -m harness export DRIVE X.fmu) in FMPy, libcosim, "
                        "Ecos and OMSimulator at a 1 ms importer step, against their SSPs in the same hosts")
    p.add_argument("--no-ssp", action="store_true", help="with --drive-fmu: the drive FMUs alone, not their SSPs")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.drive_fmu:
        rows = []
        for name in args.systems or ["bed_drive"]:
            rows += drive_fmu_runs(name, out_dir=out, timeout=args.timeout, ssp=not args.no_ssp,
                                   progress=lambda s: print(s, file=sys.stderr, flush=True))
        print(drive_fmu_markdown(rows))
        return 0 if all(f.meets for _, f, _ in rows) else 1
    verdicts = []
    for name in args.systems or drives():
        verdicts += measure(name, args.hosts, args.steps, out, args.timeout,
                            progress=lambda s: print(s, file=sys.stderr, flush=True))
    table(verdicts).to_csv(out / "host_accuracy.csv", index=False)
    print(markdown(verdicts))
    return 0 if all(v.meets for v in verdicts) else 1


if __name__ == "__main__":
    sys.exit(main())
