"""The coupling goals, measured: fewer, larger steps at a stated accuracy (``python -m benchmarks.coupling``, and
the coupling lines of ``python -m benchmarks``).

Four lines, each MET / MISS with its evidence:

1. the scenes' full bed-drive model (every component at its highest fidelity) stable at a 2 ms step or more:
   the largest step of a ladder (0.5 to 8 ms) up to which the ``jacobian`` master runs it to the end at every
   step (1 s, one machine cycle), beside Jacobi's; and meeting the drive's declared accuracy (System.accuracy, judged against the full
   model's own monolithic reference) at 1 ms or more;
2. each declared model at its declared accuracy faster than real time by the goal (bed_drive 10x, feeder 5x):
   the cheapest method and step that meets the accuracy (:func:`harness.studies.accuracy.search`), then its
   real-time factor pinned to one CPU, best of 3 (the benchmark's worker);
3. the time to reach each drive's declared accuracy against the fastest peer's, at equal scope
   (:mod:`benchmarks.scopes`): libcosim, Ecos and OMSimulator (where installed) run the exported SSP with
   their own algorithm at decreasing steps; each peer's coarsest step that meets the accuracy and the harness's
   cheapest run are timed side by side in two scopes, stepping alone (goal 5x) and the whole process a user
   waits for (goal 2x) (none meets: the line says down to which step none did);
4. (the default scene's real-time line is the benchmark's own, ``targets``).

With an output folder, each drive's work-precision chart (:func:`work_precision_chart`): every harness run of
the ladder and every peer run on the same axes, the run's time against its worst requirement error as a
multiple of that requirement's tolerance.

Wall times are measured on a shared machine; the FMU steps beside them (fmi2DoStep calls) are not noisy.
"""
from __future__ import annotations

import argparse
import csv
import math
import warnings
from dataclasses import replace
from pathlib import Path

from benchmarks.cases import METHODS, STEPS

ROOT = Path(__file__).resolve().parents[1]
FULL_STEPS = (5e-4, 1e-3, 2e-3, 4e-3, 8e-3)     # the full model's stability ladder (jacobian) [s]
FULL_ACCURACY_STEPS = (2.5e-4, 5e-4, 1e-3)      # the full model's accuracy ladder (jacobian) [s]
DECLARED_GOALS = {"bed_drive": 10.0, "feeder_gto52": 5.0}
PEER_STEPS = (2e-4, 1e-4, 5e-5)
PEERS = ("libcosim", "ecos", "omsimulator")
CHART_TOP = 100.0   # work-precision chart: errors beyond this multiple of the tolerance are drawn on the top edge   # each with its own algorithm on the exported SSP


def _quiet(*args, **kwargs):
    from harness import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(*args, **kwargs)


def _full(system) -> dict:
    from harness.studies.scenes import fidelity_levels

    return {f"{k}.fidelity": max(v) for k, v in fidelity_levels(system).items()}


