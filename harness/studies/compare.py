"""Two or more designs of one drive side by side: ``python -m harness compare DRIVE --variant "LABEL: I.p=V ..."``
and :func:`compare`.

A variant is a label and the parameter values it changes (``"heavy flywheel: flywheel.J_flywheel=16"``; no
values: the drive as declared), or a saved result file (``"measured: results/bed_drive.csv"``, a CSV or Parquet
written by ``run --out``).  Every variant is run with the same method and stop time (the drive's default
experiment unless given); the engineering quantities of each (:mod:`harness.reporting.quantities`) go into one table with,
beside each variant after the first, its difference from the first and the percent change.  ``--plot DIR``
draws the drive's cycle-chart signals of every variant over its last steady machine cycle, overlaid against the
crank angle (``DIR/<drive>_compare.png``).

Refused in one line before any run: fewer than two variants, a label given twice, a variant that is not
``LABEL: ...``, a parameter that is not ``Instance.parameter=VALUE`` or that the drive's FMUs do not have (with
the nearest names), a result file that does not exist.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from harness.errors import SystemDescriptionError


@dataclass(frozen=True)
class Variant:
    """A design: ``label``, the parameter values it changes (``Instance.parameter`` -> value) or a saved
    ``result`` file."""
    label: str
    start_values: dict = field(default_factory=dict)
    result: Path | None = None


def parse_variant(text: str) -> Variant:
    """``"LABEL: I.p=V I.p=V"`` or ``"LABEL: FILE.csv"`` (or .parquet) as a :class:`Variant`."""
    from harness.run import parse_sets

    label, colon, rest = str(text).partition(":")
    if not colon or not label.strip():
        raise SystemDescriptionError(f"--variant {text!r}: expected 'LABEL: Instance.param=VALUE ...' or 'LABEL: "
                                     f"FILE.csv'")
    items = rest.split()
    if len(items) == 1 and "=" not in items[0]:
        path = Path(items[0])
        if path.suffix.lower() not in (".csv", ".parquet"):
            raise SystemDescriptionError(f"--variant {text!r}: {items[0]} is neither Instance.param=VALUE nor a "
                                         f"result file "
                                         f"(.csv, .parquet)")
        if not path.is_file():
            raise SystemDescriptionError(f"--variant {text!r}: result file {path} does not exist")
        return Variant(label.strip(), result=path)
    return Variant(label.strip(), parse_sets(items))


def check(system, variants: list[Variant]) -> None:
    """The variants' rules (module docstring), before any run."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu
    from harness.run import split_parameters

    if len(variants) < 2:
        raise SystemDescriptionError(f"compare {system.name}: give at least two variants (--variant 'LABEL: I.p=V "
                                     f"...'; a "
                                     f"variant with no values is the drive as declared)")
    seen = set()
    for v in variants:
        if v.label in seen:
            raise SystemDescriptionError(f"compare {system.name}: variant label {v.label!r} is given twice")
        seen.add(v.label)
    mds = {inst.name: model_description(resolve_fmu(inst.fmu)) for inst in system.instances}
    for v in variants:
        params = split_parameters(system, v.start_values)      # an unknown instance: one line, nearest names
        system.validate(mds, {f"{i}.{k}": x for i, d in params.items() for k, x in d.items()
                              if f"{i}.{k}" in v.start_values})


