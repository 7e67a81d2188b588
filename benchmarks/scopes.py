"""Speed at equal scope: the harness and every peer measured the same way, side by side, in one run
(``python -m benchmarks.scopes``).

For each drive (bed_drive, feeder_gto52) every tool runs the SAME exported SSP at its declared accuracy:

* which run: the harness's cheapest method and step that meets the drive's declared accuracy
  (:func:`harness.studies.accuracy.search` over :data:`benchmarks.cases.METHODS`), each peer's coarsest step
  of :data:`PEER_STEPS` whose run (its own algorithm, :func:`benchmarks.host_accuracy.run_guarded`) meets it,
  judged by the same :func:`harness.studies.accuracy.check` against the monolithic reference;
* scope "stepping alone": a fresh process loads the SSP and initialises (not timed), then the stepping from the
  initialised state to the stop time is timed, no result file for anyone (the peers record nothing; the
  harness's recorder keeps the judged columns in memory, its divergence detector on).  libcosim initialises
  inside its first step: its first step is taken before the clock starts.  FMPy's ``simulate_ssp`` has no
  call that steps an initialised system: no stepping figure;
* scope "whole process": what a user waits for, timed from outside: a fresh process starts, loads the SSP,
  initialises, runs, writes the judged columns over time to a CSV file and exits (the harness:
  ``python -m harness run SSP ... --output ... --out FILE``; the peers: :mod:`benchmarks.whole`).

* scope "sweep" (``--sweep POINTS``): the same points of one parameter (:data:`SWEEP_PARAMETERS`), each
  initialised and run to the stop time, one fresh process per tool pinned to one CPU, timed from start to exit:
  the harness's ``sweep`` command with ``--workers 0`` (its points in its own process: the FMUs' code is
  imported once, each point opens its instances again) against a peer's loop that loads the SSP again for
  every point (:mod:`benchmarks.whole`, OMSimulator and Ecos: the peers whose Python API sets a parameter).

Every tool is run ``repeats`` times in turn (tool A, B, C, A, B, C, ...), unpinned and pinned to one CPU
(``taskset -c 0``); each table gives min and median of the wall time, the ratio of the mins (peer / harness)
and, for whole processes, the least CPU time (user + system, the kernel's accounting: on a shared machine the
wall time also holds the time spent waiting for a CPU).  The goals (stepping >= 5x the fastest peer, whole
process >= 2x, sweep throughput >= 3x) are lines with their evidence; the harness's whole process is also
measured part by part in one process (interpreter start, imports, loading the SSP, opening the FMUs,
initialisation, stepping, writing) and printed beside it: what bounds it.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DRIVES = ("bed_drive", "feeder_gto52")
PEERS = ("omsimulator", "libcosim", "ecos", "fmpy-ssp")
PEER_STEPS = (2e-4, 1e-4, 5e-5)   # coarsest first: a peer's run is its coarsest step that meets the accuracy
MODES = ("unpinned", "pinned")
SCOPES = {"stepping": "stepping alone: from initialised to the stop time, no result file (peers record nothing, "
                      "the harness keeps the judged columns in memory)",
          "whole": "whole process: start a fresh process, load the SSP, initialise, run, write the judged columns "
                   "to a CSV file, exit"}
GOALS = {"stepping": 5.0, "whole": 2.0, "sweep": 3.0}
SWEEP_SCOPE = ("sweep of the same points: one fresh process per tool pinned to one CPU, start to exit; each point "
               "initialised and run to the stop time, no time series written (the harness: its sweep command, "
               "warm FMU code, new instances per point; a peer: the SSP loaded again per point)")


@dataclass(frozen=True)
class Config:
    """One tool's run of a drive: ``master``/``order`` for the harness only; ``note``: how it was chosen."""
    tool: str
    step: float
    master: str = ""
    order: int = 0
    note: str = ""

    def label(self) -> str:
        how = f"{self.master} order {self.order}, " if self.tool == "harness" else ""
        return f"{how}{self.step * 1e3:g} ms"


