"""A part sized to a target: ``python -m harness size DRIVE --vary I.p --target "QUANTITY <= VALUE"`` and
:func:`size`.

The engineering quantity (:mod:`harness.reporting.quantities`) is computed from a co-simulation run of the drive for each
value of the parameter tried.  First the bracket: the quantity at ``--candidates`` values spread geometrically over
``--range`` (default 8 values between a quarter and four times the drive's value), run at once as one batch of
variants where the batch applies (:mod:`harness.run.batch`: each value's own numbers), else side by side on a
cluster or one after the other.  Where the target is met at one end and missed at the other, Brent's method
finds the value where the quantity crosses the target inside the pair of neighbouring candidates where it first
changes, seen from the end that meets it (to ``--xtol`` of the range, runs reused); the answer is
the boundary value on the side that meets it (the smallest value when the quantity falls as the parameter
rises under ``<=``, the largest when it rises), verified by a run at it.  Where the target is met at both ends
or at neither, it says so with the range the quantity took over the bracket; where the quantity's elasticity
over the bracket, d ln Q / d ln p, is below 0.1 (a 16x change of the parameter moves it by less than 32 %), it
says that the parameter barely governs it.

Refused in one line before any run: a target that is not ``NAME <= VALUE`` or ``NAME >= VALUE``, a quantity the
drive does not report (with the nearest names), a parameter the drive's FMUs do not have, a bracket that is not
two positive increasing values for a positive parameter.
"""
from __future__ import annotations

import contextlib
import difflib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from harness.errors import SystemDescriptionError

WEAK = 0.1    # elasticity d ln Q / d ln p below which the parameter barely governs the quantity


@dataclass(frozen=True)
class Target:
    quantity: str
    op: str        # "<=" or ">="
    value: float

    def met(self, q: float) -> bool:
        return q <= self.value if self.op == "<=" else q >= self.value

    def __str__(self) -> str:
        return f"{self.quantity} {self.op} {self.value:g}"


def parse_target(text: str) -> Target:
    m = re.fullmatch(r"\s*([A-Za-z_][\w]*)\s*(<=|>=)\s*([-+0-9.eE]+)\s*", str(text))
    if not m:
        raise SystemDescriptionError(f"--target {text!r}: expected 'QUANTITY <= VALUE' or 'QUANTITY >= VALUE'")
    try:
        value = float(m.group(3))
    except ValueError:
        raise SystemDescriptionError(f"--target {text!r}: {m.group(3)!r} is not a number") from None
    return Target(m.group(1), m.group(2), value)