def full_model_lines(quick: bool, log=print) -> list[tuple[str, bool | None, str]]:
    """Line 1: the bed drive's full model, its largest stable step and the largest that meets its accuracy."""
    from harness import load
    from harness.studies import accuracy
    from harness.studies.reference import reference

    system = load("bed_drive")
    params = _full(system)
    stop = 0.2 if quick else system.accuracy.stop_time
    ran = {}   # step -> ran to the end
    for h in FULL_STEPS[2:3] if quick else FULL_STEPS:
        df = _quiet(system, stop_time=stop, step=h, master="jacobian", extrapolation=1, start_values=params)
        log(f"bed_drive full model, jacobian at {h:g} s: {'complete' if df.attrs['complete'] else df.attrs['error']}")
        ran[h] = bool(df.attrs["complete"])
    jac = _quiet(system, stop_time=stop, step=2.5e-4, master="jacobi", extrapolation=1, start_values=params)
    jac_note = "jacobi at 0.25 ms: " + ("complete" if jac.attrs["complete"] else "stopped")
    # stable up to h: every step of the ladder up to h runs to the end (a step that runs between two that stop
    # is no step a user can rely on: the verdicts of this coupling come in bands, docs/stability.md)
    upto = None
    for h in sorted(ran):
        if not ran[h]:
            break
        upto = h
    verdicts = ", ".join(f"{h * 1e3:g} ms {'runs to the end' if ok else 'stopped'}" for h, ok in sorted(ran.items()))
    lines = [("bed_drive full model stable at a 2 ms step or more (jacobian)", upto is not None and upto >= 2e-3,
              (f"every step up to {upto * 1e3:g} ms runs to the end" if upto else "stopped at the smallest step")
              + f" ({verdicts}) over {stop:g} s; {jac_note}")]
    spec = replace(system.accuracy, stop_time=stop)
    ref = reference(system, stop_time=stop, step=spec.reference_step, parameters=params)
    sys_acc = replace(system, accuracy=spec)
    meets = []
    for h in FULL_ACCURACY_STEPS[-1:] if quick else FULL_ACCURACY_STEPS:
        df = _quiet(system, stop_time=stop, step=h, master="jacobian", extrapolation=1, start_values=params)
        checks = accuracy.check(sys_acc, df, ref)
        text = ", ".join(f"{c.name} {c.error:.3g}/{c.tolerance:g}" for c in checks)
        log(f"bed_drive full model, jacobian at {h:g} s: {text}")
        meets.append((h, all(c.ok for c in checks), text))
    ok = [h for h, m, _ in meets if m]
    largest = max(ok) if ok else None
    lines.append(("bed_drive full model meets its declared accuracy at 1 ms or more (jacobian)",
                  largest is not None and largest >= 1e-3,
                  (f"meets up to {largest * 1e3:g} ms; " if largest else "meets at no step tried; ")
                  + "; ".join(f"{h * 1e3:g} ms: {t}" for h, _, t in meets)))
    return lines


def _pinned_realtime(system_name: str, row, timeout: float) -> dict:
    from benchmarks.launch import run_config

    run = dict(stop_time=float(row["stop_time"]), step=float(row["step"]), master=str(row["master"]),
               extrapolation=int(row["order"]), parameters={})
    return run_config({"case": system_name, "tool": "realtime", "run": run, "quick": False}, "pinned", timeout)


def declared_lines(quick: bool, timeout: float, log=print):
    """Line 2 (and the harness's cheapest run per drive, for line 3)."""
    from harness import load
    from harness.studies import accuracy

    lines, cheapest, tables = [], {}, {}
    for name, goal in DECLARED_GOALS.items():
        system = load(name)
        if quick:
            system = replace(system, accuracy=replace(system.accuracy, stop_time=system.experiment.step * 400))
        steps = STEPS[name][:2] if quick else STEPS[name]
        table = accuracy.search(system, METHODS, steps, progress=lambda s: log(f"{name}: {s}"))
        tables[name] = table
        best = accuracy.cheapest(table)
        what = f"{name} declared model at its declared accuracy >= {goal:g}x real time"
        if best is None:
            lines.append((what, False, "no method and step of the ladder meets its accuracy"))
            continue
        best = best.copy()
        best["stop_time"] = system.accuracy.stop_time
        out = {"error": "quick: not pinned"} if quick else _pinned_realtime(name, best, timeout)
        rt = best["stop_time"] / out["seconds"] if "seconds" in out else best["realtime"]
        how = "pinned, best of 3" if "seconds" in out else "one unpinned run of the search"
        cheapest[name] = (best, rt)
        lines.append((what, rt >= goal,
                      f"cheapest: {best['master']} order {best['order']} at {best['step'] * 1e3:g} ms, "
                      f"{int(best['fmu_steps'])} FMU steps over {best['stop_time']:g} s: {rt:.2f}x real time ({how})"))
    return lines, cheapest, tables


