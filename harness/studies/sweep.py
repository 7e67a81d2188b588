"""Parameter sweeps: every point a full co-simulation, run on dask.distributed (or serially).

A sweep is described by a YAML or JSON file::

    stop_time: 0.5                      # optional: the system's default experiment otherwise
    step: 1.0e-4
    master: jacobi
    grid:                               # full factorial over the listed values ...
      alpha_c: [0.05, 0.1, 0.2, 0.3]
      rpm: {linspace: [100, 200, 3]}
    sample:                             # ... or a Latin hypercube (not both)
      method: lhs
      n: 20
      seed: 1
      ranges: {rpm: [100, 200]}         # or distributions: {flywheel.d: {normal: [0.03, 3.0e-4]}} (a tolerance
                                        # study; harness.studies.tolerance; --sample N draws N points)
    from_checkpoint: startup.ckpt       # optional: every point continues this checkpoint (harness.run.checkpoint)
    set:                                # parameters of the run, as expressions of the sweep variables
      feeder.w0: "rpm * 2 * pi / 60"    # a sweep variable named like "Instance.param" is set directly
    outputs:                            # quantities of interest (harness.reporting.qoi expressions)
      peak_contact_force: 'peak(r["fourbar.contact_force"])'
    plot:                               # optional: charts written by ``sweep ... --plot DIR``
      x: alpha_c                        # a column of the result (sweep variable, output or set:...)
      y: [peak_contact_force]                 # one row of panels per entry
      hue: [rpm, clearance]             # one line per combination (optional)
      facet: law                        # one column of panels per value (optional)
      reduce: max                       # max | mean | min over the sweep variables not named above
      logx: false                       # logy too
      xspan: [0.3, 0.4, "seed: threshold"]   # optional: a shaded band over x on every panel (label optional)
      units: {rpm: rpm, peak_contact_force: N}   # units of the columns that are no FMU parameter ("1": none)

``python -m harness sweep SYSTEM --grid SPEC --plot DIR`` writes the result file and
``DIR/<spec stem>.png`` + ``.svg`` in one command.  Every axis and legend entry carries its unit: a parameter's
from its FMU, ``wall_time`` in s, any other column from ``plot.units``; a column without one is labelled
``[?]`` and the chart says so, so a missing unit shows instead of passing for a pure number.  Spec errors are
one line naming the file and the key (``spec.yaml: set.flywheel.d: ... uses unknown name 'alpha'``).

Each worker process loads the FMUs itself (pythonfmu FMUs hold the GIL, so threads would not help).  A
failed point is recorded with its error and never aborts the sweep; every foreign FMU (one not built by the
toolkit) runs in a child process of its own (:mod:`harness.fmi.isolated`), so one that crashes or hangs fails
its point, not the worker.  The result is one DataFrame: the sweep
variables, the parameters set, the quantities of interest, ``error`` and ``wall_time``; saved as Parquet
(``.parquet``) or CSV.  ``sweep ... --report FILE.html`` writes one page of it (:func:`report`).

(About 630 lines: the spec's format and its checks, the run of the points, the chart and the page read
together; the pre-run checks and the cluster live in sweep_checks and sweep_cluster.)
"""
from __future__ import annotations

import ast
import difflib
import itertools
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harness.reporting import qoi
from harness.reporting.charts import save_figure
from harness.studies.sweep_checks import SweepError  # noqa: F401 (defined below this module, re-exported)
from harness.studies.trial import one_line, trial