@dataclass
class Sizing:
    """What :func:`size` found: ``answer`` (None when the bracket holds none) with ``verified`` (the quantity
    at it), ``runs`` (value -> quantity, every run made), the bracket and the ``message`` to print."""
    parameter: str
    target: Target
    bracket: tuple[float, float]
    runs: dict = field(default_factory=dict)
    answer: float | None = None
    verified: float | None = None
    message: str = ""
    system: object = field(default=None, repr=False)      # the drive sized
    verifying: object = field(default=None, repr=False)   # the run at the answer (its DataFrame), None without one

    def report(self, path, charts: list | None = None):
        """One self-contained HTML page of the sizing (:mod:`harness.reporting.htmlreport`): the answer, the runs tried
        (with a chart of the quantity over the parameter and the target), the verifying run's quantities and
        charts, the drive, the method and the versions; returns its path."""
        from harness.reporting import htmlreport as h

        keeps = []
        try:
            page = h.Page(f"{self.system.name}: {self.parameter} sized to {self.target}",
                          f"{len(self.runs)} co-simulation runs over [{self.bracket[0]:g}, {self.bracket[1]:g}]")
            answer = (f"{self.parameter} = {self.answer:.6g} ({self.target.quantity} = {self.verified:.6g} in the "
                      f"run at it)" if self.answer is not None else "no answer in the bracket")
            rows = [[p, q, "yes" if self.target.met(q) else "no", "verifying run" if p == self.answer else ""]
                    for p, q in sorted(self.runs.items())]
            runs_chart, keep = h.render_charts(self._runs_chart, None)
            keeps.append(keep)
            page.section("Answer", h.para(answer), h.para(self.message, "note"))
            page.section("Runs tried", h.table([self.parameter, self.target.quantity, f"meets {self.target}", ""],
                                               rows, numeric={0, 1}),
                         *[h.image(p, f"{self.target.quantity} over {self.parameter}, every run; the target "
                                      f"dashed") for p in runs_chart])
            if self.verifying is not None:
                df = self.verifying
                if charts is None and len(df):
                    from harness.reporting.charts import plot_result

                    charts, keep = h.render_charts(lambda d: plot_result(self.system, df, d), None)
                    keeps.append(keep)
                h.quantities_section(page, df.attrs.get("quantities"),
                                     heading=f"The verifying run at {self.parameter} = {self.answer:.6g}: "
                                             f"engineering quantities")
                page.section("The verifying run: charts", *[h.image(p, f"{self.system.name} at {self.parameter} = "
                                                                       f"{self.answer:.6g}") for p in charts or []])
                h.drive_section(page, self.system, df.attrs.get("start_values"),
                                heading="The drive (as in the verifying run)")
                h.method_section(page, self.system, df.attrs)
                h.versions_section(page, [("stepping of the verifying run", df.attrs.get("wall_time"))])
            else:
                h.drive_section(page, self.system, None, heading="The drive as declared")
                h.versions_section(page, [])
            return page.write(path)
        finally:
            for k in keeps:
                if k is not None:
                    k.cleanup()

    def _runs_chart(self, folder):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from harness.reporting.charts import save_figure

        ps = sorted(self.runs)
        fig, ax = plt.subplots(figsize=(6.5, 3.2))
        ax.plot(ps, [self.runs[p] for p in ps], marker="o", lw=1.0)
        ax.axhline(self.target.value, color="0.3", ls="--", lw=0.9, label=str(self.target))
        if self.answer is not None:
            ax.plot([self.answer], [self.verified], marker="*", ms=12, color="C3", ls="none", label="answer")
        ax.set_xlabel(self.parameter)
        ax.set_ylabel(self.target.quantity)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        return save_figure(fig, Path(folder) / "size_runs", dpi=100)


def run_at(system, parameter: str, quantity: str, start_values: dict, options: dict, value: float) -> dict:
    """One run of the sizing at ``parameter = value`` (in this process or on a dask worker): ``{"value": the
    quantity, "error": one line or "", "frame": the result}``; never raises (the client raises the error).
    ``system``: a :class:`~harness.model.System`, a drive's name or a shipped file
    (:mod:`harness.studies.sweep_cluster`, loaded once per worker process)."""
    from harness.reporting.quantities import quantities
    from harness.run import load, simulate
    from harness.studies.sweep_cluster import SystemFile, system_on_worker

    try:
        if isinstance(system, (str, SystemFile)):
            key = system if isinstance(system, str) else system.digest
            if key not in _LOADED:
                _LOADED[key] = load(system_on_worker(system))
            system = _LOADED[key]
        df = simulate(system, start_values={**start_values, parameter: value}, **options)
        if not df.attrs.get("complete", True):
            return dict(value=None, frame=None, error=f"the run at {parameter} = {value:g} stopped: "
                                                      f"{df.attrs.get('error')}")
        q = quantities(system, df)
        found = q[quantity]
        if found is None or not isinstance(found, (int, float)):
            return dict(value=None, frame=None, error=f"{quantity} has no value at {parameter} = {value:g}: "
                                                      f"{q.row(quantity).note or q.heading()}")
        return dict(value=float(found), frame=df, error="")
    except Exception as e:  # noqa: BLE001 (one line back to the client, which raises it)
        from harness.studies.trial import one_line

        return dict(value=None, frame=None, error=f"the run at {parameter} = {value:g}: {one_line(e)}")


