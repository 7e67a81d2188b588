"""The benchmark driver (``python -m benchmarks``; see the package docstring).

    python -m benchmarks                      # everything, pinned and unpinned
    python -m benchmarks --quick --cases ring --tools jacobi-sampled,fmpy --modes unpinned --out /tmp/b

Each configuration (case x tool x mode) runs in its own subprocess; ``pinned`` prefixes ``taskset -c 0``.
Results: ``<out>/benchmark.csv`` (one row per configuration), the chart (``--chart``, default
docs/images/benchmark.png and .svg; a ``--quick`` run, whose timings mean nothing, writes both into
results/benchmark-quick/ unless told otherwise), and a printed table with the cost per FMU-step, the ratios
harness/peer, the result check and the targets.
"""
from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

from benchmarks import cofmupy
from benchmarks.cases import CASES, check_columns, ssp_folder
from benchmarks.launch import run_config
from benchmarks.runners import CONVENTIONS, HARNESS_TOOLS, SAME_ALGORITHM, TOOLS
from harness.reporting.charts import save_figure

ROOT = Path(__file__).resolve().parents[1]
MODES = ("pinned", "unpinned")
RTOL = 1e-9          # result check: |value - reference| <= RTOL * (|reference| + column scale)
REFERENCE = "jacobi-sampled"
PLAIN_FMI = "jacobi-sampled-fmi"      # the same master through the FMUs' C libraries (no in-process path)
REALTIME_SYSTEM = "bed_drive"         # whose default scene must run >= SCENE_GOAL x faster than real time
SCENE_GOAL = 10.0                     # real-time factor the default scene must reach
DECLARED_GOALS = {"bed_drive": 10.0, "feeder_gto52": 5.0}   # real-time factor goal of the declared model
SWEEP_SYSTEM, SWEEP_GOAL = "feeder_gto52", 0.050   # goal: per-point overhead of a warm sweep worker [s]
FIELDS = ("case", "tool", "mode", "fmus", "steps", "step", "seconds", "us_per_fmu_step", "ratio_harness_to_tool",
          "same_result", "max_rel_deviation", "realtime_factor", "note")


def _csv_list(text: str, allowed, what: str) -> list[str]:
    items = [t.strip() for t in text.split(",") if t.strip()]
    bad = [t for t in items if t not in allowed]
    if bad or not items:
        raise SystemExit(f"--{what} {text!r}: unknown {', '.join(bad) or '(empty)'}; choose from {', '.join(allowed)}")
    return items


def compare(final: dict, reference: dict, scales: dict) -> float:
    """Largest |value - reference| / (|reference| + scale) over the check columns (inf if one is missing)."""
    worst = 0.0
    for c, ref in reference.items():
        v = final.get(c)
        if v is None or not math.isfinite(v):
            return math.inf
        worst = max(worst, abs(v - ref) / (abs(ref) + scales[c]))
    return worst