def peer_lines(cheapest: dict, quick: bool, timeout: float, log=print):
    """Line 3: each drive's time to its declared accuracy against the peers', at equal scope.  Which runs: the
    harness's cheapest (line 2's search) and each peer's coarsest step whose own run of the exported SSP meets
    the accuracy (:func:`benchmarks.host_accuracy.measure`: each in a guarded process, judged by the same
    check).  Their times: :func:`benchmarks.scopes.measure`, every tool side by side in the same two scopes,
    pinned and unpinned, min of 3 each: the stepping alone (initialised to stop, no result file) and the whole
    process a user waits for (start, load the SSP, initialise, run, write the judged columns, exit).  The
    guarded runs' own times are not compared: their scopes differ from tool to tool.  Returns the lines and
    every peer verdict per drive."""
    from benchmarks import host_accuracy, scopes

    lines, runs = [], {}
    for name, (best, rt) in cheapest.items():
        what = f"{name}: time to its declared accuracy against the fastest peer's, at equal scope"
        if quick:  # a quick run's harness time is over a shortened span: nothing to compare
            lines.append((what, None, "quick: not measured"))
            continue
        hosts = [h for h in PEERS if host_accuracy.unavailable(h) is None]
        if not hosts:
            lines.append((what, None, "no peer available"))
            continue
        verdicts = host_accuracy.measure(name, hosts, extra_steps=PEER_STEPS, timeout=timeout,
                                         progress=lambda text: log(text))
        runs[name] = verdicts
        configs = {"harness": scopes.Config("harness", float(best["step"]), str(best["master"]), int(best["order"]))}
        for v in verdicts:
            if v.meets and (v.run.host not in configs or v.run.step > configs[v.run.host].step):
                configs[v.run.host] = scopes.Config(v.run.host, v.run.step)
        if len(configs) == 1:
            tried = "; ".join(host_accuracy.describe(v) for v in verdicts)
            lines.append((what, None, f"no peer meets it at any step tried (down to "
                                      f"{min(v.run.step for v in verdicts) * 1e3:g} ms): {tried}"))
            continue
        rows = scopes.measure(name, configs, scopes.MODES, 3, False, timeout, log)
        log(scopes.tables(rows))
        lines += scopes.goal_lines(rows, False)
    return lines, runs


def goal_lines(quick: bool = False, timeout: float = 1800.0, log=print,
               out: Path | None = None) -> list[tuple[str, bool | None, str]]:
    """The goal lines; with ``out``, each drive's work-precision chart is written there too."""
    lines = full_model_lines(quick, log)
    declared, cheapest, tables = declared_lines(quick, timeout, log)
    peers, runs = peer_lines(cheapest, quick, timeout, log)
    if out is not None:
        for name, table in tables.items():
            for path in work_precision_chart(name, table, runs.get(name, []), Path(out) / f"work_precision_{name}"):
                log(f"wrote {path}")
    return lines + declared + peers


def _worst(errors_and_tolerances) -> float:
    """The worst requirement error as a multiple of its tolerance (NaN if any could not be judged)."""
    ratios = [e / t for e, t in errors_and_tolerances]
    return math.nan if not ratios or any(not math.isfinite(r) for r in ratios) else max(ratios)