@dataclass
class SweepSpec:
    variables: list[str]
    points: list[dict[str, float]]
    set: dict[str, str] = field(default_factory=dict)
    outputs: dict[str, str] = field(default_factory=dict)
    run: dict = field(default_factory=dict)  # stop_time, step, master, extrapolation
    system: str | None = None  # the system the spec was written for (``system:`` key; informative)
    plot: dict | None = None   # the checked ``plot:`` section
    source: str = "<spec>"
    kind: str = "grid"         # where the variables were declared: "grid" or "sample" (for the messages)
    tolerance: bool = False    # drawn from stated distributions: a tolerance study (its spread is reported)

    def variable_key(self, name: str) -> str:
        """The spec key that declares sweep variable ``name`` (``grid.rpm``, ``sample.ranges.rpm``)."""
        return f"grid.{name}" if self.kind == "grid" else (f"sample.distributions.{name}" if self.tolerance else
                                                           f"sample.ranges.{name}")

    def names_read_by_set(self) -> set[str]:
        """The names the ``set:`` expressions read (sweep variables; ``pi`` and ``sqrt`` left out)."""
        names = set()
        for expr in self.set.values():
            if not isinstance(expr, (int, float)):
                names |= {n.id for n in ast.walk(ast.parse(str(expr), mode="eval")) if isinstance(n, ast.Name)}
        return names - {"pi", "sqrt"}

    def parameters(self, point: dict[str, float]) -> dict[str, float]:
        """The run's parameters for one point: dotted sweep variables plus the ``set`` expressions."""
        params = {k: v for k, v in point.items() if "." in k}
        ns = dict(point)
        ns.update(pi=math.pi, sqrt=math.sqrt)
        for name, expr in self.set.items():
            try:
                params[name] = _arith(expr, ns, f"set.{name}")
            except ZeroDivisionError:
                raise SweepError(f"set.{name}: {expr!r} divides by zero at {point}") from None
        return params


_ARITH_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call, ast.operator,
                ast.unaryop)


def _arith(expr, ns: dict, what: str, check_only: bool = False) -> float:
    if isinstance(expr, (int, float)) and not isinstance(expr, bool):
        return float(expr)
    try:
        tree = ast.parse(str(expr), mode="eval")
    except SyntaxError as e:
        raise SweepError(f"{what}: {expr!r} is not an expression ({e.msg})") from None
    for node in ast.walk(tree):
        if not isinstance(node, _ARITH_NODES):
            raise SweepError(f"{what}: {expr!r} is not an arithmetic expression")
        if isinstance(node, ast.Name) and node.id not in ns:
            known = sorted(n for n in ns if n.isidentifier())
            close = difflib.get_close_matches(node.id, known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SweepError(f"{what}: {expr!r} uses unknown name {node.id!r}{hint}; known names: {', '.join(known)}")
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name) and node.func.id == "sqrt"):
            raise SweepError(f"{what}: {expr!r}: only sqrt(...) may be called")
    if check_only:
        return math.nan
    return float(eval(compile(tree, "<set>", "eval"), {"__builtins__": {}}, ns))  # noqa: S307


def _values(name: str, spec, source: str) -> list[float]:
    """The values of grid variable ``name``: a list of numbers, or ``{linspace|logspace: [lo, hi, n]}`` with a
    whole count n >= 1; a switch (``true``), a text that is no number, a count of 2.7 or 0 is refused."""
    key = f"{source}: grid.{name}"
    if isinstance(spec, list) and spec:
        return [_number(v, key) for v in spec]
    for kind in ("linspace", "logspace"):
        if isinstance(spec, dict) and kind in spec and len(spec) == 1:
            args = spec[kind]
            if not (isinstance(args, list) and len(args) == 3):
                raise SweepError(f"{key}: {kind}: give [lo, hi, n], not {args!r}")
            lo, hi, n = _number(args[0], key), _number(args[1], key), _count(args[2], f"{key}: {kind}")
            if kind == "linspace":
                return [float(v) for v in np.linspace(lo, hi, n)]
            if lo <= 0 or hi <= 0:
                raise SweepError(f"{key}: logspace: lo and hi must be > 0, not {lo!r} and {hi!r}")
            return [float(v) for v in np.logspace(math.log10(lo), math.log10(hi), n)]
    raise SweepError(f"{key}: give a non-empty list, {{linspace: [lo, hi, n]}} or "
                     f"{{logspace: [lo, hi, n]}}, not {spec!r}")