def run_all(cases: list[str], tools: list[str], modes: list[str], quick: bool, work: Path,
            timeout: float, realtime: bool, log=print) -> list[dict]:
    rows: list[dict] = []
    work = Path(work).resolve()  # the workers (and CoFmuPy's venv) run in other folders
    work.mkdir(parents=True, exist_ok=True)
    for name in cases:
        case = CASES[name]
        system = case.system()
        folder = ssp_folder(system, work)
        columns = check_columns(system)
        n = case.n_steps(quick)
        pset = "default" if any(i.parameters for i in system.instances) else None
        base = {"case": name, "folder": str(folder), "step": case.step, "n": n, "columns": columns,
                "parameter_set": pset, "detector": case.detector}
        results = {}
        for mode in modes:
            for tool in tools:
                row = {"case": name, "tool": tool, "mode": mode, "fmus": len(system.instances), "steps": n,
                       "step": case.step, "note": "" if case.detector or tool not in HARNESS_TOOLS else
                       "divergence detector off: the case's coupling is unstable (benchmarks/cases.py)"}
                spec = dict(base, tool=tool)
                if tool == "cofmupy":  # its own venv (benchmarks.cofmupy); may be skipped with a reason
                    out = cofmupy.run_config(spec, mode, timeout)
                else:
                    out = run_config(spec, mode, timeout)
                if "skipped" in out:
                    row["note"] = (row["note"] + " skipped: " + out["skipped"]).lstrip()
                elif "error" in out:
                    row["note"] = (row["note"] + " failed: " + out["error"]).lstrip()
                else:
                    row["seconds"] = out["seconds"]
                    row["us_per_fmu_step"] = 1e6 * out["seconds"] / (out["steps"] * out["fmus"])
                    results[(tool, mode)] = out["final"]
                log(f"{name:13s} {mode:9s} {tool:15s} "
                    + (f"{row['us_per_fmu_step']:9.2f} us/FMU-step" if "seconds" in row else row["note"]))
                rows.append(row)
        _check(rows, name, results, columns, convention_references(tools, base, timeout))
    if realtime:
        rows.extend(run_realtime(REALTIME_SYSTEM, modes, quick, work, timeout, log))
        for name in DECLARED_GOALS:
            if name != REALTIME_SYSTEM:
                rows.extend(run_realtime(name, modes, quick, work, timeout, log, kinds=("experiment",)))
        rows.extend(run_sweep_overhead(SWEEP_SYSTEM, modes, quick, timeout, log))
    _ratios(rows)
    return rows


def realtime_runs(system_name: str, cache: Path, log=print, kinds=("scene", "experiment")) -> list[tuple[str, str, dict]]:
    """(kind, label, run) of the system's default scene and of its default experiment.

    The default scene is answered by :func:`harness.studies.scenes.choose` (the coarsest model within the scene's
    tolerance of the full model; the full model is cached in ``cache``): the run is that model over the
    scene's time.  The default experiment is the system's declared model over its stop time."""
    from harness import load
    from harness.studies.scenes import choose, find_scene

    system = load(system_name)
    exp = system.experiment
    declared = ("experiment", f"default experiment (declared model): step {exp.step:g} s, {exp.master}",
                dict(stop_time=exp.stop_time, step=exp.step, master=exp.master, parameters={}))
    if "scene" not in kinds:
        return [declared]
    scene = find_scene(system)
    log(f"{system_name}: choosing the model of the default scene {scene.name!r} ({scene.question})")
    chosen = choose(system, scene, cache_dir=cache).chosen
    fid = ", ".join(f"{k} {v}" for k, v in chosen.fidelities.items())
    return [("scene", f"default scene {scene.name}: fidelity {fid}; step {chosen.step:g} s, {chosen.master}",
             dict(stop_time=scene.stop_time or exp.stop_time, step=chosen.step, master=chosen.master,
                  parameters={f"{k}.fidelity": v for k, v in chosen.fidelities.items()}))] + (
        [declared] if "experiment" in kinds else [])


def _realtime_row(out: dict, row: dict, factor: str) -> dict:
    """``row`` completed from a real-time worker's ``out``: its cost and real-time factor, the factor also in the
    note (``factor``: the note's format of it), or the failure."""
    if "error" in out:
        row["note"] += "; failed: " + out["error"]
        return row
    row.update(seconds=out["seconds"], steps=out["steps"], fmus=out["fmus"],
               us_per_fmu_step=1e6 * out["seconds"] / (out["steps"] * out["fmus"]),
               realtime_factor=out["final"]["stop_time"] / out["seconds"])
    row["note"] += factor.format(row["realtime_factor"]) + f" (best of {out['repeats']})"
    return row