def work_precision_chart(name: str, table, verdicts, stem: Path) -> list[Path]:
    """Time to run against accuracy for one drive: each harness run of the accuracy ladder (one line per
    method through its steps) and each peer's run of the exported SSP (one line per tool; its time is the
    tool's whole run in the guarded worker, loading included, the harness's its initialisation and stepping: the
    chart places runs by accuracy and does not compare speeds, which :mod:`benchmarks.scopes` does at equal
    scope), the error being the worst of the drive's declared requirements as a multiple of its tolerance
    (below 1: the run meets them all).  Runs that did not complete or could not be judged are drawn on the top
    edge with a cross, runs whose error is beyond :data:`CHART_TOP` times the tolerance there with a triangle.
    The points are also written to ``<stem>.csv`` (NaN: not judged)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from harness import load
    from harness.reporting.charts import save_figure

    reqs = load(name).accuracy.requirements
    series = []   # (label, marker, [(time, worst, step)])
    for (master, order), g in table.groupby(["master", "order"], sort=False):
        pts = [(float(r["wall_time"]), _worst((float(r[q.name]), q.tolerance) for q in reqs) if r["complete"]
                else math.nan, float(r["step"])) for _, r in g.iterrows()]
        series.append((f"harness {master}, order {order}", "o", pts))
    by_host: dict = {}
    for v in verdicts:
        worst = _worst((c.error, c.tolerance) for c in v.checks) if v.checks else math.nan
        by_host.setdefault(v.run.host, []).append((float(v.run.run_time if math.isfinite(v.run.run_time)
                                                         else v.run.wall_time), worst, float(v.run.step)))
    series += [(f"{host} (its own algorithm)", "s", pts) for host, pts in by_host.items()]
    Path(stem).parent.mkdir(parents=True, exist_ok=True)
    with open(Path(stem).with_suffix(".csv"), "w", newline="") as fh:   # the chart's points, to read or redraw
        w = csv.writer(fh)
        w.writerow(["method", "step_s", "time_s", "worst_error_over_tolerance"])
        for label, _, pts in series:
            w.writerows([label, h, t, x] for t, x, h in pts)
    fig, ax = plt.subplots(figsize=(10.5, 5.5))
    for label, marker, pts in series:
        pts = sorted(pts, key=lambda p: -p[2])
        t = [p[0] for p in pts]
        w = [min(p[1], CHART_TOP) if math.isfinite(p[1]) else CHART_TOP for p in pts]
        line, = ax.plot(t, w, "-" + marker, mfc="none", ms=6, label=label)
        for ti, wi, (_, raw, h) in zip(t, w, pts):
            ax.annotate(f"{h * 1e3:g} ms", (ti, wi), textcoords="offset points", xytext=(4, 3), fontsize=6,
                        color=line.get_color())
            if not math.isfinite(raw) or raw > CHART_TOP:
                ax.plot([ti], [wi], "x" if not math.isfinite(raw) else "^", color=line.get_color(), ms=9)
    ax.axhline(1.0, color="k", lw=1.0, ls="--", label="declared accuracy (every requirement at its tolerance)")
    ax.plot([], [], "kx", ms=9, label="stopped, failed or not judged (drawn at the top)")
    ax.plot([], [], "k^", ms=9, label=f"ran to the end, error beyond {CHART_TOP:g} x (drawn at the top)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    drawn = [min(w, CHART_TOP) for _, _, pts in series for _, w, _ in pts if math.isfinite(w) and w > 0]
    ax.set_ylim(0.5 * min(drawn + [0.1]), CHART_TOP * 1.6)
    ax.set_xlabel(f"time to run {load(name).accuracy.stop_time:g} s of the drive [s]  (wall time, shared machine; "
                  f"NOT equal scope: the harness initialising and stepping,\nthe peers loading the SSP, initialising, "
                  f"stepping and collecting the judged columns; equal-scope times: benchmarks.scopes)", fontsize=8)
    ax.set_ylabel("worst requirement error / its tolerance  [1]")
    ax.set_title(f"{name}: time against the declared accuracy\n(the harness's masters; the peers' own runs of the "
                 f"exported SSP)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    fig.tight_layout()
    return save_figure(fig, Path(stem), dpi=150)


def write(lines, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["goal", "met", "evidence"])
        for what, met, evidence in lines:
            w.writerow([what, "" if met is None else met, evidence])
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.coupling", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short runs and ladders (smoke test; numbers mean nothing)")
    ap.add_argument("--out", type=Path, default=None, help="folder of coupling_goals.csv (default: results/benchmark"
                                                          "[-quick])")
    ap.add_argument("--timeout", type=float, default=1800.0, help="per peer run and per pinned run [s]")
    args = ap.parse_args(argv)
    out = args.out or ROOT / "results" / ("benchmark-quick" if args.quick else "benchmark")
    lines = goal_lines(args.quick, args.timeout, out=out)
    print("")
    for what, met, evidence in lines:
        print(f"[{'n/a ' if met is None else ('MET ' if met else 'MISS')}] {what}: {evidence}")
    print(f"\nwrote {write(lines, out / 'coupling_goals.csv')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