def _number(value, key: str) -> float:
    """A finite number (also written as text, as YAML reads ``1e-3``); a switch is no number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise SweepError(f"{key}: {value!r} is not a number (give numbers; a switch is 0 or 1)")
    try:
        x = float(value)
    except ValueError:
        raise SweepError(f"{key}: {value!r} is not numeric") from None
    if not math.isfinite(x):
        raise SweepError(f"{key}: {value!r} is not a finite number")
    return x


def _count(value, key: str) -> int:
    """A number of points: a whole number >= 1 (``3`` or ``3.0``; 2.7, 0 or ``true`` refused)."""
    whole = (isinstance(value, int) and not isinstance(value, bool)) or (isinstance(value, float)
                                                                          and value.is_integer())
    if not whole:
        raise SweepError(f"{key}: the count {value!r} is not a whole number of points")
    if value < 1:
        raise SweepError(f"{key}: the count {value!r} gives no point: give at least 1")
    return int(value)


PLOT_KEYS = ("x", "y", "hue", "facet", "reduce", "logx", "logy", "xspan", "units")


def _names(value, what: str, source: str) -> list[str]:
    if value is None:
        return []
    vals = [value] if isinstance(value, str) else value
    if not isinstance(vals, list) or not all(isinstance(v, str) for v in vals):
        raise SweepError(f"{source}: {what}: expected a column name or a list of names, not {value!r}")
    return list(vals)


def _check_plot(plot, names: list[str], sets: dict, outputs: dict, source: str) -> dict:
    if not isinstance(plot, dict):
        raise SweepError(f"{source}: plot: expected a mapping with keys {list(PLOT_KEYS)}")
    unknown = set(plot) - set(PLOT_KEYS)
    if unknown:
        raise SweepError(f"{source}: plot: unknown key(s) {sorted(unknown)}; expected some of {list(PLOT_KEYS)}")
    if "x" not in plot or "y" not in plot:
        raise SweepError(f"{source}: plot: needs 'x' and 'y'")
    columns = set(names) | set(outputs) | {f"set:{k}" for k in sets if k not in names} | {"wall_time"}
    out = {"reduce": plot.get("reduce", "max"), "logx": bool(plot.get("logx", False)),
           "logy": bool(plot.get("logy", False))}
    for key in ("x", "y", "hue", "facet"):
        vals = _names(plot.get(key), f"plot.{key}", source)
        for v in vals:
            if v not in columns:
                raise SweepError(f"{source}: plot.{key}: unknown column {v!r}; columns are {sorted(columns)}")
        if key in ("x", "facet") and len(vals) > 1:
            raise SweepError(f"{source}: plot.{key}: give one column, not {vals!r}")
        out[key] = vals
    if out["reduce"] not in ("max", "mean", "min"):
        raise SweepError(f"{source}: plot.reduce: {out['reduce']!r} is not one of max, mean, min")
    out["xspan"] = _check_xspan(plot.get("xspan"), source)
    units = plot.get("units") or {}
    if not isinstance(units, dict) or not all(isinstance(u, str) for u in units.values()):
        raise SweepError(f"{source}: plot.units: expected a mapping column -> unit text, not {units!r}")
    for c in units:
        if c not in columns:
            raise SweepError(f"{source}: plot.units: unknown column {c!r}; columns are {sorted(columns)}")
    out["units"] = dict(units)
    return out


def _check_xspan(span, source: str):
    """``[lo, hi]`` or ``[lo, hi, label]`` with lo < hi: a band shaded over x on every panel."""
    if span is None:
        return None
    ok = isinstance(span, list) and len(span) in (2, 3) and (len(span) == 2 or isinstance(span[2], str))
    try:
        ok = ok and float(span[0]) < float(span[1])
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise SweepError(f"{source}: plot.xspan: {span!r} must be [lo, hi] or [lo, hi, label] with lo < hi")
    return [float(span[0]), float(span[1]), span[2] if len(span) == 3 else None]


def parse_spec(data: dict, source: str = "<spec>", sample: int | None = None) -> SweepSpec:
    """The spec ``data`` read from ``source``; ``sample``: the points to draw from its ``sample:`` section in place
    of its ``n`` (``--sample N``; :mod:`harness.studies.tolerance`)."""
    known = {"grid", "sample", "set", "outputs", "stop_time", "step", "master", "extrapolation", "system", "plot",
             "from_checkpoint"}
    unknown = set(data) - known
    if unknown:
        raise SweepError(f"{source}: unknown key(s) {sorted(unknown)}; expected some of {sorted(known)}")
    if ("grid" in data) == ("sample" in data):
        raise SweepError(f"{source}: give exactly one of 'grid' or 'sample'")
    if sample is not None and "sample" not in data:
        raise SweepError(f"{source}: --sample {sample} draws points from a 'sample:' section, which this spec does not "
                         f"have (its points are a grid)")
    for key in ("grid", "set", "outputs"):
        if key in data and not isinstance(data[key], dict):
            raise SweepError(f"{source}: {key}: expected a mapping, not {type(data[key]).__name__}")
    if "grid" in data:
        names = list(data["grid"])
        if not names:
            raise SweepError(f"{source}: grid: no variables")
        axes = [_values(n, data["grid"][n], source) for n in names]
        points = [dict(zip(names, combo)) for combo in itertools.product(*axes)]
    else:
        from harness.studies.tolerance import sample_points

        names, points = sample_points(data["sample"], source, sample)
    sets = dict(data.get("set") or {})
    ns = {n: 1.0 for n in names}
    ns.update(pi=math.pi, sqrt=math.sqrt)
    for name, expr in sets.items():  # names and syntax now; values per point (a zero division shows there)
        try:
            _arith(expr, ns, name, check_only=True)
        except SweepError as e:
            raise SweepError(f"{source}: set.{e}") from None
    outputs = dict(data.get("outputs") or {})
    for name, expr in outputs.items():
        try:
            qoi.check(str(expr))
        except qoi.QoIError as e:
            raise SweepError(f"{source}: outputs.{name}: {e}") from None
    plot = _check_plot(data["plot"], names, sets, outputs, source) if "plot" in data else None
    run = {k: data[k] for k in ("stop_time", "step", "master", "extrapolation") if k in data}
    tolerance = "sample" in data and isinstance(data["sample"], dict) and "distributions" in data["sample"]
    if "from_checkpoint" in data:   # a shared start-up: every point continues from it, its own values set then
        ckpt = Path(str(data["from_checkpoint"])).expanduser()
        if not ckpt.is_file():
            raise SweepError(f"{source}: from_checkpoint: {ckpt} is no file")
        run["from_checkpoint"] = str(ckpt.resolve())
    return SweepSpec(variables=names, points=points, set=sets, outputs=outputs, run=run,
                     system=data.get("system"), plot=plot, source=source, kind="grid" if "grid" in data else "sample",
                     tolerance=tolerance)


def read_spec(path: str | Path, sample: int | None = None) -> SweepSpec:
    path = Path(path)
    if not path.exists():
        raise SweepError(f"{path}: no such sweep file")
    text = path.read_text()
    try:
        if path.suffix.lower() in (".yaml", ".yml"):
            import yaml

            data = yaml.safe_load(text)
        else:
            data = json.loads(text)
    except Exception as e:
        raise SweepError(f"{path}: cannot parse ({type(e).__name__}: {' '.join(str(e).split())})") from None
    if not isinstance(data, dict):
        raise SweepError(f"{path}: expected a mapping at the top level")
    return parse_spec(data, str(path), sample)


def run_point(system_name, spec: SweepSpec, point: dict[str, float]) -> dict:
    """One co-simulation; never raises: the error is part of the row.  ``system_name``: a system name or file,
    or a :class:`~harness.studies.sweep_cluster.SystemFile` sent by the client (loaded from this worker's copy)."""
    from harness import load
    from harness.studies.sweep_cluster import system_on_worker

    row: dict = dict(point)
    row.update({name: math.nan for name in spec.outputs})  # a failed point keeps every column (NaN)
    t0 = time.perf_counter()
    try:
        params = spec.parameters(point)
        row.update({f"set:{k}": v for k, v in params.items() if k not in point})
        wanted = sorted({c for e in spec.outputs.values() for c in qoi.columns(e)})
        # the failure is recorded in the row, not warned about per point; the run's own message (e.g. the FMU
        # refusing a parameter) is the error, and quantities of a partial run would be misleading (NaN)
        # foreign FMUs run isolated (harness.fmi.isolated): one that crashes or hangs fails its point, not the worker
        settings = {"isolate": True, **spec.run}
        run = trial(load(system_on_worker(system_name)), start_values=params, output=wanted or None, **settings)
        if run.complete:
            for name, expr in spec.outputs.items():
                row[name] = qoi.evaluate(expr, run.result)
        row["error"] = run.error
    except Exception as e:  # recorded, never aborts the sweep
        row["error"] = one_line(e)
    row["wall_time"] = time.perf_counter() - t0
    return row


def run_sweep(system_name: str, spec: SweepSpec, scheduler: str | None = None, workers: int | None = None,
              progress: bool = True, log=None, batch: bool = True) -> pd.DataFrame:
    """Run every point; ``workers=0`` runs serially in this process (same results, bit for bit), ``None``
    starts two local workers, or one on a single CPU.  ``log``: a :class:`harness.studies.sweep_checks.PointLog`
    that receives each point as it finishes and whose points already done are skipped (``--resume``); the
    result then holds them all, in the spec's order.  ``batch``: the points run as batches of variants where the
    batch applies (:mod:`harness.studies.sweep_batch`: each point's own numbers, many points per run; on dask one
    batch per task); False, or a system the batch does not take, runs one point at a time."""
    from harness import load
    from harness.model import resolve_fmu
    from harness.studies import sweep_batch
    from harness.studies.sweep_checks import check_workers, default_workers, point_key
    from harness.studies.sweep_cluster import check_scheduler, payload, shipped

    workers = default_workers() if workers is None else workers
    check_workers(workers, local=scheduler is None)
    for inst in load(system_name).instances:  # build missing FMUs once, before workers race for them
        resolve_fmu(inst.fmu)
    todo = [p for p in spec.points if log is None or point_key(spec, p) not in log.done]
    rows = []

    def finished(row):
        rows.append(row)
        if log is not None:
            log.add(row)

    from harness.run.batch import MIN_VARIANTS

    batched = batch and len(todo) >= MIN_VARIANTS and sweep_batch.refusal(system_name, spec) is None

    def bar(items, total):
        return _progress(items, progress, total=total)

    if workers == 0 and scheduler is None:
        if batched:
            sweep_batch.run(system_name, spec, todo, None, 1, finished, bar)
        else:
            for p in _progress(todo, progress):
                finished(run_point(system_name, spec, p))
    elif todo:
        from dask.distributed import Client, LocalCluster, as_completed

        import logging

        if scheduler:
            check_scheduler(scheduler)   # one line for a service that is no dask scheduler, before dask tries
        # silence_logs: the workers' WARNING lines (e.g. tasks cancelled after Ctrl-C) would follow the
        # sweep's own one-line report; errors still show
        cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                      dashboard_address=":0", silence_logs=logging.ERROR)
        try:
            with Client(scheduler or cluster) as client:
                if batched:
                    n = len(client.scheduler_info().get("workers", {})) or workers or 1
                    sweep_batch.run(system_name, spec, todo, client, n, finished, bar)
                    todo = []
                # a system file goes to the workers as bytes (they may share no disk with this process): as a
                # task of its own that returns them, so the scheduler holds them once and computes them again
                # when the worker holding them is lost (scattered data would be lost with it, and every point
                # after it cancelled: measured)
                system = shipped(system_name)
                if not isinstance(system, str):
                    system = client.submit(payload, system, key=f"system-file-{system.digest[:32]}")
                futures = [client.submit(run_point, system, spec, p, pure=False) for p in todo]   # (none batched)
                try:
                    for fut in _progress(as_completed(futures), progress, total=len(futures)):
                        finished(fut.result())
                finally:
                    client.cancel(futures)
        finally:
            if cluster is not None:
                cluster.close()
    if log is not None:
        return log.frame()
    order = {tuple(float(p[v]) for v in spec.variables): i for i, p in enumerate(spec.points)}
    rows.sort(key=lambda r: order[point_key(spec, r)])
    return pd.DataFrame(rows)