def run_realtime(system_name: str, modes: list[str], quick: bool, work: Path, timeout: float, log=print,
                 kinds=("scene", "experiment")) -> list[dict]:
    """Real-time factor of the default scene and of the default experiment (``kinds``), in each mode."""
    rows = []
    for kind, label, run in realtime_runs(system_name, work / "cache", log, kinds):
        for mode in modes:
            out = run_config({"case": system_name, "tool": "realtime", "run": run, "quick": quick}, mode, timeout)
            row = _realtime_row(out, {"case": f"{system_name} ({kind})", "tool": run["master"], "mode": mode,
                                      "step": None, "kind": kind, "note": label}, "; real-time factor {:.3g}")
            log(f"{system_name} {kind:10s} {mode:9s} {row['note']}")
            rows.append(row)
            if kind == "experiment":
                rows.extend(run_floors(system_name, run, mode, quick, timeout, log))
    return rows


FLOORS = {"physics": "floor with free physics (the FMUs' equations cost nothing; their FMI layer and the master "
                     "remain)",
          "fmu-calls": "floor with free FMU calls (the master alone)"}


def run_floors(system_name: str, run: dict, mode: str, quick: bool, timeout: float, log=print) -> list[dict]:
    """The declared model's run with stand-ins after initialisation (:mod:`benchmarks.floors`): the real-time
    factor it could reach if the FMUs' physics, or all their calls, cost nothing."""
    rows = []
    for stand_in, label in FLOORS.items():
        out = run_config({"case": system_name, "tool": "realtime", "run": run, "quick": quick,
                          "stand_in": stand_in}, mode, timeout)
        row = _realtime_row(out, {"case": f"{system_name} ({stand_in} floor)", "tool": run["master"], "mode": mode,
                                  "step": None, "kind": f"floor-{stand_in}", "system": system_name, "note": label},
                            ": at most {:.3g}x real time")
        log(f"{system_name} {stand_in + ' floor':10s} {mode:9s} {row['note']}")
        rows.append(row)
    return rows


def run_sweep_overhead(system_name: str, modes: list[str], quick: bool, timeout: float, log=print) -> list[dict]:
    """Per-point overhead of a sweep worker (everything but stepping): the wall time of
    :func:`harness.studies.sweep.run_point` for a ONE-step run, on a warm worker process (after a first point),
    in each mode (:func:`benchmarks.runners.run_sweep_overhead`)."""
    rows = []
    for mode in modes:
        out = run_config({"case": system_name, "tool": "sweep-overhead", "quick": quick}, mode, timeout)
        row = {"case": f"{system_name} (sweep point)", "tool": "run_point", "mode": mode, "step": None,
               "kind": "sweep", "note": "per-point overhead of a warm worker, one-step runs"}
        if "error" in out:
            row["note"] += "; failed: " + out["error"]
        else:
            row.update(seconds=out["seconds"], overhead_s=out["overhead_s"], first_point_s=out["first_point_s"])
            row["note"] += (f": {1e3 * out['overhead_s']:.1f} ms per point (median of {out['points']}; "
                            f"first point of the worker {1e3 * out['first_point_s']:.0f} ms)")
        log(f"{system_name} sweep      {mode:9s} {row['note']}")
        rows.append(row)
    return rows


def convention_references(tools: list[str], spec: dict, timeout: float) -> dict[str, dict]:
    """Final values of jacobi-sampled computed with the time doubles of each peer in ``tools`` that hands
    fmi2DoStep other doubles than the harness (libcosim: h_k = t_k+1 - t_k; Ecos, CoFmuPy: t += h): the fmpy
    loop with that convention (benchmarks.peers.communication_points), run once, unpinned and untimed.  A drive with
    a sensitive trajectory (contact, a dead point) can turn those last bits into 1e-8 of the result."""
    out = {}
    for conv in sorted({CONVENTIONS[t] for t in tools if t in CONVENTIONS}):
        got = run_config(dict(spec, tool=f"reference-{conv}"), "unpinned", timeout)
        if "final" in got:
            out[conv] = got["final"]
    return out


