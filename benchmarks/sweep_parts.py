"""Where a sweep's CPU time goes, part by part, in the harness and in OMSimulator on the same points.

    python -m benchmarks.sweep_parts [--drive feeder_gto52] [--points 10] [--quick]

The points are those of :mod:`benchmarks.scopes`' sweep (the drive's sweep parameter from 0.9 to 1.1 times its
declared value, each point initialised and run to the drive's accuracy stop time, each tool at its step that
meets the declared accuracy: the harness's sweep at Jacobi with linear extrapolation, OMSimulator at its own
step).  Each tool sweeps them in one fresh process pinned to one CPU (``taskset -c 0``), taken in turn, as a
warm worker of ``harness sweep`` does (``--workers 0``: the points in one process) and as
:func:`benchmarks.whole.sweep_omsimulator` does (the SSP instantiated again for every point).  CPU seconds
(``time.process_time``), part by part:

* harness: the worker's start (the interpreter and its imports, the sweep module's), then per point its
  system loaded (:func:`harness.load`), its FMUs opened (:func:`harness.fmi.open_instance`: instantiating the
  slave objects; the first point also extracts and imports the FMUs' code), initialisation and stepping (the
  run's own ``cpu_time``) and the rest (the point's quantities, the row), and the Python modules the point
  imported: a warm point imports none, because the worker keeps its FMUs' code and extracted folders; at the
  end the table written (``harness.studies.sweep.save``);
* OMSimulator: its import, then per point the SSP instantiated (its FMUs loaded), the parameter set and
  initialised, simulated, terminated and deleted.

The throughput of a sweep is points per second; per point, once the worker is warm, the harness pays its
point's opening, initialisation and stepping, OMSimulator its instantiation, initialisation and simulation.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the steps each tool meets the drive's declared accuracy at (docs/performance.md, benchmarks.scopes' runs)
RUNS = {"feeder_gto52": {"harness": ("jacobi", 1, 4e-4), "omsimulator": 2e-4},
        "bed_drive": {"harness": ("jacobi", 1, 5e-4), "omsimulator": 2e-4}}


def _cpu() -> float:
    return time.process_time()


def child_harness(ssp: str, stop: float, parameter: str, values: list[float], run, out: str) -> dict:
    start = _cpu()  # the interpreter's start, up to this module's own imports
    import harness
    import harness.run.simulation
    import harness.studies.sweep as sweep_module
    from harness.studies.sweep import parse_spec, run_point, save

    imports = _cpu() - start
    master, order, step = run
    spec = parse_spec({"grid": {parameter: values}, "stop_time": stop, "step": step, "master": master,
                       "extrapolation": order, "outputs": {}}, "<sweep_parts>")
    parts = {"load": 0.0, "open": 0.0, "run": 0.0}
    load, open_instance, trial = harness.load, harness.run.simulation.open_instance, sweep_module.trial

    def timed(key, fn):
        def wrapper(*args, **kwargs):
            t0 = _cpu()
            try:
                return fn(*args, **kwargs)
            finally:
                parts[key] += _cpu() - t0
        return wrapper

    def trial_cpu(*args, **kwargs):
        r = trial(*args, **kwargs)
        if r.result is not None:
            parts["run"] += r.result.attrs["cpu_time"]
        return r

    harness.load = timed("load", load)
    harness.run.simulation.open_instance = timed("open", open_instance)
    sweep_module.trial = trial_cpu
    points, rows = [], []
    for p in spec.points:
        for k in parts:
            parts[k] = 0.0
        modules = len(sys.modules)
        t0 = _cpu()
        row = run_point(ssp, spec, p)
        total = _cpu() - t0
        if row["error"]:
            raise RuntimeError(f"harness sweep point {p}: {row['error']}")
        rows.append(row)
        points.append({"total": total, **parts, "rest": total - sum(parts.values()),
                       "modules_imported": len(sys.modules) - modules})
    import pandas as pd

    t0 = _cpu()
    save(pd.DataFrame(rows), out)
    return {"start": start, "imports": imports, "points": points, "write": _cpu() - t0}


def child_omsimulator(ssp: str, stop: float, parameter: str, values: list[float], step: float) -> dict:
    start = _cpu()
    from OMSimulator import SSP, CRef

    imports = _cpu() - start
    system = Path(ssp).stem
    t0 = _cpu()
    archive = SSP(ssp)
    opened = _cpu() - t0
    points = []
    for value in values:
        c = [_cpu()]
        im = archive.instantiate()
        c.append(_cpu())
        im.setFixedStepSize(step)
        im.setStopTime(stop)
        im.setResultFile("")
        im.setValue(CRef(system, *parameter.split(".", 1)), value)
        im.initialize()
        c.append(_cpu())
        im.simulate()
        c.append(_cpu())
        im.terminate()
        im.delete()
        c.append(_cpu())
        points.append({"total": c[4] - c[0], "instantiate": c[1] - c[0], "initialize": c[2] - c[1],
                       "simulate": c[3] - c[2], "delete": c[4] - c[3]})
    return {"start": start, "imports": imports + opened, "points": points, "write": 0.0}


def _child(tool: str, args: list[str], timeout: float) -> dict:
    cmd = ["taskset", "-c", "0", sys.executable, "-m", "benchmarks.sweep_parts", "--child", tool, *args]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    before = os.times()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=str(ROOT))
    after = os.times()
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith("RESULT "):
            out = json.loads(line[len("RESULT "):])
            out["process_cpu"] = (after.children_user - before.children_user
                                  + after.children_system - before.children_system)
            return out
    raise RuntimeError(f"{tool} sweep child failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")


def _summary(r: dict) -> dict:
    """First point and the median of the others, per part; the process's CPU outside the points."""
    pts = r["points"]
    warm = pts[1:] or pts
    keys = [k for k in pts[0] if k != "modules_imported"]
    return {"first": pts[0], "warm": {k: statistics.median(p[k] for p in warm) for k in keys},
            "warm_mean": statistics.fmean(p["total"] for p in warm), "raw": pts,
            "warm_modules": max((p.get("modules_imported", 0) for p in warm), default=0),
            "outside": r["process_cpu"] - sum(p["total"] for p in pts) - r["write"], "write": r["write"],
            "total": r["process_cpu"], "points": len(pts)}


