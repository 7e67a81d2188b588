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
      ranges: {rpm: [100, 200]}
    set:                                # parameters of the run, as expressions of the sweep variables
      feeder.w0: "rpm * 2 * pi / 60"    # a sweep variable named like "Instance.param" is set directly
    outputs:                            # quantities of interest (harness.qoi expressions)
      impact_force: 'peak(r["fourbar.impact_force"])'

Each worker process loads the FMUs itself (pythonfmu FMUs hold the GIL, so threads would not help).  A
failed point is recorded with its error and never aborts the sweep.  The result is one DataFrame: the sweep
variables, the parameters set, the quantities of interest, ``error`` and ``wall_time``; saved as Parquet
(``.parquet``) or CSV.
"""
from __future__ import annotations

import ast
import itertools
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harness import qoi


class SweepError(ValueError):
    pass


@dataclass
class SweepSpec:
    variables: list[str]
    points: list[dict[str, float]]
    set: dict[str, str] = field(default_factory=dict)
    outputs: dict[str, str] = field(default_factory=dict)
    run: dict = field(default_factory=dict)  # stop_time, step, master, extrapolation
    system: str | None = None  # the system the spec was written for (``system:`` key; informative)

    def parameters(self, point: dict[str, float]) -> dict[str, float]:
        """The run's parameters for one point: dotted sweep variables plus the ``set`` expressions."""
        params = {k: v for k, v in point.items() if "." in k}
        ns = dict(point)
        ns.update(pi=math.pi, sqrt=math.sqrt)
        for name, expr in self.set.items():
            params[name] = _arith(expr, ns, name)
        return params


_ARITH_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Name, ast.Load, ast.Call, ast.operator,
                ast.unaryop)


def _arith(expr, ns: dict, what: str) -> float:
    if isinstance(expr, (int, float)):
        return float(expr)
    tree = ast.parse(str(expr), mode="eval")
    for node in ast.walk(tree):
        if not isinstance(node, _ARITH_NODES):
            raise SweepError(f"set {what}: {expr!r} is not an arithmetic expression")
        if isinstance(node, ast.Name) and node.id not in ns:
            raise SweepError(f"set {what}: {expr!r} uses unknown name {node.id!r}")
    return float(eval(compile(tree, "<set>", "eval"), {"__builtins__": {}}, ns))  # noqa: S307


def _values(name: str, spec) -> list[float]:
    if isinstance(spec, list):
        return [float(v) for v in spec]
    if isinstance(spec, dict) and "linspace" in spec:
        lo, hi, n = spec["linspace"]
        return [float(v) for v in np.linspace(lo, hi, int(n))]
    if isinstance(spec, dict) and "logspace" in spec:
        lo, hi, n = spec["logspace"]
        return [float(v) for v in np.logspace(math.log10(lo), math.log10(hi), int(n))]
    raise SweepError(f"grid variable {name}: give a list, {{linspace: [lo, hi, n]}} or {{logspace: [lo, hi, n]}}")


def parse_spec(data: dict, source: str = "<spec>") -> SweepSpec:
    known = {"grid", "sample", "set", "outputs", "stop_time", "step", "master", "extrapolation", "system"}
    unknown = set(data) - known
    if unknown:
        raise SweepError(f"{source}: unknown key(s) {sorted(unknown)}; expected some of {sorted(known)}")
    if ("grid" in data) == ("sample" in data):
        raise SweepError(f"{source}: give exactly one of 'grid' or 'sample'")
    if "grid" in data:
        names = list(data["grid"])
        axes = [_values(n, data["grid"][n]) for n in names]
        points = [dict(zip(names, combo)) for combo in itertools.product(*axes)]
    else:
        s = data["sample"]
        if not isinstance(s, dict) or "n" not in s or not isinstance(s.get("ranges"), dict) or not s["ranges"]:
            raise SweepError(f"{source}: sample needs 'n' and 'ranges: {{name: [lo, hi], ...}}'")
        for n_, r_ in s["ranges"].items():
            if not (isinstance(r_, (list, tuple)) and len(r_) == 2 and float(r_[0]) < float(r_[1])):
                raise SweepError(f"{source}: sample range {n_} = {r_!r} must be [lo, hi] with lo < hi")
        if s.get("method", "lhs") != "lhs":
            raise SweepError(f"{source}: sample method {s.get('method')!r} is not supported (lhs)")
        from scipy.stats import qmc

        names = list(s["ranges"])
        lo = np.array([s["ranges"][n][0] for n in names], float)
        hi = np.array([s["ranges"][n][1] for n in names], float)
        unit = qmc.LatinHypercube(d=len(names), seed=s.get("seed", 0)).random(int(s["n"]))
        points = [dict(zip(names, map(float, row))) for row in qmc.scale(unit, lo, hi)]
    for name, expr in data.get("outputs", {}).items():
        qoi.check(expr)
    run = {k: data[k] for k in ("stop_time", "step", "master", "extrapolation") if k in data}
    return SweepSpec(variables=names, points=points, set=dict(data.get("set", {})),
                     outputs=dict(data.get("outputs", {})), run=run, system=data.get("system"))