def _progress(items, enabled: bool, total: int | None = None):
    import sys

    if not enabled or not sys.stderr.isatty():
        return items
    from tqdm import tqdm

    return tqdm(items, total=total, desc="sweep", unit="run")


def save(df: pd.DataFrame, out: str | Path) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".parquet":
        try:
            df.to_parquet(out)
        except ImportError:
            raise SweepError(f"{out}: Parquet needs pyarrow (pip install pyarrow); use a .csv name") from None
    else:
        df.to_csv(out, index=False)
    return out


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep", help="parameter sweep on dask.distributed",
        description="Run one co-simulation per point of a sweep spec and write one row per point (sweep "
                    "variables, parameters set, quantities of interest, error, wall_time [s]). The spec, the "
                    "parameters, the quantities, the output format and --workers are checked before the first "
                    "point. Each finished point is appended to OUT.partial.csv at once; a complete sweep "
                    "writes OUT (and OUT's stem.sweep.json, what the sweep was) and removes it, an interrupted one "
                    "(Ctrl-C: exit 130) keeps it, and --resume skips the points it holds. A system file (.ssp, "
                    ".fmu, .py) is sent to the workers, which need not share a disk with this process.")
    p.add_argument("system", help="system module name in systems/ or an .ssp/.ssd file")
    p.add_argument("--grid", required=True, type=Path, metavar="SPEC",
                   help="sweep description (.yaml/.yml/.json; format: module harness.studies.sweep)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of an existing dask scheduler (default: a local cluster of --workers)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local worker processes, an integer from 0 to the number of CPUs (0: run serially here; "
                        "default 2, or 1 on a single CPU)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="result file, .csv or .parquet (default: results/sweep_<system>.csv)")
    p.add_argument("--resume", action="store_true",
                   help="skip the points already in OUT.partial.csv, which must be of the same system, spec and "
                        "settings (a torn last line is run again); on a finished sweep do nothing (default: start "
                        "afresh)")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="also write the charts of the spec's plot section to DIR/<spec stem>.png and .svg "
                        "(default: no charts)")
    p.add_argument("--sample", type=int, default=None, metavar="N",
                   help="draw N points from the spec's sample: section (its ranges, or the distributions of a "
                        "tolerance study, whose spread of each quantity is then reported and written to "
                        "OUT's stem.spread.csv) in place of its n (default: its n)")
    p.add_argument("--no-batch", action="store_true",
                   help="run the points one at a time (default: as batches of variants stepped together wherever "
                        "the drive's FMUs are the toolkit's and the method is jacobi, jacobi-sampled or "
                        "gauss-seidel; the same numbers per point)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE.html",
                   help="write one self-contained HTML page: what was swept, the table of points, the spec's "
                        "chart, the drive and versions; checked before the first point (default: none)")
    p.set_defaults(func=_run_cli)