_LOADED: dict = {}   # drive name or file digest -> System, per worker process


def _sent(system, given):
    """What the workers receive for the drive: its name or file as given (a file's bytes, as a sweep sends
    them), or the name of a drive object equal to the one its name loads; one line for a changed object."""
    from harness.run import load
    from harness.studies.sweep_cluster import shipped

    if not hasattr(given, "instances"):
        return shipped(str(given))
    try:
        if load(given.name) == given:
            return given.name
    except Exception:  # noqa: BLE001 (no loadable name: refused below)
        pass
    raise SystemDescriptionError(f"size {given.name} on a dask scheduler: the workers load the drive by its name or "
                                 f"file, "
                       f"and this System differs from the one {given.name!r} loads; give the name or file, with "
                       f"start_values for the changed parameters")


def _batch_applies(system, options: dict, n: int) -> bool:
    """Whether ``n`` runs of ``system`` under ``options`` go as one batch (harness.run.batch): the batch applies and
    ``n`` is at least the batch's break-even count."""
    from harness.run.batch import MIN_VARIANTS, refusal

    return n >= MIN_VARIANTS and refusal(system, {k: v for k, v in options.items() if v is not None}) is None


def run_batch_at(system, parameter: str, quantity: str, start_values: dict, options: dict, values: list) -> list:
    """:func:`run_at` of each of ``values`` as one batch of variants (harness.run.batch), in this process or on a
    dask worker: the same outcomes, each the quantity of its own run's numbers."""
    from harness.reporting.quantities import quantities
    from harness.run import load
    from harness.run.batch import BatchOptions, Keep, simulate_batch
    from harness.studies.sweep_cluster import SystemFile, system_on_worker

    if isinstance(system, (str, SystemFile)):
        key = system if isinstance(system, str) else system.digest
        if key not in _LOADED:
            _LOADED[key] = load(system_on_worker(system))
        system = _LOADED[key]
    settings = {k: v for k, v in options.items() if v is not None}
    run = simulate_batch(system, [{**start_values, parameter: v} for v in values], settings,
                         Keep(columns=None, frames=True, quantities=True), BatchOptions())
    out = []
    for v, r in zip(values, run.results):
        if not r.complete:
            out.append(dict(value=None, frame=None, error=f"the run at {parameter} = {v:g} stopped: {r.error}"))
            continue
        q = r.frame.attrs["quantities"] if "quantities" in r.frame.attrs else quantities(system, r.frame)
        found = q[quantity]
        if found is None or not isinstance(found, (int, float)):
            out.append(dict(value=None, frame=None, error=f"{quantity} has no value at {parameter} = {v:g}: "
                                                          f"{q.row(quantity).note or q.heading()}"))
            continue
        out.append(dict(value=float(found), frame=r.frame, error=""))
    return out


@contextlib.contextmanager
def _runner(system, given, scheduler: str | None, together: bool = False):
    """(what each run is given as the drive, a function running a list of :func:`run_at` argument tuples and
    returning their outcomes in order): in this process, or on the workers of the dask scheduler at
    ``scheduler`` (checked first as a sweep checks it; a drive file sent as bytes once).  ``together``: a list of
    at least :data:`harness.run.batch.MIN_VARIANTS` calls runs as one batch (:func:`run_batch_at`)."""
    from harness.run.batch import MIN_VARIANTS

    def one_batch(calls) -> bool:
        return together and len(calls) >= MIN_VARIANTS

    if scheduler is None:
        yield system, lambda calls: (run_batch_at(*calls[0][:5], [c[5] for c in calls]) if one_batch(calls) else
                                     [run_at(*c) for c in calls])
        return
    from dask.distributed import Client

    from harness.studies.sweep_cluster import SystemFile, check_scheduler, payload

    ref = _sent(system, given)
    check_scheduler(scheduler)
    with Client(scheduler) as client:
        if isinstance(ref, SystemFile):
            ref = client.submit(payload, ref, key=f"system-file-{ref.digest[:32]}")
        yield ref, lambda calls: (client.submit(run_batch_at, *calls[0][:5], [c[5] for c in calls], pure=False).result()
                                  if one_batch(calls) else
                                  client.gather([client.submit(run_at, *c, pure=False) for c in calls]))