def read_spec(path: str | Path) -> SweepSpec:
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
        raise SweepError(f"{path}: cannot parse ({type(e).__name__}: {e})") from None
    if not isinstance(data, dict):
        raise SweepError(f"{path}: expected a mapping at the top level")
    return parse_spec(data, str(path))


def run_point(system_name: str, spec: SweepSpec, point: dict[str, float]) -> dict:
    """One co-simulation; never raises: the error is part of the row."""
    from harness import load, simulate

    import warnings

    row: dict = dict(point)
    row.update({name: math.nan for name in spec.outputs})  # a failed point keeps every column (NaN)
    t0 = time.perf_counter()
    try:
        params = spec.parameters(point)
        row.update({f"set:{k}": v for k, v in params.items() if k not in point})
        wanted = sorted({c for e in spec.outputs.values() for c in qoi.columns(e)})
        with warnings.catch_warnings():  # the failure is recorded in the row, not warned about per point
            warnings.simplefilter("ignore")
            df = simulate(load(system_name), parameters=params, outputs=wanted or None, **spec.run)
        if df.attrs.get("complete") is False:
            # the run's own message (e.g. the FMU refusing a parameter) is the error; quantities of a partial
            # run would be misleading, so they stay NaN (evaluating them would also replace the message)
            row["error"] = (str(df.attrs.get("error") or "incomplete run").splitlines() or ["incomplete run"])[0]
        else:
            for name, expr in spec.outputs.items():
                row[name] = qoi.evaluate(expr, df)
            row["error"] = ""
    except Exception as e:  # recorded, never aborts the sweep
        row["error"] = f"{type(e).__name__}: {e}".splitlines()[0]
    row["wall_time"] = time.perf_counter() - t0
    return row


def run_sweep(system_name: str, spec: SweepSpec, scheduler: str | None = None, workers: int = 2,
              progress: bool = True) -> pd.DataFrame:
    """Run every point; ``workers=0`` runs serially in this process (same results, bit for bit)."""
    from harness import load
    from harness.model import resolve_fmu

    for inst in load(system_name).instances:  # build missing FMUs once, before workers race for them
        resolve_fmu(inst.fmu)
    if workers == 0 and scheduler is None:
        rows = [run_point(system_name, spec, p) for p in _progress(spec.points, progress)]
    else:
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                      dashboard_address=None)
        with Client(scheduler or cluster) as client:
            futures = [client.submit(run_point, system_name, spec, p, pure=False) for p in spec.points]
            index = {f.key: i for i, f in enumerate(futures)}
            rows = [None] * len(futures)
            for fut in _progress(as_completed(futures), progress, total=len(futures)):
                rows[index[fut.key]] = fut.result()
        if cluster is not None:
            cluster.close()
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
    p = subparsers.add_parser("sweep", help="parameter sweep on dask.distributed")
    p.add_argument("system", help="system module name in systems/ or an .ssp/.ssd file")
    p.add_argument("--grid", required=True, type=Path, help="sweep description (.yaml/.yml/.json)")
    p.add_argument("--scheduler", default=None, help="address of an existing dask scheduler")
    p.add_argument("--workers", type=int, default=2, help="local worker processes (0: run serially)")
    p.add_argument("--out", type=Path, default=None, help="result file (.parquet or .csv)")
    p.set_defaults(func=_run_cli)


def _run_cli(args) -> int:
    spec = read_spec(args.grid)
    df = run_sweep(args.system, spec, scheduler=args.scheduler, workers=args.workers)
    out = save(df, args.out or Path("results") / f"sweep_{Path(args.system).stem}.csv")
    failed = int((df["error"] != "").sum())
    print(f"{len(df)} points, {failed} failed; wrote {out}")
    return 0