def _run_cli(args) -> int:
    import sys

    from harness.studies.sweep_checks import (PointLog, default_workers, finished, identity, identity_path,
                                              partial_path, preflight)

    workers = default_workers() if args.workers is None else args.workers
    spec = read_spec(args.grid, getattr(args, "sample", None))
    if args.plot is not None and spec.plot is None:
        raise SweepError(f"{args.grid}: --plot needs a 'plot:' section in the spec")
    out = Path(args.out or Path("results") / f"sweep_{Path(args.system).stem}.csv")
    preflight(args.system, spec, out, workers, local=args.scheduler is None)
    if getattr(args, "report", None) is not None:
        from harness.reporting.htmlreport import check_report_path

        check_report_path(args.report)
    if args.scheduler:
        from harness.studies.sweep_cluster import check_scheduler

        check_scheduler(args.scheduler)   # before the partial file: a wrong address loses and writes nothing
    ident = identity(args.system, spec)
    resume = getattr(args, "resume", False)
    if resume and not partial_path(out).exists() and finished(out, spec, ident):
        print(f"{out}: complete, nothing to do ({len(spec.points)} points; run without --resume to compute "
              f"them again)")
        return 0
    log = PointLog(partial_path(out), spec, resume=resume, identity=ident)
    skipped = len(log.done)
    if log.dropped:
        print(f"warning: {log.path}: {log.dropped} torn or incomplete line(s) dropped; their points run again",
              file=sys.stderr)
    try:
        df = run_sweep(args.system, spec, scheduler=args.scheduler, workers=workers, log=log,
                       batch=not getattr(args, "no_batch", False))
    except KeyboardInterrupt as e:  # Ctrl-C, or SIGTERM as the command line raises it (status 143)
        from harness.run import interruption

        status, how = interruption(e)
        print(f"error: {how}: {len(log.rows)} of {len(spec.points)} points finished and kept in "
              f"{log.path}; rerun with --resume to skip them", file=sys.stderr)
        return status
    out = save(df, out)
    identity_path(out).write_text(json.dumps(ident, indent=1, sort_keys=True) + "\n")
    log.path.unlink(missing_ok=True)
    log.id_path.unlink(missing_ok=True)
    failed = int((df["error"] != "").sum())
    resumed = f" ({skipped} taken from {log.path.name})" if skipped else ""
    print(f"{len(df)} points{resumed}, {failed} failed; wrote {out}")
    if spec.tolerance:
        from harness.studies.tolerance import spread, spread_path, spread_table

        table = spread(df, spec.outputs)
        table.to_csv(spread_path(out))
        print(f"spread of each quantity over the points that ran (wrote {spread_path(out)}):")
        print(spread_table(table))
    paths = None
    if args.plot is not None:
        from harness.studies.sweep_checks import parameter_units

        paths = plot_sweep(df, spec, args.plot / Path(args.grid).stem,
                           title=f"{Path(args.system).stem}: {Path(args.grid).name}",
                           units=parameter_units(args.system, spec))
        print("charts: " + ", ".join(str(p) for p in paths))
    if getattr(args, "report", None) is not None:
        charts = [p for p in paths if p.suffix == ".png"] if paths is not None else None
        print(f"report {report(df, spec, args.report, args.system, charts, result_file=out)}")
    if len(df) and failed == len(df):
        first = df["error"].iloc[0]
        print(f"error: every point failed; the first: {first}", file=sys.stderr)
        return 1
    return 0