@dataclass
class Comparison:
    """The variants' results (label -> DataFrame) and their quantities side by side: :meth:`frame`, :meth:`table`,
    :meth:`plot`."""
    system: object
    results: dict

    def frame(self) -> pd.DataFrame:
        """One row per quantity: its unit, each variant's value, and for each variant after the first its
        difference from the first and the change in percent of the first's value (None where either has none,
        or the first's is 0)."""
        labels = list(self.results)
        tables = {lab: df.attrs["quantities"] for lab, df in self.results.items()}
        names: list[str] = []
        for q in tables.values():
            names += [r.name for r in q.rows if r.name not in names]
        rows = []
        for name in names:
            row = {"quantity": name, "unit": ""}
            values = {}
            for lab in labels:
                q = tables[lab]
                r = q.row(name) if name in q else None
                row["unit"] = row["unit"] or (r.unit if r is not None else "")
                values[lab] = r.value if r is not None and isinstance(r.value, (int, float)) else None
                row[lab] = values[lab] if values[lab] is not None else (r.value if r is not None else None)
            base = values[labels[0]]
            for lab in labels[1:]:
                x = values[lab]
                row[f"{lab} - {labels[0]}"] = None if base is None or x is None else x - base
                row[f"{lab} change %"] = (None if base in (None, 0.0) or x is None else 100.0 * (x - base) / abs(base))
            rows.append(row)
        return pd.DataFrame(rows).set_index("quantity")

    def table(self) -> str:
        """The frame as text, with the variants' definitions above it."""
        lines = [f"{self.system.name}: {len(self.results)} variants"]
        for lab, df in self.results.items():
            changed = df.attrs.get("variant") or "the drive as declared"
            lines.append(f"  {lab}: {changed}")
        f = self.frame()

        def fmt(v):
            if v is None or (isinstance(v, float) and not math.isfinite(v)):
                return "-"
            if isinstance(v, (list, tuple)):
                return ", ".join(fmt(x) for x in v) or "none"
            if isinstance(v, (int, float)):
                return f"{v:.4g}"
            return str(v)

        cells = [[name, *(fmt(x) for x in row)] for name, row in zip(f.index, f.itertuples(index=False))]
        head = ["quantity", *f.columns]
        width = [max(len(str(c[i])) for c in cells + [head]) for i in range(len(head))]
        lines.append("  " + "  ".join(h.ljust(w) if i < 2 else h.rjust(w) for i, (h, w) in enumerate(zip(head, width))))
        lines.append("  " + "-" * (sum(width) + 2 * (len(width) - 1)))
        for c in cells:
            lines.append("  " + "  ".join(x.ljust(w) if i < 2 else x.rjust(w) for i, (x, w) in enumerate(zip(c, width))))
        return "\n".join(lines)

    def plot(self, out_dir: str | Path) -> list[Path]:
        """The drive's cycle-chart signals of every variant over its last steady machine cycle against the crank
        angle, overlaid (``<out_dir>/<drive>_compare.png`` and ``.svg``); [] when the drive declares no crank
        angle or no variant completed a cycle."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from harness.reporting.chartdraw import save_figure, values as _values
        from harness.reporting.charts import last_revolution

        spec = getattr(self.system, "chart", None)
        if spec is None or spec.crank_angle is None:
            return []
        panels = [p for p in spec.panels if p.cycle]
        cycles = {}
        for lab, df in self.results.items():
            if spec.crank_angle in df:
                found = last_revolution(df[spec.crank_angle].to_numpy(dtype=float), spec.cycle_origin,
                                        spec.cycle_angle)
                if found is not None:
                    cycles[lab] = found
        if not cycles or not panels:
            return []
        cols = 2
        rows = -(-len(panels) // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(13, 2.6 * rows + 0.8), squeeze=False)
        for ax, panel in zip(axes.flat, panels):
            unit = "-"
            for lab, (mask, _k, x) in cycles.items():
                df = self.results[lab]
                units = df.attrs.get("units") or {}
                for j, column in enumerate(panel.columns):
                    if column not in df:
                        continue
                    y, unit = _values(df, column, units)
                    name = panel.labels[j] if panel.labels else column
                    ax.plot(x, y[mask], lw=0.9, label=f"{lab}" + (f": {name}" if len(panel.columns) > 1 else ""))
            ax.set_title(f"{panel.title} [{unit}]", fontsize=8.5, loc="left")
            ax.set_xlim(0.0, 360.0)
            ax.set_xticks(np.arange(0.0, 361.0, 45.0))
            ax.set_xlabel("crank angle [deg]" + (f" from the {spec.origin_name}" if spec.origin_name else ""),
                          fontsize=7)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
        for ax in list(axes.flat)[len(panels):]:
            ax.set_visible(False)
        fig.suptitle(f"{self.system.name}: {', '.join(cycles)} over their last machine cycle", fontsize=9)
        fig.tight_layout()
        return [p for p in save_figure(fig, Path(out_dir) / f"{self.system.name}_compare", dpi=110)
                if p.suffix == ".png"]


    def report(self, path: str | Path, charts: list[Path] | None = None) -> Path:
        """One self-contained HTML page of the comparison (:mod:`harness.reporting.htmlreport`): the variants, the
        side-by-side table, the overlaid chart (``charts``: PNGs already drawn, else drawn here), the drive as
        declared, the method and the versions; returns its path."""
        from harness.reporting import htmlreport as h

        keep = None
        if charts is None:
            charts, keep = h.render_charts(self.plot, None)
        try:
            first = next(iter(self.results.values()))
            page = h.Page(f"{self.system.name}: {len(self.results)} variants compared",
                          "every variant run with the same method and stop time; differences from the first")
            page.section("Variants", h.table(["label", "what it changes", "points", "to t [s]", "stepping [s]"],
                                             [[lab, df.attrs.get("variant", ""), len(df),
                                               float(df.index[-1]) if len(df) else 0.0,
                                               df.attrs.get("wall_time")] for lab, df in self.results.items()],
                                             numeric={2, 3, 4}))
            for lab, verdicts in (getattr(self, "verdicts", None) or {}).items():
                h.limits_section(page, verdicts, f"variant {lab}")
            page.section("Engineering quantities side by side",
                         h.para(_heading_line(first)), h.frame_table(self.frame(), "quantity"))
            page.section("Charts", *[h.image(p, f"{self.system.name}: the variants over their last machine cycle")
                                     for p in charts] or [h.para("no chart: the drive declares no crank angle or no "
                                                                 "variant completed a machine cycle")])
            h.drive_section(page, self.system, None, heading="The drive as declared (the variants change the "
                                                             "values above)")
            h.method_section(page, self.system, first.attrs)
            h.versions_section(page, [(f"stepping, {lab}", df.attrs.get("wall_time", "saved result"))
                                      for lab, df in self.results.items()])
            return page.write(path)
        finally:
            if keep is not None:
                keep.cleanup()


def _heading_line(df) -> str:
    q = df.attrs.get("quantities")
    return q.heading().splitlines()[0] + " (the first variant's; each variant's own steady cycles)" if q else ""


def compare(system, variants, batch: bool = True, **options) -> Comparison:
    """Run every variant of ``system`` (a name in systems/ or a System; variants as :class:`Variant` or
    ``"LABEL: ..."`` strings) with :func:`harness.run.simulate` and ``options`` (the same for all) and return the
    :class:`Comparison`.  A variant's ``start_values`` go over ``options["start_values"]``.  ``batch``: the variants
    that change parameters run together as one batch where the batch applies and they are enough to pay for it
    (:data:`harness.run.batch.MIN_VARIANTS`; :mod:`harness.run.batch`: each variant's own numbers, bit for bit),
    else one after the other."""
    from harness.reporting.quantities import quantities
    from harness.results import read_csv
    from harness.run import load, simulate

    system = load(system)
    variants = [v if isinstance(v, Variant) else parse_variant(v) for v in variants]
    check(system, variants)
    base = dict(options.pop("start_values", None) or {})
    runs = [v for v in variants if v.result is None]
    batched = _batched(system, runs, base, options) if batch else {}
    results = {}
    for v in variants:
        if v.result is not None:
            df = read_csv(v.result) if v.result.suffix.lower() == ".csv" else pd.read_parquet(v.result)
            df.attrs["quantities"] = quantities(system, df)
            df.attrs["variant"] = f"the saved result {v.result}"
        else:
            df = batched.get(v.label)
            if df is None:
                df = simulate(system, start_values={**base, **v.start_values}, **options)
            df.attrs["variant"] = ", ".join(f"{k} = {x:g}" if isinstance(x, (int, float)) else f"{k} = {x}"
                                            for k, x in v.start_values.items()) or "the drive as declared"
            if not df.attrs.get("complete", True):
                raise SystemDescriptionError(f"compare {system.name}: variant {v.label!r} stopped: "
                                             f"{df.attrs.get('error')}")
        results[v.label] = df
    return Comparison(system, results)


def _batched(system, runs: list[Variant], base: dict, options: dict) -> dict:
    """{label: result} of the variants ``runs`` stepped as one batch (harness.run.batch), or {} where the batch does
    not apply (they then run one by one)."""
    from harness.run.batch import MIN_VARIANTS, BatchOptions, Keep, refusal, simulate_batch

    settings = {k: v for k, v in options.items() if v is not None}
    if len(runs) < MIN_VARIANTS or refusal(system, settings) is not None:
        return {}
    run = simulate_batch(system, [{**base, **v.start_values} for v in runs], settings,
                         Keep(columns=None, frames=True, quantities=True), BatchOptions())
    return {v.label: r.frame for v, r in zip(runs, run.results)}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "compare", help="two or more designs of a drive side by side: their engineering quantities and charts",
        description="Run a drive once per variant (the same method and stop time for all) and print its "
                    "engineering quantities side by side, with each variant's difference from the first and the "
                    "percent change. A variant is 'LABEL: Instance.param=VALUE ...' (no values: the drive as "
                    "declared) or 'LABEL: FILE.csv' (a saved result of run --out).")
    p.add_argument("system", help="system name in systems/ (e.g. bed_drive), a .py file defining SYSTEM, or .ssp")
    p.add_argument("--variant", action="append", default=[], required=True, metavar="'LABEL: I.p=V ...'",
                   help="a design to compare (repeat for each; at least two)")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] of every run (default: the drive's default experiment)")
    p.add_argument("--step", type=float, default=None, metavar="SECONDS",
                   help="communication step [s] (default: the drive's)")
    p.add_argument("--master", default=None, help="master of every run (default: the drive's)")
    p.add_argument("--no-batch", action="store_true",
                   help="run the variants one after the other (default: together, as one batch of variants, where "
                        "the drive's FMUs are the toolkit's and the method is jacobi, jacobi-sampled or "
                        "gauss-seidel; the same numbers)")
    p.add_argument("--from-checkpoint", type=Path, default=None, metavar="FILE",
                   help="every variant continues this checkpoint of the drive (`run --checkpoint`): a shared "
                        "start-up run once, each variant's values set at its time (default: each from the start)")
    p.add_argument("--out", type=Path, default=None, metavar="FILE.csv",
                   help="write the side-by-side table as CSV (default: printed only)")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="draw the variants over their last machine cycle against the crank angle: "
                        "DIR/<drive>_compare.png (default: no chart)")
    p.add_argument("--limits", type=Path, default=None, metavar="FILE.yaml",
                   help="judge every variant's quantities against limits (a YAML mapping 'quantity: \"<= VALUE\"', "
                        "as run --limits): pass or FAIL per variant, printed, in FILE.limits.json beside --out and "
                        "in the report; exit status 3 after writing everything when any fails (default: none)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE.html",
                   help="write one self-contained HTML page: the variants, the side-by-side table, the overlaid "
                        "chart, the drive, the method and versions; checked before any run (default: none)")
    p.set_defaults(func=_cli)


def _cli(args) -> int:
    from harness.results import check_writable
    from harness.run import RunOptions, load

    system = load(args.system)
    variants = [parse_variant(v) for v in args.variant]
    if args.out is not None:
        check_writable(args.out, "--out")
    if args.plot is not None:
        check_writable(args.plot, "--plot", folder=True)
    if args.report is not None:
        from harness.reporting.htmlreport import check_report_path

        check_report_path(args.report)
    check(system, variants)
    found = []
    if getattr(args, "limits", None) is not None:
        from harness.reporting import limits
        from harness.run.cli import expected_names

        found = limits.read(args.limits)
        limits.check_names(found, expected_names(system), f"limits file {args.limits}", f"drive {system.name}")
    result = compare(system, variants, batch=not getattr(args, "no_batch", False), stop_time=args.stop_time,
                     step=args.step, master=args.master, options=RunOptions(progress=None),
                     from_checkpoint=getattr(args, "from_checkpoint", None))
    failed = _judge(result, found, args) if found else False
    print(result.table())
    for lab, verdicts in (result.verdicts if found else {}).items():
        print(limits.table(verdicts, f"variant {lab}: limits of {args.limits}"))
    if args.out is not None:
        result.frame().to_csv(args.out)
        print(f"wrote {args.out}")
    charts = None
    if args.plot is not None:
        charts = result.plot(args.plot)
        print("chart " + ", ".join(map(str, charts)) if charts else "no chart: the drive declares no crank angle "
              "or no variant completed a machine cycle")
    if args.report is not None:
        print(f"report {result.report(args.report, charts)}")
    if failed:
        return limits.FAILED
    return 0


def _judge(result: Comparison, found: list, args) -> bool:
    """Every variant's quantities against the limits (:mod:`harness.reporting.limits`), kept on ``result`` and
    written beside ``--out``; whether any failed."""
    import json

    from harness.reporting import limits

    result.verdicts = {}
    for lab, df in result.results.items():
        result.verdicts[lab] = limits.judge(found, [(lab, df.attrs["quantities"])])
    if args.out is not None:
        limits.json_path(args.out).write_text(json.dumps(
            {lab: limits.to_dict(v, str(args.limits)) for lab, v in result.verdicts.items()}, indent=1,
            allow_nan=False) + "\n")
    return any(not v.passed for vs in result.verdicts.values() for v in vs)
