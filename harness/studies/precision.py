"""Work-precision study of a system: ``python -m harness study precision SYSTEM``.

The study runs a grid of co-simulation methods (master x extrapolation order x step control) at several
step sizes (fixed step) or tolerances (variable step: ``richardson``, ``ecco``), measures each run's wall
time and its error against the monolithic reference (:func:`harness.studies.reference.reference`, the same
equations as one ODE integrated by Radau to rtol 1e-9), and writes

* ``<out>/precision_<system>.csv``: one row per run and compared variable (the reference itself is the row
  with ``master = "reference"``): the method, step/tolerance, wall time, accepted/rejected steps, whether it
  completed, and the metrics of :mod:`harness.studies.metrics` (max / RMS, absolute / relative).  ``quantity`` is
  True on the rows of the system's quantity of interest.
* ``<out>/precision_<system>.png`` / ``.svg``: the work-precision chart, log-log error of the quantity of
  interest (``--metric``, default ``max_abs``) versus wall time, one line per method, and the reference's own
  cost as a vertical line.

Choices:

* Wall time is the whole :func:`harness.simulate` call (loading and instantiating the FMUs included), and for
  the reference the whole ``reference()`` call (assembling the models, integrating, sampling the grid), so
  both are what a user waits for.  On a shared machine it is noisy (a few ten per cent).
* The reference is sampled on the finest fixed step of the grid (``reference_step``): fixed-step results are
  compared at exactly its grid points; variable-step results at their own communication points, with the
  reference interpolated linearly (error ~ h_ref^2/8 * |x''|, negligible against coupling errors).
* A run that stops early (blow-up, FMU error) is kept in the CSV with ``complete = False`` and no metrics,
  and is left out of the chart (the legend counts the failures of each method).
* Variable-step methods start from the finest fixed step; their step lies in [step/1000, 100*step]
  (:class:`harness.master.stepcontrol.StepOptions` defaults).

The quantity of interest of each system and the study's default grid are declared with the system
(``System.precision``, a :class:`harness.specs.PrecisionSpec` in ``systems/<name>.py``).
"""
from __future__ import annotations

import itertools
import math
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from harness.reporting.charts import save_figure
from harness.run import declared
from harness.specs import PrecisionSpec
from harness.studies.metrics import METRICS, error_metrics
from harness.studies.trial import StudyInterrupted, keep_interrupted, quiet_simulate, write_complete


PRECISION: dict[str, PrecisionSpec] = declared("precision")
"""System name -> its :class:`~harness.specs.PrecisionSpec`, as declared in ``systems/<name>.py``."""

DEFAULT_MASTERS = ("jacobi", "gauss-seidel")
DEFAULT_ORDERS = (0, 1, 2)
DEFAULT_CONTROLS = ("none", "richardson", "ecco")
QUICK = dict(masters=("jacobi",), orders=(0, 1), step_controls=("none", "ecco"), n_steps=2, n_tolerances=2)


def precision_spec(system) -> PrecisionSpec:
    """The :class:`PrecisionSpec` of a system (its ``precision`` field, else :data:`PRECISION` by name)."""
    spec = getattr(system, "precision", None)
    if isinstance(spec, PrecisionSpec):
        return spec
    if system.name not in PRECISION:
        raise ValueError(f"system {system.name!r} has no precision quantity: declare precision=PrecisionSpec(...) "
                         f"in systems/{system.name}.py (known: {', '.join(sorted(PRECISION))})")
    return PRECISION[system.name]


def _positive_list(name: str, values) -> list[float]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise ValueError(f"{name} = {v!r} is not admissible: must be a positive number")
        out.append(float(v))
    if not out:
        raise ValueError(f"{name} is empty: give at least one value")
    return sorted(set(out))


@dataclass
class Study:
    """Result of :func:`precision_study`: the long ``table`` (CSV rows), the spec and the reference cost."""
    system: str
    spec: PrecisionSpec
    table: pd.DataFrame
    reference_time: float
    reference_step: float
    stop_time: float
    files: list[Path] = field(default_factory=list)

    def quantity_rows(self) -> pd.DataFrame:
        t = self.table
        return t[t["quantity"] & (t["master"] != "reference")]