def measure(drive: str, points: int, quick: bool, timeout: float, log=print) -> dict:
    from harness import load
    from harness.ssp import export_ssp

    from benchmarks.scopes import SWEEP_PARAMETERS, sweep_values

    system = load(drive)
    stop = system.experiment.step * 50 if quick else system.accuracy.stop_time
    values = sweep_values(drive, points)
    out = {}
    with tempfile.TemporaryDirectory(prefix="sweep_parts_") as tmp:
        ssp = str(export_ssp(system, Path(tmp) / f"{drive}.ssp"))
        common = [ssp, repr(stop), SWEEP_PARAMETERS[drive], json.dumps(values)]
        run = RUNS[drive]
        out["harness"] = _summary(_child("harness", [*common, json.dumps(run["harness"]),
                                                     str(Path(tmp) / "sweep.csv")], timeout))
        log(f"harness: {json.dumps(out['harness'])}")
        out["omsimulator"] = _summary(_child("omsimulator", [*common, repr(run["omsimulator"])], timeout))
        log(f"omsimulator: {json.dumps(out['omsimulator'])}")
    out.update(drive=drive, stop=stop, runs=RUNS[drive])
    return out


def report(m: dict, goal: float = 3.0) -> list[str]:
    h, o = m["harness"], m["omsimulator"]
    hw, ow = h["warm"], o["warm"]
    n = h["points"]
    lines = [
        f"{m['drive']}: {n} points, {m['stop']:g} s each; CPU seconds, pinned to one CPU, each tool in one process",
        "| part | harness | OMSimulator |", "|---|---|---|",
        f"| worker start: interpreter, imports, outside the points | {h['outside']:.2f} | {o['outside']:.2f} |",
        f"| first point | {h['first']['total']:.3f} (opening the FMUs {h['first']['open']:.3f}, "
        f"{h['first']['modules_imported']} modules imported) | {o['first']['total']:.3f} |",
        f"| a warm point (median; mean) | {hw['total']:.3f}; {h['warm_mean']:.3f} | {ow['total']:.3f}; "
        f"{o['warm_mean']:.3f} |",
        f"| of it: loading the system / the SSP instantiated, FMUs loaded | {hw['load']:.3f} | {ow['instantiate']:.3f} |",
        f"| of it: opening the FMUs (instances) | {hw['open']:.3f} | (in the above) |",
        f"| of it: initialisation and stepping | {hw['run']:.3f} | {ow['initialize'] + ow['simulate']:.3f} |",
        f"| of it: the rest (quantities, row; terminate and delete) | {hw['rest']:.3f} | {ow['delete']:.3f} |",
        f"| Python modules a warm point imports | {h['warm_modules']} | |",
        f"| writing the table | {h['write']:.3f} | - |",
        f"| the whole process | {h['total']:.2f} | {o['total']:.2f} |",
    ]
    ratio = o["total"] / h["total"]
    warm_ratio = o["warm_mean"] / h["warm_mean"]
    floor = ow["total"] / hw["run"]  # medians
    lines += [
        f"throughput ratio (OMSimulator's CPU / the harness's, whole processes): {ratio:.2f}x; per warm point "
        f"{warm_ratio:.2f}x (means); goal {goal:g}x: {'met' if ratio >= goal else 'missed'}",
        f"floor: with the harness's warm point costing its initialisation and stepping alone (system loading and "
        f"FMU opening free) the per-point ratio (medians) could reach {floor:.2f}x",
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--child"]:
        tool, ssp, stop, parameter, values, *rest = argv[1:]
        import warnings

        warnings.simplefilter("ignore")
        if tool == "harness":
            r = child_harness(ssp, float(stop), parameter, json.loads(values), json.loads(rest[0]), rest[1])
        else:
            r = child_omsimulator(ssp, float(stop), parameter, json.loads(values), float(rest[0]))
        print("RESULT " + json.dumps(r), flush=True)
        return 0
    ap = argparse.ArgumentParser(prog="python -m benchmarks.sweep_parts", description=__doc__.splitlines()[0])
    ap.add_argument("--drive", default="feeder_gto52", choices=sorted(RUNS))
    ap.add_argument("--points", type=int, default=10, help="points of the sweep (default 10)")
    ap.add_argument("--quick", action="store_true", help="50 steps per point (timings rougher)")
    ap.add_argument("--json", help="also write the measurements to this file")
    ap.add_argument("--timeout", type=float, default=1800.0)
    args = ap.parse_args(argv)
    if args.points < 2:
        raise SystemExit(f"--points {args.points}: at least 2 (the first point is cold, the others warm)")
    m = measure(args.drive, args.points, args.quick, args.timeout)
    print("\n".join(report(m)))
    if args.json:
        Path(args.json).write_text(json.dumps(m, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