def _check(rows: list[dict], case: str, results: dict, columns: list[str], by_convention: dict | None = None) -> None:
    """Result check of one case: every tool that runs the jacobi-sampled algorithm must give the final values
    of the harness's jacobi-sampled (same mode, else any mode) to RTOL -- a peer that hands fmi2DoStep other
    time doubles, those of jacobi-sampled computed with its doubles (:func:`convention_references`); other
    masters are only reported."""
    refs = [results[k] for k in results if k[0] == REFERENCE]
    by_convention = by_convention or {}
    for row in rows:
        if row["case"] != case or (row["tool"], row["mode"]) not in results:
            continue
        ref = results.get((REFERENCE, row["mode"])) or (refs[0] if refs else None)
        against = REFERENCE
        conv = CONVENTIONS.get(row["tool"])
        if conv in by_convention:
            ref, against = by_convention[conv], f"{REFERENCE} with {row['tool']}'s time doubles"
        if ref is None:
            row["note"] = (row["note"] + "; no jacobi-sampled reference to check against").lstrip("; ")
            continue
        scales = {c: 1e-12 + 1e-6 * max(abs(r[c]) for r in refs or [ref]) for c in columns}
        dev = compare(results[(row["tool"], row["mode"])], ref, scales)
        row["max_rel_deviation"] = dev
        if row["tool"] in SAME_ALGORITHM:
            row["same_result"] = bool(dev <= RTOL)
            if not row["same_result"]:
                row["note"] = (row["note"] + f"; RESULT DIFFERS from {against} ({dev:.3g})").lstrip("; ")
        else:
            row["same_result"] = "n/a (other algorithm)"


def _ratios(rows: list[dict]) -> None:
    """ratio_harness_to_tool: harness jacobi-sampled cost / this tool's cost, same case and mode."""
    base = {(r["case"], r["mode"]): r["us_per_fmu_step"] for r in rows
            if r["tool"] == REFERENCE and "us_per_fmu_step" in r}
    for r in rows:
        b = base.get((r["case"], r["mode"]))
        if b is not None and "us_per_fmu_step" in r:
            r["ratio_harness_to_tool"] = b / r["us_per_fmu_step"]


def targets(rows: list[dict]) -> list[tuple[str, bool | None, str]]:
    """(target, met (None: not measured), evidence) for each target (the goals above)."""
    cost = {(r["case"], r["tool"], r["mode"]): r["us_per_fmu_step"] for r in rows if "us_per_fmu_step" in r}
    peers = ("libcosim", "ecos", "cofmupy")
    out = []
    ring = {t: cost.get(("ring", t, "pinned")) for t in TOOLS}
    h = ring.get(REFERENCE)
    measured = {t: v for t, v in ring.items() if t in peers and v is not None}
    if h is not None and measured:
        out.append(("ring pinned: harness faster than every peer", all(h < v for v in measured.values()),
                    ", ".join(f"{t} {v / h:.2f}x the harness" for t, v in measured.items())))
    else:
        out.append(("ring pinned: harness faster than every peer", None, "not measured"))
    f, plain = ring.get("fmpy"), ring.get(PLAIN_FMI)
    out.append(("ring pinned: harness on its plain FMI path within 1.3x of the fmpy floor",
                None if plain is None or f is None else plain <= 1.3 * f,
                "not measured" if plain is None or f is None else f"{PLAIN_FMI}/fmpy = {plain / f:.2f}"
                + (f", {PLAIN_FMI}/ctypes floor = {plain / ring['ctypes']:.2f}" if ring.get("ctypes") else "")))
    for case in CASES:
        if case == "ring":
            continue
        h = cost.get((case, REFERENCE, "pinned"))
        measured = {t: cost[(case, t, "pinned")] for t in peers if (case, t, "pinned") in cost}
        what = f"{case} pinned: harness faster than the fastest peer"
        if h is None or not measured:
            out.append((what, None, "not measured"))
            continue
        best = min(measured, key=measured.get)
        out.append((what, h < measured[best], f"fastest peer {best}: harness/{best} = {h / measured[best]:.2f}"
                    + ("; against Ecos by part in CPU time, with the floor: python -m benchmarks.step_parts"
                       if best == "ecos" else "")))
    for r in rows:
        if r.get("kind") == "scene" and "realtime_factor" in r:
            out.append((f"{REALTIME_SYSTEM} default scene >= {SCENE_GOAL:g}x faster than real time ({r['mode']})",
                        r["realtime_factor"] >= SCENE_GOAL, r["note"]))
    for name, goal in DECLARED_GOALS.items():
        for mode in MODES:
            r = next((r for r in rows if r.get("kind") == "experiment" and r["mode"] == mode
                      and r["case"] == f"{name} (experiment)"), None)
            if r is None:
                continue
            what = f"{name} declared model >= {goal:g}x real time ({mode})"
            floors = [f"{f['realtime_factor']:.3g}x with free {f['kind'].removeprefix('floor-')}" for f in rows
                      if f.get("system") == name and f["mode"] == mode and "realtime_factor" in f]
            note = r.get("note", "") + (f"; at most {', '.join(floors)}" if floors else "")
            out.append((what, None, note) if "realtime_factor" not in r
                       else (what, r["realtime_factor"] >= goal, note))
    for r in rows:
        if r.get("kind") == "sweep":
            what = f"sweep point overhead of a warm worker < {1e3 * SWEEP_GOAL:g} ms ({r['mode']})"
            out.append((what, None, r.get("note", "")) if "overhead_s" not in r
                       else (what, r["overhead_s"] < SWEEP_GOAL, r.get("note", "")))
    return out