def methods(masters, orders, step_controls) -> list[tuple[str, int, str]]:
    """The method grid: (master, extrapolation order, step control)."""
    return list(itertools.product(masters, orders, step_controls))


def precision_study(system, stop_time: float | None = None, steps=None, tolerances=None,
                    masters=DEFAULT_MASTERS, orders=DEFAULT_ORDERS, step_controls=DEFAULT_CONTROLS,
                    parameters: dict | None = None, reference_step: float | None = None,
                    reference_options: dict | None = None, progress=None) -> Study:
    """Run the grid and measure it (module docstring).  ``progress``: callable taking one line of text."""
    from harness.master import MASTERS
    from harness.studies.reference import component_classes, reference
    from harness.run import load
    from harness.master.stepcontrol import STEP_CONTROLS

    system = load(system)
    spec = precision_spec(system)
    stop_time = float(stop_time if stop_time is not None else spec.stop_time)
    if not (math.isfinite(stop_time) and stop_time > 0):
        raise ValueError(f"stop_time = {stop_time!r} is not admissible: must be a positive number [s]")
    steps = _positive_list("steps", spec.steps if steps is None else steps)
    tolerances = _positive_list("tolerances", spec.tolerances if tolerances is None else tolerances)
    for m in masters:
        if m not in MASTERS:
            raise ValueError(f"master = {m!r} is not admissible: must be one of {', '.join(MASTERS)}")
    for o in orders:
        if o not in (0, 1, 2):
            raise ValueError(f"extrapolation order = {o!r} is not admissible: must be 0, 1 or 2")
    for c in step_controls:
        if c not in STEP_CONTROLS:
            raise ValueError(f"step control = {c!r} is not admissible: must be one of none, richardson, ecco")
    if steps[-1] > stop_time:
        raise ValueError(f"steps: {steps[-1]:g} s is longer than stop_time = {stop_time:g} s")
    h_ref = float(reference_step) if reference_step is not None else steps[0]
    say = progress or (lambda s: None)
    columns = spec.compared

    component_classes()  # one-time imports of the component modules: not part of the reference's cost
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy's numerical-Jacobian overflow chatter
        t0 = time.perf_counter()
        ref = reference(system, stop_time=stop_time, step=h_ref, parameters=parameters,
                        **(reference_options or {}))
        t_ref = time.perf_counter() - t0
    missing = [c for c in columns if c not in ref.columns]
    if missing:
        raise ValueError(f"precision column {missing[0]!r} of system {system.name} is not a variable of the "
                         f"reference")
    say(f"{system.name}: reference (step {h_ref:g} s, {stop_time:g} s) in {t_ref:.3g} s")
    rows = [dict(system=system.name, master="reference", extrapolation=-1, step_control="monolithic",
                 step=h_ref, tolerance=math.nan, wall_time=t_ref, stepping_time=math.nan, steps=len(ref) - 1,
                 rejected=0, complete=True, run_error="", variable=c, quantity=c == spec.quantity,
                 **{k: 0.0 for k in METRICS}) for c in columns]
    try:  # Ctrl-C or SIGTERM: the rows finished so far go with the interrupt
        for master, order, control in methods(masters, orders, step_controls):
            variable = STEP_CONTROLS[control].variable
            for value in (tolerances if variable else steps):
                step, tol = (steps[0], value) if variable else (value, None)
                t1 = time.perf_counter()
                df = quiet_simulate(system, stop_time=stop_time, step=step, master=master, extrapolation=order,
                                    step_control=control, tolerance=tol, start_values=parameters, output=columns,
                                    on_error="return")
                wall = time.perf_counter() - t1
                a = df.attrs
                base = dict(system=system.name, master=master, extrapolation=order, step_control=control,
                            step=step if not variable else math.nan, tolerance=tol if variable else math.nan,
                            wall_time=wall, stepping_time=a.get("wall_time", math.nan), steps=a.get("steps", 0),
                            rejected=a.get("rejected", 0), complete=bool(a.get("complete", False)),
                            run_error=a.get("error", ""))
                if base["complete"]:
                    m = error_metrics(df, ref, columns, t_start=spec.t_start or None)
                    for c in columns:
                        rows.append(dict(base, variable=c, quantity=c == spec.quantity,
                                         **{k: float(m.at[c, k]) for k in METRICS}))
                    q = m.loc[spec.quantity]
                    say(f"  {master:12s} order {order} {control:10s} {'tol' if variable else 'step'} "
                        f"{value:<8g} {wall:7.3f} s  {spec.label}: max {q.max_abs:.3e} {spec.unit}, "
                        f"rms rel {q.rms_rel:.2e}")
                else:
                    for c in columns:
                        rows.append(dict(base, variable=c, quantity=c == spec.quantity,
                                         **{k: math.nan for k in METRICS}))
                    say(f"  {master:12s} order {order} {control:10s} {'tol' if variable else 'step'} "
                        f"{value:<8g} {wall:7.3f} s  FAILED: {base['run_error'][:90]}")
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    table = pd.DataFrame(rows)
    return Study(system.name, spec, table, t_ref, h_ref, stop_time)