def size(system, parameter: str, target, bracket: tuple[float, float] | None = None, xtol: float = 1e-3,
         max_runs: int = 16, scheduler: str | None = None, candidates: int = 8, batch: bool = True,
         **options) -> Sizing:
    """Size ``parameter`` (``Instance.parameter``) of ``system`` so that ``target`` (a :class:`Target` or
    ``"NAME <= VALUE"``) holds; ``options`` go to every :func:`harness.run.simulate` run.  ``candidates``: the
    values tried at once first, spread geometrically over the bracket, its ends included (at least 2), then at
    most ``max_runs`` more (the root finding and the verifying run); ``batch``:
    those run as one batch of variants where the batch applies (:mod:`harness.run.batch`; the same numbers as their
    own runs).  ``scheduler``: the address of a dask scheduler; the runs then go to its workers (the candidates at
    once, as one batch or side by side, then each of the root finding's runs) through the sweep's machinery
    (:mod:`harness.studies.sweep_cluster`: the address checked first, a drive file sent as bytes); the answer is the
    same as without one."""
    from scipy.optimize import brentq

    from harness.run import load

    given = system
    system = load(system)
    target = target if isinstance(target, Target) else parse_target(target)
    p0 = _current(system, parameter)
    lo, hi = bracket if bracket is not None else (p0 / 4.0, p0 * 4.0)
    if not (0.0 < lo < hi) or not all(map(math.isfinite, (lo, hi))):
        raise SystemDescriptionError(f"size {system.name}: bracket [{lo:g}, {hi:g}] of {parameter} must be two "
                                     f"positive "
                                     f"increasing values (the drive's value is {p0:g})")
    check_target(system, target)
    base = dict(options.pop("start_values", None) or {})
    if isinstance(candidates, bool) or not isinstance(candidates, int) or candidates < 2:
        raise SystemDescriptionError(f"size {system.name}: candidates = {candidates!r} must be a whole number >= 2 "
                                     f"(the bracket's two ends at least)")
    result = Sizing(parameter, target, (lo, hi), system=system)
    frames = {}
    together = batch and _batch_applies(system, options, candidates)
    with _runner(system, given, scheduler, together) as (ref, submit):

        def quantities_at(ps: list[float]) -> list[float]:
            todo = [p for p in dict.fromkeys(ps) if p not in result.runs]
            if len(result.runs) + len(todo) > candidates + max_runs:
                raise SystemDescriptionError(f"size {system.name}: {candidates} candidates and {max_runs} more runs "
                                             f"used without settling {parameter}; "
                                             f"runs: {_runs(result.runs)}")
            for p, run in zip(todo, submit([(ref, parameter, target.quantity, base, options, p) for p in todo])):
                if run["error"]:
                    raise SystemDescriptionError(f"size {system.name}: {run['error']}")
                frames[p], result.runs[p] = run["frame"], run["value"]
            return [result.runs[p] for p in ps]

        def quantity(p: float) -> float:
            return quantities_at([p])[0]

        grid = [lo * (hi / lo) ** (k / (candidates - 1)) for k in range(candidates)]
        grid[-1] = hi
        qs = quantities_at(grid)                 # at once: one batch, or side by side on a cluster
        q_lo, q_hi = qs[0], qs[-1]
        # the elasticity d ln Q / d ln p over the bracket: a 1 % change of the parameter moves Q by that many %
        elasticity = (math.log(abs(q_hi) / abs(q_lo)) / math.log(hi / lo)) if q_lo * q_hi > 0 else math.inf
        change = 100 * abs(q_hi - q_lo) / max(abs(q_lo), abs(q_hi))
        weak = (f"; {target.quantity} changes by {change:.3g} % over this {hi / lo:g}x range of {parameter} "
                f"(elasticity {elasticity:.2g}): the parameter barely governs it"
                if abs(elasticity) < WEAK else "")
        taken = f"{target.quantity} took {min(q_lo, q_hi):.4g} to {max(q_lo, q_hi):.4g} over [{lo:g}, {hi:g}]"
        if target.met(q_lo) and target.met(q_hi):
            result.message = f"{target} holds at both ends of the bracket ({taken}){weak}"
            return result
        if not target.met(q_lo) and not target.met(q_hi):
            result.message = f"no value of {parameter} in [{lo:g}, {hi:g}] meets {target}: {taken}{weak}"
            return result
        # the neighbouring candidates where the target first stops being met, seen from the end that meets it
        side = lo if target.met(q_lo) else hi
        pairs = list(zip(grid, grid[1:], qs, qs[1:]))
        a, b, _, _ = next(p for p in (pairs if side == lo else pairs[::-1]) if target.met(p[2]) != target.met(p[3]))
        root = brentq(lambda p: quantity(p) - target.value, a, b, xtol=xtol * (hi - lo), maxiter=max_runs)
        # the boundary value on the side that meets the target, verified by its own run
        answer = root
        if not target.met(quantity(answer)):
            answer = min(result.runs, key=lambda p: abs(p - root) if target.met(result.runs[p]) and
                         (p - root) * (side - root) >= 0 else math.inf)
        result.answer, result.verified = answer, quantity(answer)
        result.verifying = frames.get(answer)
        which = "largest" if side == lo else "smallest"
        qs = [result.runs[p] for p in sorted(result.runs)]
        steps = [b - a for a, b in zip(qs, qs[1:]) if b != a]
        monotonic = all(d > 0 for d in steps) or all(d < 0 for d in steps)
        result.message = (f"{parameter} = {answer:.6g}: the {which} value in [{lo:g}, {hi:g}] that meets "
                          f"{target} ({target.quantity} = {result.verified:.6g} in the run at it; "
                          f"{len(result.runs)} runs){weak}")
        if not monotonic:
            worst = max(result.runs, key=lambda p: result.runs[p] if target.op == "<=" else -result.runs[p])
            result.message = (f"{parameter} = {answer:.6g}: {target} holds from here towards {side:g}, but "
                              f"{target.quantity} is not monotonic in {parameter} over the runs "
                              f"({result.runs[worst]:.4g} at {worst:.4g}): other values may meet the target too, "
                              f"or miss it; narrow --range "
                              f"({target.quantity} = {result.verified:.6g} in the run at it; {len(result.runs)} runs)")
        return result


