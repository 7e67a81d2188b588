"""Batches of variants against one run per variant, and the 50-point feeder sweep against OMSimulator
(``python -m benchmarks``, or ``python -m benchmarks.batch`` alone).

* **Per-variant cost** (:func:`per_variant`): for each drive and N = 1, 10, 100, 1000 variants (one real parameter
  spread over +-10 % of its declared value), a fresh process pinned to CPU 0 (``taskset -c 0``) times, in CPU
  seconds (``time.process_time``), :func:`harness.run.batch.simulate_batch` of the N variants, and a fresh process
  the same way times :func:`harness.simulate` of three of them, one after the other (after one warm-up run, the
  median): both record the same one column and compute nothing else.  The ratio is the scalar run's CPU over the
  batch's CPU per variant.  Each batch also reports where its time went, component by component and in the
  master (:attr:`harness.master.batch.BatchMaster.costs`, CPU seconds), and how each component was stepped
  (vectorised, or each variant's scalar model): where a drive falls short, that says which part costs what.
  The bed drive runs its default experiment (2 s); the drives whose parts run as scalar loops a shorter span
  (:data:`STOP`), the trimmer at a single step (:data:`STEP`), the same for batch and scalar.
* **The feeder sweep** (:func:`feeder_sweep`): the 50 points of ``benchmarks.scopes``' sweep (the feeder's cam
  clearance over +-10 %, 0.6 s each, each tool at the step that meets the drive's declared accuracy: the harness
  Jacobi with linear extrapolation at 0.4 ms, OMSimulator 0.2 ms), one fresh process per tool pinned to one CPU,
  timed from start to exit in CPU seconds: the harness's ``sweep --workers 0`` (batched), the same with
  ``--no-batch``, and OMSimulator instantiating the SSP for every point.

Goals (:data:`GOALS`): the bed drive's default experiment at least 20 times less CPU per variant at 100 variants
and 50 times at 1000; the feeder sweep at least 10 times less CPU than OMSimulator's.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DRIVES = ("bed_drive", "feeder_gto52", "proof_press", "spine_knife", "trimmer_conveyor")
SIZES = (1, 10, 100, 1000)
PARAMETER = {"bed_drive": "flywheel.J_flywheel", "feeder_gto52": "feeder.clearance", "proof_press": "flywheel.J_flywheel",
             "spine_knife": "knife.T_cut", "trimmer_conveyor": "drive.J_flywheel"}
STOP = {"proof_press": 0.5, "spine_knife": 0.1}    # s: the rest run their default experiment
# the trimmer's declared experiment steps its knife load at its own rate (multirate), which a batch does not: both
# sides run every FMU at a quarter millisecond
STEP = {"trimmer_conveyor": 2.5e-4}
COLUMN = {"bed_drive": "bed.bed.s", "feeder_gto52": "feeder.pin_force", "proof_press": "flywheel.crank.w",
          "spine_knife": "knife.feed_force", "trimmer_conveyor": "trim.transport_force"}
GOALS = {("bed_drive", 100): 20.0, ("bed_drive", 1000): 50.0}
SWEEP_GOAL = 10.0          # OMSimulator's CPU over the harness's, the 50-point feeder sweep
SCALAR_RUNS = 3
QUICK_STOP = 0.02         # s: every run of --quick


def variants(name: str, n: int) -> list[dict]:
    from harness import load

    inst, _, var = PARAMETER[name].partition(".")
    value = float(load(name).instance(inst).parameters[var])
    return [{PARAMETER[name]: value * (0.9 + 0.2 * k / max(n - 1, 1))} for k in range(n)]


def worker(spec: dict) -> dict:
    """In THIS process: the batch of ``spec["n"]`` variants, or ``spec["scalar"]`` runs one by one; CPU seconds."""
    import warnings

    warnings.simplefilter("ignore")
    from harness import simulate
    from harness.run.batch import BatchOptions, Keep, simulate_batch

    name, n = spec["name"], spec["n"]
    stop = spec.get("stop") or STOP.get(name)
    settings = {"stop_time": stop} if stop else {}
    if name in STEP:
        settings["step"] = STEP[name]
    column = COLUMN[name]
    vs = variants(name, n)
    if spec.get("scalar"):
        simulate(name, start_values=vs[0], output=[column], **settings)       # warm: imports, FMU code
        cpu = []
        for v in vs[:SCALAR_RUNS]:
            t0 = time.process_time()
            df = simulate(name, start_values=v, output=[column], **settings)
            cpu.append(time.process_time() - t0)
            if not df.attrs["complete"]:
                return {"error": df.attrs["error"]}
        return {"cpu_per_run": statistics.median(cpu), "runs": cpu, "steps": int(df.attrs["steps"])}
    simulate_batch(name, vs[:1], {**settings, "stop_time": 0.01}, Keep(columns=(column,)))   # warm: imports, the vector math's check
    t0 = time.process_time()
    run = simulate_batch(name, vs, settings, Keep(columns=(column,)), BatchOptions())
    cpu = time.process_time() - t0
    bad = [r.error for r in run.results if not r.complete]
    return {"cpu": cpu, "cpu_per_variant": cpu / n, "costs": run.info["costs"], "groups": run.info["groups"],
            "rerun": run.info["rerun"], "failed": len(bad), "first_error": bad[0] if bad else "",
            "vector_math": run.info["vector_math"]}


def _launch(spec: dict, timeout: float) -> dict:
    from benchmarks.launch import run_config

    return run_config(spec, "pinned", timeout, ("benchmarks.batch", "--worker"))


def per_variant(drives, sizes, timeout: float, log=print, stop: float | None = None) -> list[dict]:
    """One row per drive and N: the batch's CPU per variant, the scalar run's, their ratio, and the batch's parts
    (``stop``: every run's stop time, in place of :data:`STOP` and the default experiments)."""
    rows = []
    for name in drives:
        scalar = _launch({"name": name, "n": SCALAR_RUNS, "scalar": True, "stop": stop}, timeout)
        log(f"{name}: scalar runs {scalar}")
        for n in sizes:
            b = _launch({"name": name, "n": n, "stop": stop}, timeout)
            row = {"drive": name, "n": n, "stop_time": stop or STOP.get(name, "default"),
                   "step": STEP.get(name, "default"),
                   "scalar_cpu_per_run": scalar.get("cpu_per_run", math.nan),
                   "batch_cpu": b.get("cpu", math.nan), "batch_cpu_per_variant": b.get("cpu_per_variant", math.nan),
                   "error": b.get("error", "") or scalar.get("error", "") or b.get("first_error", "")}
            row["ratio"] = row["scalar_cpu_per_run"] / row["batch_cpu_per_variant"]
            costs = b.get("costs", {})
            total = sum(costs.values()) or math.nan
            row["parts"] = "; ".join(f"{k} {v:.3g} s ({100 * v / total:.0f} %)" for k, v in
                                     sorted(costs.items(), key=lambda kv: -kv[1]))
            forms = (b.get("groups") or [{}])[0].get("forms", {})
            row["scalar_loops"] = ", ".join(k for k, f in forms.items() if f != "vectorised")
            row["setup_and_rest_s"] = b.get("cpu", math.nan) - (total if costs else math.nan)
            log(f"{name} N={n}: {row['batch_cpu_per_variant']:.4g} s/variant against {row['scalar_cpu_per_run']:.4g} "
                f"s/run: {row['ratio']:.1f}x; {row['parts']}{' ' + row['error'] if row['error'] else ''}")
            rows.append(row)
    return rows


def feeder_sweep(points: int, timeout: float, log=print, stop: float | None = None) -> list[dict]:
    """The 50-point feeder sweep (module docstring): CPU seconds of each tool's whole process, pinned (``stop``:
    each point's stop time in place of the drive's accuracy run's)."""
    import tempfile

    from benchmarks import host_accuracy
    from benchmarks.scopes import Config, _pin, _timed, sweep_command, sweep_values
    from harness import load
    from harness.ssp import export_ssp

    name = "feeder_gto52"
    system = load(name)
    stop = stop or system.accuracy.stop_time
    values = sweep_values(name, points)
    configs = {"harness": Config("harness", 4e-4, "jacobi", 1), "omsimulator": Config("omsimulator", 2e-4)}
    rows = []
    with tempfile.TemporaryDirectory(prefix="batch_sweep_") as tmp:
        work = Path(tmp)
        ssp = export_ssp(system, work / f"{name}.ssp")
        runs = [("harness (batched)", configs["harness"], []), ("harness --no-batch", configs["harness"], ["--no-batch"])]
        why = host_accuracy.unavailable("omsimulator") if hasattr(host_accuracy, "unavailable") else None
        if why is None:
            runs.append(("omsimulator", configs["omsimulator"], []))
        for label, cfg, extra in runs:
            cmd = [*_pin("pinned"), *sweep_command(cfg, ssp, stop, name, values, work), *extra]
            r = _timed(cmd, work, timeout)
            log(f"{name} sweep of {points} points, {label}: {r}")
            rows.append({"tool": label, "step": cfg.step, "points": points, "stop_time": stop,
                         "cpu_s": r.get("cpu_s", math.nan), "wall_s": r.get("seconds", math.nan),
                         "error": r.get("error", "")})
        if why is not None:
            rows.append({"tool": "omsimulator", "step": 2e-4, "points": points, "stop_time": stop, "cpu_s": math.nan,
                         "wall_s": math.nan, "error": why})
    return rows


def goal_lines(rows: list[dict], sweep_rows: list[dict], quick: bool) -> list[tuple[str, bool | None, str]]:
    lines = []
    for (name, n), goal in GOALS.items():
        r = next((x for x in rows if x["drive"] == name and x["n"] == n), None)
        what = f"{name}: {goal:g}x less CPU per variant at {n} variants than one run per variant"
        if r is None or not math.isfinite(r["ratio"]):
            lines.append((what, None, "not measured" if r is None else r["error"]))
            continue
        lines.append((what, None if quick else r["ratio"] >= goal,
                      f"{r['ratio']:.1f}x ({r['batch_cpu_per_variant']:.4g} s/variant against "
                      f"{r['scalar_cpu_per_run']:.4g} s/run; pinned, CPU); parts: {r['parts']}"))
    ours = next((x for x in sweep_rows if x["tool"] == "harness (batched)"), None)
    peer = next((x for x in sweep_rows if x["tool"] == "omsimulator"), None)
    what = f"feeder_gto52: the 50-point sweep with {SWEEP_GOAL:g}x less CPU than OMSimulator"
    if ours is None or peer is None or not (math.isfinite(ours["cpu_s"]) and math.isfinite(peer["cpu_s"])):
        lines.append((what, None, (peer or {}).get("error") or (ours or {}).get("error") or "not measured"))
    else:
        ratio = peer["cpu_s"] / ours["cpu_s"]
        lines.append((what, None if quick else ratio >= SWEEP_GOAL,
                      f"{ratio:.2f}x (harness {ours['cpu_s']:.3g} s, OMSimulator {peer['cpu_s']:.3g} s of CPU, whole "
                      f"processes pinned)"))
    return lines


def run(out: Path, quick: bool, timeout: float, drives=DRIVES, log=print) -> list[tuple]:
    """Everything of the module docstring; ``quick``: N = 1 and 10 of the bed drive and an 8-point sweep, all of
    :data:`QUICK_STOP` (a smoke test: the numbers mean nothing).  Returns the goal lines."""
    if quick:
        rows = per_variant(("bed_drive",), (1, 10), timeout, log, QUICK_STOP)
        sweep_rows = feeder_sweep(8, timeout, log, QUICK_STOP)
    else:
        rows = per_variant(drives, SIZES, timeout, log)
        sweep_rows = feeder_sweep(50, timeout, log)
    from benchmarks.scopes import write

    write(rows, out / "batch.csv")
    write(sweep_rows, out / "batch_sweep.csv")
    lines = goal_lines(rows, sweep_rows, quick)
    for what, met, evidence in lines:
        log(f"[{'n/a ' if met is None else ('MET ' if met else 'MISS')}] {what}: {evidence}")
    log(f"wrote {out / 'batch.csv'}, {out / 'batch_sweep.csv'}")
    return lines


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--worker"]:
        try:
            result = worker(json.loads(argv[1]))
        except Exception as e:   # reported in the table; the benchmark goes on
            result = {"error": " ".join(f"{type(e).__name__}: {e}".split())[:300]}
        print("RESULT " + json.dumps(result), flush=True)
        return 0
    ap = argparse.ArgumentParser(prog="python -m benchmarks.batch", description=__doc__.splitlines()[0])
    ap.add_argument("--drives", nargs="+", default=list(DRIVES), choices=DRIVES)
    ap.add_argument("--quick", action="store_true", help="the bed drive at N = 1, 10 and a 10-point sweep (smoke)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="per process [s]")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "benchmark")
    args = ap.parse_args(argv)
    run(args.out, args.quick, args.timeout, tuple(args.drives))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