ROWS_SHOWN = 400   # a report's table shows at most this many points (the result file holds them all)


def report(df: pd.DataFrame, spec: SweepSpec, path: str | Path, system: str, charts: list[Path] | None = None,
           result_file: str | Path | None = None) -> Path:
    """One self-contained HTML page of a sweep (:mod:`harness.reporting.htmlreport`): what was swept (variables, set
    expressions, quantities of interest, run settings), the table of points, the chart of the spec's ``plot:``
    section (``charts``: PNGs already drawn, else drawn here), the drive as declared and the versions with the
    points' run time; returns its path.  ``system``: the system's name or file, as given to :func:`run_sweep`."""
    from harness.reporting import htmlreport as h
    from harness.run import load

    drive = load(system)
    keep = None
    if charts is None and spec.plot is not None and len(df):
        from harness.studies.sweep_checks import parameter_units

        charts, keep = h.render_charts(lambda d: plot_sweep(df, spec, d / Path(spec.source).stem,
                                                            title=f"{drive.name}: {Path(spec.source).name}",
                                                            units=parameter_units(system, spec)), None)
    try:
        failed = int((df["error"].fillna("").astype(str) != "").sum()) if "error" in df.columns else 0
        page = h.Page(f"{drive.name}: sweep {Path(spec.source).name}",
                      f"{len(df)} points, {failed} failed" + (f"; the result file: {result_file}" if result_file
                                                               else ""))
        values = {v: sorted({float(p[v]) for p in spec.points}) for v in spec.variables}
        what = [[f"{spec.kind} variable", v, ", ".join(f"{x:g}" for x in values[v][:12])
                 + (f" ... ({len(values[v])} values)" if len(values[v]) > 12 else "")] for v in spec.variables]
        what += [["set", k, str(e)] for k, e in spec.set.items()]
        what += [["output", k, str(e)] for k, e in spec.outputs.items()]
        what += [["run", k, str(v)] for k, v in spec.run.items()]
        page.section("What was swept", h.table(["", "name", "values or expression"], what, numeric=set()))
        page.section("Chart", *[h.image(p, f"{drive.name}: {Path(spec.source).name}") for p in charts or []]
                     or [h.para("no chart: the spec has no plot: section" if spec.plot is None else "no chart")])
        shown = df.head(ROWS_SHOWN)
        cut = (f"the first {ROWS_SHOWN} of {len(df)} points (the result file holds them all)"
               if len(df) > ROWS_SHOWN else f"all {len(df)} points")
        page.section("Points", h.para(cut, "note"), h.frame_table(shown.reset_index(drop=True), "point"))
        h.drive_section(page, drive, None, heading="The drive as declared (the sweep sets the values above)")
        total = float(df["wall_time"].sum()) if "wall_time" in df.columns else math.nan
        h.versions_section(page, [("the points' run time, summed", total)])
        return page.write(path)
    finally:
        if keep is not None:
            keep.cleanup()