def check_target(system, target: Target) -> None:
    """The target names a quantity the drive reports (its names from the drive's declaration, before any run)."""
    import pandas as pd

    from harness.reporting.quantities import quantities

    names = quantities(system, pd.DataFrame(index=pd.Index([], name="time"))).names
    if target.quantity not in names:
        close = difflib.get_close_matches(target.quantity, names, n=3)
        raise SystemDescriptionError(f"size {system.name}: no quantity {target.quantity!r}"
                                     + (f" (did you mean {', '.join(close)}?)" if close else
                              f" (quantities: {', '.join(names) or 'none declared'})"))


def _runs(runs: dict) -> str:
    return ", ".join(f"{p:.4g} -> {q:.4g}" for p, q in sorted(runs.items()))


def _current(system, parameter: str) -> float:
    """The drive's value of ``parameter`` (the system's, else the FMU's declared start); one line when the FMU
    has no such parameter."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu
    from harness.run import split_parameters

    inst, _, name = parameter.partition(".")
    split_parameters(system, {parameter: None})      # an unknown instance: one line with the nearest names
    md = model_description(resolve_fmu(system.instance(inst).fmu))
    found = {v.name: v for v in md.modelVariables if v.causality == "parameter"}
    if name not in found:
        close = difflib.get_close_matches(name, list(found), n=3)
        raise SystemDescriptionError(f"size {system.name}: FMU {md.modelName} of instance {inst} has no parameter "
                                     f"{name!r}"
                                     + (f" (did you mean {', '.join(close)}?)" if close else ""))
    given = dict(system.instance(inst).parameters).get(name)
    return float(given if given is not None else found[name].start)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "size", help="size one parameter of a drive to an engineering-quantity target",
        description="Find the smallest (or largest) value of one parameter for which an engineering quantity "
                    "meets a target (QUANTITY <= VALUE or >= VALUE): the quantity at --candidates values over the "
                    "bracket, run at once, then Brent's method inside the pair where the target is first crossed, "
                    "runs reused; the answer is verified by a run at it. A target no value in the bracket meets is one line with the range the quantity took.")
    p.add_argument("system", help="system name in systems/ (e.g. bed_drive), a .py file defining SYSTEM, or .ssp")
    p.add_argument("--vary", required=True, metavar="Instance.param", help="the parameter to size")
    p.add_argument("--target", required=True, metavar="'QUANTITY <= VALUE'",
                   help="the engineering quantity's target (names as `run` prints them)")
    p.add_argument("--range", nargs=2, type=float, default=None, metavar=("LOW", "HIGH"),
                   help="the bracket searched (default: a quarter and four times the drive's value)")
    p.add_argument("--candidates", type=int, default=8, metavar="N",
                   help="values tried at once first, spread geometrically over the range, its ends included "
                        "(default 8; run as one batch of variants where the batch applies)")
    p.add_argument("--no-batch", action="store_true",
                   help="run the candidates one after the other (default: as one batch of variants, where the "
                        "drive's FMUs are the toolkit's and the method is jacobi, jacobi-sampled or gauss-seidel; "
                        "the same numbers)")
    p.add_argument("--xtol", type=float, default=1e-3, metavar="SHARE",
                   help="the answer's tolerance as a share of the bracket (default 1e-3)")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] of every run (default: the drive's default experiment)")
    p.add_argument("--set", action="append", default=[], metavar="Instance.param=VALUE",
                   help="other parameter values, the same in every run")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a dask scheduler: the runs go to its workers (the candidates at once, "
                        "then the root finding's runs), as a sweep's points do (default: in this process)")
    p.add_argument("--report", type=Path, default=None, metavar="FILE.html",
                   help="write one self-contained HTML page: the answer, the runs tried, the verifying run's "
                        "quantities and charts, the drive, the method and versions; checked before any run "
                        "(default: none)")
    p.set_defaults(func=_cli)


def _cli(args) -> int:
    from harness.run import RunOptions, load, parse_sets

    system = load(args.system)
    target = parse_target(args.target)
    _current(system, args.vary)
    check_target(system, target)
    if args.report is not None:
        from harness.reporting.htmlreport import check_report_path

        check_report_path(args.report)
    if args.scheduler:
        from harness.studies.sweep_cluster import check_scheduler

        check_scheduler(args.scheduler)   # one line for a wrong address, before any run
    result = size(args.system, args.vary, target, tuple(args.range) if args.range else None, xtol=args.xtol,
                  scheduler=args.scheduler, candidates=args.candidates, batch=not args.no_batch,
                  stop_time=args.stop_time, start_values=parse_sets(args.set), options=RunOptions(progress=None))
    print(result.message)
    print(f"runs ({args.vary} -> {target.quantity}): {_runs(result.runs)}")
    if args.report is not None:
        print(f"report {result.report(args.report)}")
    return 0 if result.answer is not None else 2


__all__ = ["size", "parse_target", "Target", "Sizing"]