def method_label(master: str, order: int, control: str) -> str:
    return f"{master}, order {order}" + ("" if control in ("none", "fixed") else f", {control}")


def plot_work_precision(study: Study, path_stem: Path, metric: str = "max_abs") -> list[Path]:
    """Log-log error of the quantity of interest vs wall time: one line per method (points ordered by cost),
    the reference cost as a vertical line.  Writes ``<stem>.png`` and ``<stem>.svg``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if metric not in METRICS:
        raise ValueError(f"metric = {metric!r} is not admissible: must be one of {', '.join(METRICS)}")
    spec = study.spec
    q = study.quantity_rows()
    fig, ax = plt.subplots(figsize=(8.6, 5.2))
    colors = plt.get_cmap("tab10").colors
    styles = {"none": "-", "fixed": "-", "richardson": "--", "ecco": ":"}
    markers = {"jacobi": "o", "jacobi-sampled": "v", "gauss-seidel": "s", "iterative": "D"}
    groups = list(q.groupby(["master", "extrapolation", "step_control"], sort=False))
    plotted = 0
    for k, ((master, order, control), g) in enumerate(groups):
        ok = g[g["complete"] & (g[metric] > 0)].sort_values("wall_time")
        failed = int((~g["complete"]).sum())
        label = method_label(master, order, control) + (f" ({failed} failed)" if failed else "")
        color = colors[(list(DEFAULT_MASTERS).index(master) * 3 + order if master in DEFAULT_MASTERS
                        else 6 + order) % len(colors)]
        if len(ok):
            ax.plot(ok["wall_time"], ok[metric], styles.get(control, "-"), marker=markers.get(master, "o"),
                    color=color, ms=4.5, lw=1.2, label=label, mfc="none" if control != "none" else color)
            plotted += 1
        else:
            ax.plot([], [], styles.get(control, "-"), marker=markers.get(master, "o"), color=color,
                    label=label + " (no point)")
    ax.axvline(study.reference_time, color="k", lw=1.4, ls="-.",
               label=f"monolithic reference (Radau, rtol 1e-9): {study.reference_time:.2g} s")
    ax.set_xscale("log")
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # 0.2, 0.5, 1, 2 s: no crowded minor labels
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    if (q[metric] > 0).any():
        ax.set_yscale("log")
    else:  # every error is zero (e.g. a quantity that stays 0 in a short window): nothing to put on a log axis
        ax.text(0.5, 0.5, f"every {metric} error is zero", transform=ax.transAxes, ha="center")
    unit = "1" if metric.endswith("_rel") else spec.unit
    kind = {"max_abs": "max |error|", "rms_abs": "RMS error", "max_rel": "max |error| / max |ref|",
            "rms_rel": "RMS error / RMS ref"}[metric]
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel(f"{spec.label}: {kind} [{unit}]")
    ax.set_title(f"{study.system}: work-precision, {spec.label} ({spec.quantity}), {study.stop_time:g} s run",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    fig.tight_layout()
    return save_figure(fig, path_stem, dpi=130)


def run_study(system, out_dir: str | Path = "results", metric: str = "max_abs", quick: bool = False,
              **kwargs) -> Study:
    """:func:`precision_study` plus the CSV and the chart in ``out_dir``.  ``quick``: a tiny grid (jacobi,
    orders 0 and 1, fixed step and ecco, the two finest steps/loosest tolerances) unless given explicitly."""
    from harness.run import load

    system = load(system)
    if metric not in METRICS:
        raise ValueError(f"metric = {metric!r} is not admissible: must be one of {', '.join(METRICS)}")
    if quick:
        spec = precision_spec(system)
        for key in ("masters", "orders", "step_controls"):
            if kwargs.get(key) is None:
                kwargs[key] = QUICK[key]
        if kwargs.get("steps") is None:
            kwargs["steps"] = sorted(spec.steps)[: QUICK["n_steps"]]
        if kwargs.get("tolerances") is None:
            kwargs["tolerances"] = sorted(spec.tolerances, reverse=True)[: QUICK["n_tolerances"]]
    kwargs = {k: v for k, v in kwargs.items() if v is not None}
    stem = Path(out_dir) / f"precision_{system.name}"
    study = precision_study(system, **kwargs)
    study.files = [write_complete(study.table, stem.with_suffix(".csv"))] + plot_work_precision(study, stem, metric)
    return study


# -- CLI ----------------------------------------------------------------------------------------------------------
def register_precision(study_subparsers) -> None:
    """Add ``precision`` to an existing ``study`` sub-parser group."""
    p = study_subparsers.add_parser(
        "precision", help="work-precision study against the monolithic reference",
        description="Run a grid of master x extrapolation order x step control x step size (or tolerance), "
                    "measure wall time and the error of the system's quantity of interest against the "
                    "monolithic reference, write precision_<system>.csv and a work-precision chart "
                    "(.png, .svg).")
    p.add_argument("system", help=f"system module name in systems/ ({', '.join(sorted(PRECISION))})")
    p.add_argument("--stop-time", type=float, default=None, help="run length [s] (default: the system's study length)")
    p.add_argument("--steps", type=float, nargs="+", default=None,
                   help="fixed communication steps [s] (default: the system's precision steps)")
    p.add_argument("--tolerances", type=float, nargs="+", default=None,
                   help="tolerances of richardson / ecco (default: the system's, else 1e-2 1e-3 1e-4)")
    p.add_argument("--masters", nargs="+", default=None, help=f"masters (default: {' '.join(DEFAULT_MASTERS)})")
    p.add_argument("--orders", type=int, nargs="+", default=None, choices=(0, 1, 2),
                   help="extrapolation orders (default: 0 1 2)")
    p.add_argument("--step-controls", nargs="+", default=None, choices=("none", "richardson", "ecco"),
                   help="step controls (default: none richardson ecco)")
    p.add_argument("--metric", default="max_abs", choices=METRICS, help="error plotted (default: max_abs)")
    p.add_argument("--reference-step", type=float, default=None,
                   help="sampling step of the reference [s] (default: the finest step)")
    p.add_argument("--quick", action="store_true", help="a tiny grid (jacobi, orders 0 1, none + ecco, 2 points)")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="set a parameter (repeatable)")
    p.add_argument("--out", type=Path, default=Path("results"), help="output folder (default: results/)")
    p.set_defaults(func=precision_cli)


def precision_cli(args) -> int:
    from harness.run import parse_sets

    kwargs = dict(stop_time=args.stop_time, steps=args.steps, tolerances=args.tolerances, masters=args.masters,
                  orders=args.orders, step_controls=args.step_controls, reference_step=args.reference_step,
                  parameters=parse_sets(args.set) or None)
    try:
        study = run_study(args.system, args.out, metric=args.metric, quick=args.quick,
                          progress=lambda s: print(s, file=sys.stderr), **kwargs)
    except StudyInterrupted as e:
        runs = int((e.table["quantity"] & (e.table["master"] != "reference")).sum()) if len(e.table) else 0
        from harness.run import load

        csv = Path(args.out) / f"precision_{load(args.system).name}.csv"   # the study's own CSV (run_study)
        return keep_interrupted(e, csv, f"precision study stopped after {runs} runs beside the reference")
    q = study.quantity_rows()
    ok = q[q["complete"]]
    print(f"{study.system}: {len(q)} runs ({len(q) - len(ok)} failed), reference {study.reference_time:.3g} s; "
          f"wrote {', '.join(str(f) for f in study.files)}")
    return 0


__all__ = ["PrecisionSpec", "PRECISION", "Study", "precision_spec", "precision_study", "plot_work_precision",
           "run_study", "register_precision", "methods", "method_label"]