def plot_sweep(df: pd.DataFrame, spec: SweepSpec, out_stem: str | Path, title: str = "",
               units: dict[str, str] | None = None) -> list[Path]:
    """Charts of a sweep result after the spec's ``plot`` section: a row of panels per ``y``, a column per
    ``facet`` value, a line per ``hue`` combination over ``x``; the sweep variables not named are reduced
    (max/mean/min).  Failed points (NaN) are left out.  ``units``: column -> unit (the parameters' units from
    their FMUs, :func:`harness.studies.sweep_checks.parameter_units`); the spec's ``plot.units`` overrides
    them.  The legend stands to the right of the panels, off the data.  Writes ``<out_stem>.png`` and ``.svg``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pl = spec.plot
    if pl is None:
        raise SweepError(f"{spec.source}: no 'plot:' section")
    x, ys, hue, facet = pl["x"][0], pl["y"], pl["hue"], pl["facet"]
    missing = [c for c in [x, *ys, *hue, *facet] if c not in df.columns]
    if missing:
        raise SweepError(f"{spec.source}: plot: result has no column(s) {missing}")
    known = {"wall_time": "s", **(units or {}), **pl.get("units", {})}
    unknown = sorted({c for c in [x, *ys, *hue, *facet] if not known.get(c)})

    def unit(c: str) -> str:
        return known.get(c) or "?"

    def value(c: str, v) -> str:
        u = unit(c)
        return (f"{v:g}" if isinstance(v, (int, float)) else str(v)) + ("" if u == "1" else f" {u}")

    fvals = sorted(df[facet[0]].dropna().unique()) if facet else [None]
    fig, axes = plt.subplots(len(ys), len(fvals), figsize=(4.2 * len(fvals) + 0.6, 2.6 * len(ys) + 0.8),
                             squeeze=False, sharex=True)
    for j, fv in enumerate(fvals):
        sub = df if fv is None else df[df[facet[0]] == fv]
        groups = sub.groupby(hue, sort=True) if hue else [((), sub)]
        for key, g in groups:
            key = key if isinstance(key, tuple) else (key,)
            label = ", ".join(f"{h} = {value(h, k)}" for h, k in zip(hue, key))
            agg = g.groupby(x, sort=True)[ys].agg(pl["reduce"])
            for i, y in enumerate(ys):
                axes[i][j].plot(agg.index.to_numpy(), agg[y].to_numpy(), marker="o", ms=3, lw=1.0,
                                label=label or None)
        for i, y in enumerate(ys):
            ax = axes[i][j]
            if pl.get("xspan"):
                lo, hi, lab = pl["xspan"]
                ax.axvspan(lo, hi, color="0.85", zorder=0, label=lab if (i, j) == (0, 0) else None)
            ax.set_title(f"{facet[0]} = {value(facet[0], fv)}" if fv is not None else "", fontsize=8)
            ax.set_ylabel(f"{y} [{unit(y)}]", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if pl["logx"]:
                ax.set_xscale("log")
            if pl["logy"]:
                ax.set_yscale("log")
            if i == len(ys) - 1:
                ax.set_xlabel(f"{x} [{unit(x)}]", fontsize=8)
    n_fail = int((df["error"].fillna("").astype(str) != "").sum()) if "error" in df.columns else 0
    rest = [v for v in spec.variables if v not in (x, *hue, *facet)]
    note = f"; {pl['reduce']} over {', '.join(rest)}" if rest else ""
    missing_units = f"\n[?]: no unit declared for {', '.join(unknown)} (plot.units)" if unknown else ""
    fig.suptitle(f"{title}{note}; {len(df)} points, {n_fail} failed{missing_units}", fontsize=9)
    # the legend in rows above the panels, under the title: off the data, and as wide as the figure
    handles, labels = axes[0][0].get_legend_handles_labels()
    height = fig.get_figheight()
    title_h = 0.35 + (0.18 if unknown else 0.0)
    ncol = max(1, min(len(labels), int(fig.get_figwidth() // 3.2)))
    legend_h = 0.17 * -(-len(labels) // ncol) if handles else 0.0
    if handles:
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 1.0 - title_h / height), ncol=ncol,
                   fontsize=7, frameon=False)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - (title_h + legend_h) / height))
    return save_figure(fig, out_stem, dpi=110)