# -- choosing each tool's run --------------------------------------------------------------------------------
def choose(name: str, peers, quick: bool, timeout: float, log=print) -> dict:
    """{tool: Config or the reason it has none}.  ``quick``: no accuracy judged, every tool at the drive's
    default step (a smoke test of the machinery; its numbers compare nothing)."""
    from harness import load

    from benchmarks import host_accuracy

    system = load(name)
    if quick:
        exp = system.experiment
        out = {"harness": Config("harness", exp.step, exp.master, exp.extrapolation, "quick: not judged")}
        for p in peers:
            why = host_accuracy.unavailable(p)
            out[p] = why or Config(p, exp.step, note="quick: not judged")
        return out
    from harness.studies import accuracy

    from benchmarks.cases import METHODS, STEPS

    table = accuracy.search(system, METHODS, STEPS[name], progress=lambda s: log(f"{name}: {s}"))
    best = accuracy.cheapest(table)
    out = {"harness": "no method and step of the ladder meets the declared accuracy" if best is None else
           Config("harness", float(best["step"]), str(best["master"]), int(best["order"]),
                  f"cheapest that meets the declared accuracy ({int(best['fmu_steps'])} FMU steps)")}
    ready = [p for p in peers if host_accuracy.unavailable(p) is None]
    out.update({p: host_accuracy.unavailable(p) for p in peers if p not in ready})
    if not ready:
        return out
    from harness.ssp import export_ssp
    from harness.studies.reference import reference

    spec = accuracy.accuracy_spec(system)
    folder = Path(tempfile.mkdtemp(prefix="scopes_choose_"))
    ssp = export_ssp(system, folder / f"{name}.ssp")
    ref = reference(system, stop_time=spec.stop_time, step=spec.reference_step)
    columns = host_accuracy.columns_of(system)
    for p in ready:
        tried = []
        for h in PEER_STEPS:
            v = host_accuracy.judge(system, host_accuracy.run_guarded(p, ssp, spec.stop_time, h, columns, name,
                                                                      timeout), ref)
            log(host_accuracy.describe(v))
            if v.meets:
                out[p] = Config(p, h, note="coarsest step tried that meets the declared accuracy")
                break
            tried.append(f"{h * 1e3:g} ms {'misses' if v.run.status == 'complete' else v.run.status}")
        else:
            out[p] = "meets the declared accuracy at no step tried (" + ", ".join(tried) + ")"
    shutil.rmtree(folder, ignore_errors=True)
    return out


# -- the stepping scope: one fresh process per run ----------------------------------------------------------
def stepping_worker(spec: dict) -> dict:
    """In THIS process: load the SSP, initialise, time the stepping alone.  ``{"setup_s", "stepping_s"}``."""
    tool, ssp, stop, step = spec["tool"], spec["ssp"], spec["stop"], spec["step"]
    n = round(stop / step)
    t0 = time.perf_counter()
    if tool == "harness":
        from harness import simulate
        from harness.ssp import load_ssp

        df = simulate(load_ssp(ssp), stop_time=stop, step=step, master=spec["master"],
                      extrapolation=spec["order"], output=spec["columns"])
        if not df.attrs["complete"]:
            raise RuntimeError(df.attrs["error"])
        stepping = df.attrs["wall_time"] - df.attrs["init_time"]
        return {"setup_s": time.perf_counter() - t0 - stepping, "stepping_s": stepping}
    if tool == "omsimulator":
        from OMSimulator import SSP

        im = SSP(ssp).instantiate()
        im.setFixedStepSize(step)
        im.setStopTime(stop)
        im.setResultFile("")
        im.initialize()
        t1 = time.perf_counter()
        im.simulate()
        t2 = time.perf_counter()
        im.terminate()
        im.delete()
    elif tool == "libcosim":
        from libcosimpy import CosimExecution, CosimLogging

        CosimLogging.log_output_level(CosimLogging.CosimLogLevel.WARNING)
        execution = CosimExecution.CosimExecution.from_ssp_file(ssp, round(step * 1e9))
        if not execution.step(1):   # libcosim initialises inside its first step
            raise RuntimeError("libcosim: first step failed")
        t1 = time.perf_counter()
        ok = execution.step(n - 1)
        t2 = time.perf_counter()
        if not ok or execution.status().error_code != 0:
            raise RuntimeError(f"libcosim: stepping failed (error code {execution.status().error_code})")
    elif tool == "ecos":
        import ecospy

        ecospy.EcosLib.set_log_level("warn")
        with ecospy.EcosSimulation(ssp_path=ssp, step_size=step) as sim:
            if not sim.init(0.0, "default"):
                raise RuntimeError(f"ecos init: {ecospy.EcosLib.get_last_error()}")
            t1 = time.perf_counter()
            t_end = sim.step(n)
            t2 = time.perf_counter()
            sim.terminate()
        if abs(t_end - stop) > 1e-6 * step:
            raise RuntimeError(f"ecos ended at t = {t_end!r} s, not {stop!r} s")
    elif tool == "fmpy-ssp":
        raise RuntimeError("n/a: fmpy.ssp's simulate_ssp has no call that steps an initialised system")
    else:
        raise ValueError(f"unknown tool {tool!r}")
    return {"setup_s": t1 - t0, "stepping_s": t2 - t1}