def write_csv(rows: list[dict], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in FIELDS})
    return path


def chart(rows: list[dict], path: Path) -> list[Path]:
    """Grouped bars: cost per FMU-step [us] per case and tool (pinned if measured, else unpinned)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mode = "pinned" if any(r["mode"] == "pinned" and "us_per_fmu_step" in r for r in rows) else "unpinned"
    data = [r for r in rows if r["mode"] == mode and "us_per_fmu_step" in r and r["step"] is not None]
    cases = list(dict.fromkeys(r["case"] for r in data))
    tools = [t for t in TOOLS if any(r["tool"] == t for r in data)]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(cases) + 2), 4.2))
    width = 0.8 / max(1, len(tools))
    for j, tool in enumerate(tools):
        xs, ys = [], []
        for i, case in enumerate(cases):
            v = next((r["us_per_fmu_step"] for r in data if r["case"] == case and r["tool"] == tool), None)
            if v is not None:
                xs.append(i + (j - (len(tools) - 1) / 2) * width)
                ys.append(v)
        label = tool if tool not in HARNESS_TOOLS else f"harness {tool}"
        ax.bar(xs, ys, width, label=label)
    ax.set_xticks(range(len(cases)), cases)
    ax.set_yscale("log")
    ax.set_ylabel("wall time per FMU-step [us]")
    ax.set_title(f"Co-simulation cost per FMU-step ({mode}; lower is better)")
    ax.legend(fontsize=7, ncol=3)
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path, dpi=120)


def report(rows: list[dict], log=print) -> None:
    log("")
    w = max([24] + [len(r["case"]) for r in rows])
    log(f"{'case':{w}s} {'mode':9s} {'tool':15s} {'us/FMU-step':>12s} {'harness/tool':>12s}  result")
    for r in rows:
        cost = f"{r['us_per_fmu_step']:12.2f}" if "us_per_fmu_step" in r else f"{'-':>12s}"
        ratio = f"{r['ratio_harness_to_tool']:12.2f}" if "ratio_harness_to_tool" in r else f"{'-':>12s}"
        same = r.get("same_result", "")
        log(f"{r['case']:{w}s} {r['mode']:9s} {r['tool']:15s} {cost} {ratio}  {same} {r['note']}".rstrip())
    log("")
    for what, met, evidence in targets(rows):
        flag = "n/a " if met is None else ("MET " if met else "MISS")
        log(f"[{flag}] {what}: {evidence}")


def output_paths(quick: bool, out: Path | None, chart_path: Path | None) -> tuple[Path, Path]:
    """(folder of the CSV, chart path).  A full run's chart is the README's (docs/images/benchmark.png, tracked);
    a quick run's timings are meaningless, so by default it writes beside its own CSV and never over it."""
    out = out if out is not None else ROOT / "results" / ("benchmark-quick" if quick else "benchmark")
    if chart_path is None:
        chart_path = out / "benchmark.png" if quick else ROOT / "docs" / "images" / "benchmark.png"
    return out, chart_path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny sizes (smoke test; timings meaningless)")
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma list of {', '.join(CASES)}")
    ap.add_argument("--tools", default=",".join(TOOLS), help=f"comma list of {', '.join(TOOLS)}")
    ap.add_argument("--modes", default=",".join(MODES), help="pinned, unpinned or both")
    ap.add_argument("--out", type=Path, default=None,
                    help="folder of the CSV and SSPs (default: results/benchmark; with --quick "
                         "results/benchmark-quick)")
    ap.add_argument("--chart", type=Path, default=None,
                    help="bar chart path (.png; an .svg is written beside it; default: docs/images/benchmark.png, "
                         "with --quick OUT/benchmark.png)")
    ap.add_argument("--no-chart", action="store_true")
    ap.add_argument("--no-realtime", action="store_true",
                    help=f"skip the real-time runs ({REALTIME_SYSTEM}'s default scene, the declared models of "
                         f"{', '.join(DECLARED_GOALS)}) and the sweep's per-point overhead")
    ap.add_argument("--timeout", type=float, default=1800.0, help="per configuration [s]")
    ap.add_argument("--no-coupling", action="store_true",
                    help="skip the coupling goals (benchmarks.coupling: the largest steps at each drive's declared "
                         "accuracy, against the peers)")
    ap.add_argument("--no-batch", action="store_true",
                    help="skip the batches of variants (benchmarks.batch: the per-variant cost at 1, 10, 100 and 1000 "
                         "variants of each drive against one run per variant, the 50-point feeder sweep against "
                         "OMSimulator)")
    ap.add_argument("--batch-only", action="store_true", help="run only the batches of variants (benchmarks.batch)")
    args = ap.parse_args(argv)
    args.out, args.chart = output_paths(args.quick, args.out, args.chart)
    if args.batch_only:
        from benchmarks import batch

        batch.run(args.out, args.quick, args.timeout)
        return 0
    cases = _csv_list(args.cases, CASES, "cases")
    tools = _csv_list(args.tools, TOOLS, "tools")
    modes = _csv_list(args.modes, MODES, "modes")
    rows = run_all(cases, tools, modes, args.quick, args.out, args.timeout, not args.no_realtime)
    path = write_csv(rows, args.out / "benchmark.csv")
    report(rows)
    if not (args.no_realtime or args.no_coupling):
        from benchmarks import coupling

        lines = coupling.goal_lines(args.quick, args.timeout, out=args.out)
        for what, met, evidence in lines:
            print(f"[{'n/a ' if met is None else ('MET ' if met else 'MISS')}] {what}: {evidence}")
        print(f"wrote {coupling.write(lines, args.out / 'coupling_goals.csv')}")
    if not args.no_batch:
        from benchmarks import batch

        batch.run(args.out, args.quick, args.timeout)
    print(f"\nwrote {path}")
    if not args.no_chart:
        print("chart " + ", ".join(str(p) for p in chart(rows, args.chart)))
    if args.quick:
        print("--quick: tiny sizes, the timings mean nothing; docs/images/benchmark.png is left as it was")
    bad = [r for r in rows if r.get("same_result") is False]
    return 1 if bad else 0