def whole_command(cfg: Config, ssp: Path, stop: float, columns: list[str], out: Path) -> list[str]:
    """The command a user of the tool runs (the harness: its command line)."""
    if cfg.tool == "harness":
        return [sys.executable, "-m", "harness", "run", str(ssp), "--stop-time", repr(stop), "--step", repr(cfg.step),
                "--master", cfg.master, "--extrapolation", str(cfg.order),
                *[a for c in columns for a in ("--output", c)], "--out", str(out)]
    return [sys.executable, "-m", "benchmarks.whole", cfg.tool, str(ssp), repr(stop), repr(cfg.step), str(out),
            *columns]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def _pin(mode: str) -> list[str]:
    return ["taskset", "-c", "0"] if mode == "pinned" and shutil.which("taskset") else []


def time_stepping(cfg: Config, ssp: Path, stop: float, columns: list[str], mode: str, timeout: float) -> dict:
    spec = dict(tool=cfg.tool, ssp=str(ssp), stop=stop, step=cfg.step, master=cfg.master, order=cfg.order,
                columns=columns)
    cmd = [*_pin(mode), sys.executable, "-m", "benchmarks.scopes", "--stepping-worker", json.dumps(spec)]
    try:
        r = subprocess.run(cmd, cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"no result after {timeout:g} s"}
    for line in reversed(r.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    return {"error": f"exit code {r.returncode}: " + " ".join((r.stderr or "").split())[-200:]}


def time_whole(cfg: Config, ssp: Path, stop: float, columns: list[str], mode: str, timeout: float,
               work: Path) -> dict:
    out = work / f"{cfg.tool}.csv"
    out.unlink(missing_ok=True)
    cmd = [*_pin(mode), *whole_command(cfg, ssp, stop, columns, out)]
    return _timed(cmd, work, timeout, out)


def _timed(cmd: list[str], cwd: Path, timeout: float, out: Path | None = None) -> dict:
    """Wall seconds of a fresh process from its start to its exit and its CPU seconds (user + system of the
    processes it waited for, the kernel's accounting); ``out``: the file it must have written."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        r = subprocess.run(cmd, cwd=cwd, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"no result after {timeout:g} s"}
    seconds = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    if out is None:
        return {"error": f"exit code {r.returncode}: " + " ".join((r.stderr or "").split())[-200:]} \
            if r.returncode else {"seconds": seconds, "cpu_s": cpu}
    if r.returncode != 0 or not out.is_file():
        return {"error": f"exit code {r.returncode}: " + " ".join((r.stderr or "").split())[-200:]}
    with open(out) as fh:
        rows = sum(1 for _ in fh) - 1
    return {"seconds": seconds, "cpu_s": cpu, "rows": rows}


def harness_parts(cfg: Config, ssp: Path, stop: float, columns: list[str], mode: str, timeout: float) -> dict:
    """Where the harness's whole process goes, each part timed in one fresh process (``--parts-worker``), and
    the interpreter's own start and exit (``python -c pass``, the least of 3)."""
    spec = dict(ssp=str(ssp), stop=stop, step=cfg.step, master=cfg.master, order=cfg.order, columns=columns)
    r = subprocess.run([*_pin(mode), sys.executable, "-m", "benchmarks.scopes", "--parts-worker", json.dumps(spec)],
                       cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=timeout)
    out = next((json.loads(x[7:]) for x in reversed(r.stdout.splitlines()) if x.startswith("RESULT ")),
               {"error": " ".join((r.stderr or "").split())[-200:]})
    starts = []
    for _ in range(3):
        t0 = time.perf_counter()
        subprocess.run([*_pin(mode), sys.executable, "-c", "pass"], check=True)
        starts.append(time.perf_counter() - t0)
    out["interpreter_s"] = min(starts)
    return out


def parts_worker(spec: dict) -> dict:
    """The harness's whole run, as ``python -m harness run SSP --out FILE`` does it, timed part by part."""
    t0 = time.perf_counter()
    import harness.__main__  # noqa: F401  (the command line's own imports)
    from harness import simulate
    from harness.ssp import load_ssp

    t1 = time.perf_counter()
    system = load_ssp(spec["ssp"])
    t2 = time.perf_counter()
    df = simulate(system, stop_time=spec["stop"], step=spec["step"], master=spec["master"],
                  extrapolation=spec["order"], output=spec["columns"])
    t3 = time.perf_counter()
    from harness.results import write_result

    with tempfile.TemporaryDirectory() as tmp:
        write_result(df, Path(tmp) / "out.csv")
    t4 = time.perf_counter()
    wall, init = df.attrs["wall_time"], df.attrs["init_time"]
    return {"imports_s": t1 - t0, "load_ssp_s": t2 - t1, "open_fmus_s": t3 - t2 - wall, "init_s": init,
            "stepping_s": wall - init, "write_s": t4 - t3}


# -- the comparison ------------------------------------------------------------------------------------------
def measure(name: str, configs: dict, modes, repeats: int, quick: bool, timeout: float, log=print) -> list[dict]:
    """Time every tool with a Config in both scopes, in turn, ``repeats`` times per mode.  One row per drive,
    tool, mode and scope: min, median, the runs."""
    from harness import load
    from harness.ssp import export_ssp

    from benchmarks import host_accuracy

    system = load(name)
    stop = system.experiment.step * 50 if quick else system.accuracy.stop_time
    columns = host_accuracy.columns_of(system)
    runs = {t: c for t, c in configs.items() if isinstance(c, Config)}
    rows = []
    if repeats < 1:
        return rows
    with tempfile.TemporaryDirectory(prefix="scopes_") as tmp:
        work = Path(tmp)
        ssp = export_ssp(system, work / f"{name}.ssp")
        for mode in modes:
            got = {(t, s): [] for t in runs for s in SCOPES}
            cpu = {t: [] for t in runs}
            errors = {}
            for k in range(repeats):
                for t, cfg in runs.items():
                    for scope in SCOPES:
                        r = (time_stepping(cfg, ssp, stop, columns, mode, timeout) if scope == "stepping" else
                             time_whole(cfg, ssp, stop, columns, mode, timeout, work))
                        if "error" in r:
                            errors[(t, scope)] = r["error"]
                        else:
                            got[(t, scope)].append(r["stepping_s"] if scope == "stepping" else r["seconds"])
                            if scope == "whole":
                                cpu[t].append(r["cpu_s"])
                log(f"{name} {mode}: repetition {k + 1} of {repeats} done")
            for t, cfg in runs.items():
                for scope in SCOPES:
                    xs = got[(t, scope)]
                    rows.append(dict(drive=name, stop_time=stop, mode=mode, scope=scope, tool=t, run=cfg.label(),
                                     chosen=cfg.note, min_s=min(xs) if xs else math.nan,
                                     median_s=statistics.median(xs) if xs else math.nan, runs=len(xs),
                                     cpu_min_s=min(cpu[t]) if scope == "whole" and cpu[t] else math.nan,
                                     error="" if xs else errors.get((t, scope), "no run")))
            if "harness" in runs:
                parts = harness_parts(runs["harness"], ssp, stop, columns, mode, timeout)
                rows.append(dict(drive=name, stop_time=stop, mode=mode, scope="parts", tool="harness",
                                 run=runs["harness"].label(), chosen=json.dumps(parts), min_s=math.nan,
                                 median_s=math.nan, runs=1, cpu_min_s=math.nan, error=parts.get("error", "")))
    for t, c in configs.items():
        if not isinstance(c, Config):
            for scope in SCOPES:
                rows.append(dict(drive=name, stop_time=stop, mode="", scope=scope, tool=t, run="", chosen="",
                                 min_s=math.nan, median_s=math.nan, runs=0, cpu_min_s=math.nan, error=c))
    return rows


SWEEP_PARAMETERS = {"feeder_gto52": "feeder.clearance", "bed_drive": "bed.m_T"}
SWEEP_PEERS = ("omsimulator", "ecos")   # the peers whose Python API sets a parameter of a loaded SSP (benchmarks.whole)


def sweep_values(name: str, points: int) -> list[float]:
    """``points`` values of the drive's sweep parameter, from 0.9 to 1.1 times its declared value."""
    from harness import load

    inst, _, var = SWEEP_PARAMETERS[name].partition(".")
    value = float(next(i for i in load(name).instances if i.name == inst).parameters[var])
    return [value * (0.9 + 0.2 * k / max(points - 1, 1)) for k in range(points)]


def sweep_command(cfg: Config, ssp: Path, stop: float, name: str, values: list[float], work: Path) -> list[str]:
    """A sweep of ``values`` as the tool's user runs one on one CPU: the harness's ``sweep`` command with its
    points in its own process (``--workers 0``: the FMUs' code imported once, each point opening its instances
    again), a peer's loop loading the SSP again for every point (:mod:`benchmarks.whole`).  Nobody writes a
    time series; the harness writes its one row per point."""
    if cfg.tool == "harness":
        spec = work / "sweep.json"
        spec.write_text(json.dumps({"grid": {SWEEP_PARAMETERS[name]: values}, "stop_time": stop, "step": cfg.step,
                                    "master": cfg.master, "extrapolation": cfg.order}))
        return [sys.executable, "-m", "harness", "sweep", str(ssp), "--grid", str(spec), "--workers", "0",
                "--out", str(work / "sweep.csv")]
    return [sys.executable, "-m", "benchmarks.whole", "--sweep", cfg.tool, str(ssp), repr(stop), repr(cfg.step),
            SWEEP_PARAMETERS[name], *map(repr, values)]


def sweep(name: str, configs: dict, points: int, quick: bool, timeout: float, log=print) -> list[dict]:
    """The same ``points`` points in the harness and each sweep peer, each a fresh process pinned to one CPU
    (``taskset -c 0``), timed from start to exit (wall and CPU); throughput = points / wall seconds."""
    from harness import load
    from harness.ssp import export_ssp

    system = load(name)
    stop = system.experiment.step * 50 if quick else system.accuracy.stop_time
    values = sweep_values(name, points)
    rows = []
    with tempfile.TemporaryDirectory(prefix="scopes_sweep_") as tmp:
        work = Path(tmp)
        ssp = export_ssp(system, work / f"{name}.ssp")
        for t, cfg in configs.items():
            if not isinstance(cfg, Config) or (t != "harness" and t not in SWEEP_PEERS):
                continue
            r = _timed([*_pin("pinned"), *sweep_command(cfg, ssp, stop, name, values, work)], work, timeout)
            log(f"{name} sweep of {points} points, {t}: {r}")
            rows.append(dict(drive=name, stop_time=stop, mode="pinned", scope="sweep", tool=t, run=cfg.label(),
                             chosen=f"{points} points of {SWEEP_PARAMETERS[name]}", min_s=r.get("seconds", math.nan),
                             median_s=r.get("seconds", math.nan), runs=0 if "error" in r else 1,
                             cpu_min_s=r.get("cpu_s", math.nan), error=r.get("error", "")))
    return rows


def ratios(rows: list[dict], drive: str, mode: str, scope: str) -> tuple[float, str]:
    """(fastest peer's min / the harness's min, the fastest peer) for one table; NaN where either is missing."""
    mine = [r for r in rows if (r["drive"], r["mode"], r["scope"], r["tool"]) == (drive, mode, scope, "harness")]
    peers = [r for r in rows if (r["drive"], r["mode"], r["scope"]) == (drive, mode, scope)
             and r["tool"] != "harness" and math.isfinite(r["min_s"])]
    if not mine or not math.isfinite(mine[0]["min_s"]) or not peers:
        return math.nan, ""
    fastest = min(peers, key=lambda r: r["min_s"])
    return fastest["min_s"] / mine[0]["min_s"], fastest["tool"]


def tables(rows: list[dict]) -> str:
    """Every table, each headed by its drive, mode and scope."""
    out = []
    keys = []
    for r in rows:
        k = (r["drive"], r["mode"], r["scope"])
        if r["mode"] and r["scope"] in ALL_SCOPES and k not in keys:
            keys.append(k)
    for drive, mode, scope in keys:
        sel = [r for r in rows if (r["drive"], r["mode"], r["scope"]) == (drive, mode, scope)]
        ours = next((r for r in sel if r["tool"] == "harness"), None)
        stop = sel[0]["stop_time"]
        judged = "quick: accuracy not judged" if sel[0]["chosen"].startswith("quick") else "at its declared accuracy"
        out.append(f"\n{drive}, {stop:g} s {judged}, {mode}"
                   f"{' (taskset -c 0)' if mode == 'pinned' else ''}; SCOPE: {ALL_SCOPES[scope]}")
        out.append("| tool | run | min [s] | median [s] | runs | min / harness's min | CPU, min [s] |")
        out.append("|---|---|---|---|---|---|---|")
        for r in sel:
            ratio = (r["min_s"] / ours["min_s"] if ours and math.isfinite(ours["min_s"]) and math.isfinite(r["min_s"])
                     else math.nan)
            if r["error"]:
                out.append(f"| {r['tool']} | {r['run']} | - | - | 0 | {r['error']} | |")
            else:
                c = r.get("cpu_min_s", math.nan)
                out.append(f"| {r['tool']} | {r['run']} | {r['min_s']:.3g} | {r['median_s']:.3g} | {r['runs']} | "
                           f"{ratio:.2f}x | {'-' if not math.isfinite(c) else f'{c:.3g}'} |")
        no_run = [r for r in rows if r["drive"] == drive and not r["mode"] and r["scope"] == scope]
        for r in no_run:
            out.append(f"| {r['tool']} | - | - | - | 0 | {r['error']} | |")
        part = next((r for r in rows if (r["drive"], r["mode"], r["scope"]) == (drive, mode, "parts")), None)
        if scope == "whole" and part is not None and not part["error"]:
            p = json.loads(part["chosen"])
            out.append("the harness's whole process, part by part (one process): " + ", ".join(
                f"{k.removesuffix('_s').replace('_', ' ')} {v:.3g} s" for k, v in p.items()))
    return "\n".join(out)


def goal_lines(rows: list[dict], quick: bool) -> list[tuple[str, bool | None, str]]:
    """Per drive: stepping, whole process and (where measured) sweep, each its ratio in every mode."""
    lines = []
    for drive in dict.fromkeys(r["drive"] for r in rows):
        for scope, goal in GOALS.items():
            if scope == "sweep" and not any(r["drive"] == drive and r["scope"] == "sweep" for r in rows):
                continue
            what = (f"{drive}: sweep throughput >= {goal:g}x the fastest peer's" if scope == "sweep" else
                    f"{drive}: {scope.replace('whole', 'whole process')} >= {goal:g}x faster than the fastest peer")
            got = {m: ratios(rows, drive, m, scope) for m in MODES}
            got = {m: v for m, v in got.items() if math.isfinite(v[0])}
            if quick or not got:
                lines.append((what, None, "quick: numbers mean nothing" if quick else "no harness or peer time"))
                continue
            met = all(v[0] >= goal for v in got.values())
            lines.append((what, met, "; ".join(f"{m}: {v[0]:.2f}x (fastest peer {v[1]}, mins of the same run)"
                                               for m, v in got.items())))
    return lines


def write(rows: list[dict], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


ALL_SCOPES = {**SCOPES, "sweep": SWEEP_SCOPE}


def _worker(kind: str, spec: str) -> int:
    import warnings

    warnings.simplefilter("ignore")
    try:
        out = stepping_worker(json.loads(spec)) if kind == "stepping" else parts_worker(json.loads(spec))
    except Exception as e:   # reported in the table; the benchmark goes on
        out = {"error": " ".join(f"{type(e).__name__}: {e}".split())[:300]}
    print("RESULT " + json.dumps(out), flush=True)
    sys.stderr.flush()
    os._exit(0)   # pythonfmu instances a tool still holds have aborted the interpreter's exit


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] in (["--stepping-worker"], ["--parts-worker"]):
        return _worker(argv[0][2:].split("-")[0], argv[1])
    ap = argparse.ArgumentParser(prog="python -m benchmarks.scopes", description=__doc__.splitlines()[0])
    ap.add_argument("--drives", nargs="+", default=list(DRIVES))
    ap.add_argument("--tools", nargs="+", default=list(PEERS), help="the peers (the harness always runs)")
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    ap.add_argument("--repeats", type=int, default=5, help="runs per tool, scope and mode (min and median)")
    ap.add_argument("--quick", action="store_true", help="50 steps, accuracy not judged (smoke test)")
    ap.add_argument("--sweep", type=int, default=None, metavar="POINTS",
                    help="points of the sweep per drive (0: no sweep; default 50, 3 with --quick)")
    ap.add_argument("--sweep-tools", nargs="+", default=list(SWEEP_PEERS), choices=SWEEP_PEERS,
                    help="the peers that sweep (the harness always does)")
    ap.add_argument("--timeout", type=float, default=600.0, help="per process [s]")
    ap.add_argument("--use", action="append", default=[], metavar="DRIVE:TOOL=STEP[:MASTER:ORDER]",
                    help="take this run instead of choosing one (repeatable; a drive given any --use runs only the "
                         "tools given; their accuracy is then NOT judged here: give runs a full run chose)")
    ap.add_argument("--out", type=Path, default=None, help="folder of scopes.csv (default: results/benchmark"
                                                          "[-quick])")
    args = ap.parse_args(argv)
    out = args.out or ROOT / "results" / ("benchmark-quick" if args.quick else "benchmark")
    rows = []
    for name in args.drives:
        given = [u.split(":", 1)[1] for u in args.use if u.split(":", 1)[0] == name]
        configs = {} if given else choose(name, args.tools, args.quick, args.timeout,
                                          log=lambda s: print(s, file=sys.stderr))
        for u in given:
            tool, _, how = u.partition("=")
            step, master, order = (how.split(":") + ["", "0"])[:3]
            configs[tool] = Config(tool, float(step), master, int(order), "given with --use (chosen by a full run)")
        rows += measure(name, configs, args.modes, args.repeats, args.quick, args.timeout,
                        log=lambda s: print(s, file=sys.stderr))
        points = args.sweep if args.sweep is not None else (3 if args.quick else 50)
        if points:
            rows += sweep(name, {t: c for t, c in configs.items() if t == "harness" or t in args.sweep_tools},
                          points, args.quick, args.timeout, log=lambda s: print(s, file=sys.stderr))
    print(tables(rows))
    print("")
    for what, met, evidence in goal_lines(rows, args.quick):
        print(f"[{'n/a ' if met is None else ('MET ' if met else 'MISS')}] {what}: {evidence}")
    print(f"\nwrote {write(rows, out / 'scopes.csv')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
