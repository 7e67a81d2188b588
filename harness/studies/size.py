"""A part sized to a target: ``python -m harness size DRIVE --vary I.p --target "QUANTITY <= VALUE"`` and
:func:`size`.

The engineering quantity (:mod:`harness.reporting.quantities`) is computed from a co-simulation run of the drive for each
value of the parameter tried; without ``--stop-time`` each run goes on to its first steady machine cycle
(:class:`harness.run.settling.Steady`: three complete cycles at least, at most ``STEADY_LIMIT`` = 8 times the
drive's default stop time); with ``--scenario`` each run is that transient (a stop runs until settled) and the
target names one of its quantities (``stopping_angle``).  First the bracket: ``--range`` (default: a quarter and
four times the drive's value, inside the range its FMU declares, each end moved halfway towards the drive's value
while the FMU refuses it, e.g. a rated speed above the synchronous).  Where its runs go as one batch of variants
(:mod:`harness.run.batch`: each value's own numbers; a given ``--stop-time``, no scenario), the quantity at
``--candidates`` values spread geometrically over it (default 8, its ends included) at once (``--no-batch``: the
same runs one after the other); else at its two ends (at once on a cluster).  Where the default bracket's target holds at both ends or at neither, the bracket
widens: four times further out (a quarter, downward) on the side where the answer lies (met at both ends: where
the quantity gets worse; at neither: where it gets better), the new bracket the old end and the new one, again
until the target holds at one end only, the value reaches :data:`WIDEN` (64) times the drive's value (1/64 of it
downward) or the range the FMU declares, or the FMU refuses every value further out (each tried by a run of one
step and moved back halfway while refused); a ``--range`` given is searched as given.  Where the target is met at
one end and missed at the other, Brent's method finds the value where the quantity crosses the target inside the
pair of neighbouring values tried where it first changes, seen from the end that meets it (to ``--xtol`` of the
range, runs reused); the answer is the boundary value on the side that meets it (the smallest value when the
quantity falls as the parameter rises under ``<=``, the largest when it rises), verified by a run at it.  Where
the target is met at both ends or at neither, it says so with the range the quantity took over every value
tried; where the quantity's elasticity over them, d ln Q / d ln p, is below 0.1 (a 16x change of the
parameter moves it by less than 32 %), it says that the parameter barely governs it.

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
WIDEN = 64.0  # the default bracket widens to at most this many times the drive's value (1/WIDEN of it downward)


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
        options = dict(options)
        scenario = options.pop("scenario", None)
        if options.pop("until_steady", False):
            options = _until_steady(system, options)
        if scenario is not None:
            from harness.run import simulate_scenario

            df = simulate_scenario(system, scenario, start_values={**start_values, parameter: value}, **options)
        else:
            df = simulate(system, start_values={**start_values, parameter: value}, **options)
        if not df.attrs.get("complete", True):
            return dict(value=None, frame=None, error=f"the run at {parameter} = {value:g} stopped: "
                                                      f"{df.attrs.get('error')}")
        q = df.attrs["transient"] if scenario is not None and quantity in df.attrs["transient"] else \
            df.attrs["quantities"] if scenario is not None else quantities(system, df)
        found = q[quantity]
        if found is None or not isinstance(found, (int, float)):
            return dict(value=None, frame=None, error=f"{quantity} has no value at {parameter} = {value:g}: "
                                                      f"{q.row(quantity).note or q.heading()}")
        return dict(value=float(found), frame=df, error="")
    except Exception as e:  # noqa: BLE001 (one line back to the client, which raises it)
        from harness.studies.trial import one_line

        return dict(value=None, frame=None, error=f"the run at {parameter} = {value:g}: {one_line(e)}")


_LOADED: dict = {}   # drive name or file digest -> System, per worker process
STEADY_LIMIT = 8.0   # a sizing run without a stop time goes on to a steady cycle, at most this many times the drive's


def _until_steady(system, options: dict) -> dict:
    """A run's options that end it at its first steady cycle (:class:`harness.run.settling.Steady`), at most
    :data:`STEADY_LIMIT` times the drive's stop time."""
    import dataclasses

    from harness.run import RunOptions
    from harness.run.settling import Steady

    spec = system.quantities
    watch = Steady(spec.shaft_angle, spec.cycle_origin, spec.cycle_angle, spec.settle)
    opts = options.get("options") or RunOptions()
    return {**options, "stop_time": STEADY_LIMIT * system.experiment.stop_time,
            "options": dataclasses.replace(opts, observers=(*opts.observers, watch))}


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

    if options.get("until_steady") or "scenario" in options:   # each run's own end (a steady cycle, a settled stop)
        return False
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
    most ``max_runs`` more (the widening, the root finding and the verifying run), where the batch applies (a
    ``stop_time`` given, no scenario; :mod:`harness.run.batch`): ``batch`` runs them as one batch of variants (the
    same numbers as their own runs), else one after the other; where it does not, the bracket's two ends first and
    ``max_runs`` in all.  ``scheduler``: the address of a dask scheduler; the runs then go to its workers (the candidates at
    once, as one batch or side by side, then each of the root finding's runs) through the sweep's machinery
    (:mod:`harness.studies.sweep_cluster`: the address checked first, a drive file sent as bytes); the answer is the
    same as without one."""
    from scipy.optimize import brentq

    from harness.run import load

    given = system
    system = load(system)
    target = target if isinstance(target, Target) else parse_target(target)
    p0 = _current(system, parameter)
    if "scenario" in options:            # the scenario's own value (a brake's torque) is the drive's value there
        from harness.scenarios import find

        p0 = float(dict(find(system, options["scenario"]).parameters).get(parameter, p0))
    if options.get("stop_time") is None and "scenario" not in options and system.quantities is not None:
        options["until_steady"] = True          # each run to its first steady cycle (at most STEADY_LIMIT x)
    lo, hi = bracket if bracket is not None else _admissible(system, parameter, p0, options)
    if not (0.0 < lo < hi) or not all(map(math.isfinite, (lo, hi))):
        raise SystemDescriptionError(f"size {system.name}: bracket [{lo:g}, {hi:g}] of {parameter} must be two "
                                     f"positive "
                                     f"increasing values (the drive's value is {p0:g})")
    if "scenario" not in options:
        check_target(system, target)
    base = dict(options.pop("start_values", None) or {})
    if isinstance(candidates, bool) or not isinstance(candidates, int) or candidates < 2:
        raise SystemDescriptionError(f"size {system.name}: candidates = {candidates!r} must be a whole number >= 2 "
                                     f"(the bracket's two ends at least)")
    result = Sizing(parameter, target, (lo, hi), system=system)
    frames = {}
    applies = _batch_applies(system, options, candidates)
    together = batch and applies
    # the bracket's values at once: --candidates of them where the batch applies (one batch, or one after the other
    # with batch=False; on a cluster too; max_runs more after them), else its two ends (max_runs in all): the same
    # runs with and without the batch, with and without a cluster
    n = candidates if applies else 2
    budget = max_runs + (n if n > 2 else 0)
    with _runner(system, given, scheduler, together) as (ref, submit):

        def quantities_at(ps: list[float]) -> list[float]:
            todo = [p for p in dict.fromkeys(ps) if p not in result.runs]
            if len(result.runs) + len(todo) > budget:
                raise SystemDescriptionError(f"size {system.name}: {budget} runs used without settling {parameter}; "
                                             f"runs: {_runs(result.runs)}")
            for p, run in zip(todo, submit([(ref, parameter, target.quantity, base, options, p) for p in todo])):
                if run["error"]:
                    raise SystemDescriptionError(f"size {system.name}: {run['error']}")
                frames[p], result.runs[p] = run["frame"], run["value"]
            return [result.runs[p] for p in ps]

        def quantity(p: float) -> float:
            return quantities_at([p])[0]

        grid = [lo * (hi / lo) ** (k / (n - 1)) for k in range(n)]
        grid[-1] = hi
        qs = quantities_at(grid)
        q_lo, q_hi = qs[0], qs[-1]
        first = (lo, hi)
        while bracket is None and target.met(q_lo) == target.met(q_hi):   # the default bracket widens
            upward = _outward(target, q_lo, q_hi)
            new = None if upward is None else _beyond(system, parameter, p0, hi if upward else lo, upward, options)
            if new is None:
                break
            if upward:
                lo, q_lo, hi, q_hi = hi, q_hi, new, quantity(new)
            else:
                lo, q_lo, hi, q_hi = new, quantity(new), lo, q_lo
        result.bracket = (lo, hi)
        a, b = min(result.runs), max(result.runs)        # every value tried (the first bracket and its widening)
        qa, qb = result.runs[a], result.runs[b]
        widened = (f" (the bracket widened from [{first[0]:g}, {first[1]:g}] to [{a:g}, {b:g}], at most "
                   f"{WIDEN:g} times the drive's value {p0:g} either way and inside what the FMU admits)"
                   if (lo, hi) != first else "")
        # the elasticity d ln Q / d ln p over the values tried: a 1 % change of the parameter moves Q by that many %
        elasticity = (math.log(abs(qb) / abs(qa)) / math.log(b / a)) if qa * qb > 0 else math.inf
        change = 100 * abs(qb - qa) / max(abs(qa), abs(qb))
        weak = (f"; {target.quantity} changes by {change:.3g} % over this {b / a:g}x range of {parameter} "
                f"(elasticity {elasticity:.2g}): the parameter barely governs it"
                if abs(elasticity) < WEAK else "")
        qs_all = list(result.runs.values())
        taken = f"{target.quantity} took {min(qs_all):.4g} to {max(qs_all):.4g} over [{a:g}, {b:g}]"
        if target.met(q_lo) and target.met(q_hi):
            result.message = f"{target} holds at both ends of the bracket ({taken}){weak}{widened}"
            return result
        if not target.met(q_lo) and not target.met(q_hi):
            result.message = f"no value of {parameter} in [{a:g}, {b:g}] meets {target}: {taken}{weak}{widened}"
            return result
        # the neighbouring values tried where the target first stops being met, seen from the end that meets it
        side = lo if target.met(q_lo) else hi
        tried = sorted(p for p in result.runs if lo <= p <= hi)
        pairs = [(x, y) for x, y in zip(tried, tried[1:]) if target.met(result.runs[x]) != target.met(result.runs[y])]
        x, y = pairs[0] if side == lo else pairs[-1]
        root = brentq(lambda p: quantity(p) - target.value, x, y, xtol=xtol * (hi - lo), maxiter=max_runs)
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
                          f"{len(result.runs)} runs){weak}{widened}")
        if not monotonic:
            worst = max(result.runs, key=lambda p: result.runs[p] if target.op == "<=" else -result.runs[p])
            result.message = (f"{parameter} = {answer:.6g}: {target} holds from here towards {side:g}, but "
                              f"{target.quantity} is not monotonic in {parameter} over the runs "
                              f"({result.runs[worst]:.4g} at {worst:.4g}): other values may meet the target too, "
                              f"or miss it; narrow --range "
                              f"({target.quantity} = {result.verified:.6g} in the run at it; {len(result.runs)} runs)")
        return result


def _declared(system, parameter: str) -> tuple[float, float]:
    """The range the FMU declares for the parameter (min/max; open ends infinite)."""
    from harness.fmi.cache import model_description
    from harness.model import resolve_fmu

    inst, _, name = parameter.partition(".")
    v = next(v for v in model_description(resolve_fmu(system.instance(inst).fmu)).modelVariables if v.name == name)
    low = float(v.min) if getattr(v, "min", None) not in (None, "") else -math.inf
    high = float(v.max) if getattr(v, "max", None) not in (None, "") else math.inf
    return low, high


def _admitted(system, parameter: str, end: float, toward: float, options: dict) -> float:
    """``end``, moved halfway (geometrically) towards ``toward`` while the FMU refuses it (a rated speed above the
    synchronous one), at most 12 times; each value tried by a run of one step."""
    import warnings

    from harness.run import RunWarning, simulate

    for _ in range(12):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RunWarning)      # a refused value is the answer sought here
            one = simulate(system, stop_time=system.experiment.step, step=system.experiment.step,
                           start_values={**(options.get("start_values") or {}), parameter: end},
                           options=options.get("options"))
        if not one.attrs.get("bad_input"):
            break
        end = math.sqrt(end * toward)
    return end


def _admissible(system, parameter: str, p0: float, options: dict) -> tuple[float, float]:
    """The default bracket: a quarter and four times the drive's value, inside the range the FMU declares for the
    parameter, each end moved towards the drive's value while the FMU refuses it (:func:`_admitted`)."""
    low, high = _declared(system, parameter)
    return (_admitted(system, parameter, max(p0 / 4.0, low), p0, options),
            _admitted(system, parameter, min(p0 * 4.0, high), p0, options))


def _beyond(system, parameter: str, p0: float, end: float, upward: bool, options: dict) -> float | None:
    """The default bracket's next end past ``end``: four times further out (a quarter, downward), inside the range
    the FMU declares and admits (:func:`_admitted`, moved back towards ``end``) and within :data:`WIDEN` times the
    drive's value (1/WIDEN of it downward); None when no value further out is left."""
    low, high = _declared(system, parameter)
    new = min(end * 4.0, high, p0 * WIDEN) if upward else max(end / 4.0, low, p0 / WIDEN)
    if not (new > 0.0) or abs(new - end) <= 1e-9 * abs(end):
        return None
    new = _admitted(system, parameter, new, end, options)
    return None if abs(new - end) <= 1e-6 * abs(end) else new


def _outward(target: Target, q_lo: float, q_hi: float) -> bool | None:
    """Which way the default bracket widens when the target holds at both ends or at neither: True upward, False
    downward, None where the quantity is the same at both ends.  Met at both ends, the boundary lies where the
    quantity gets worse (larger under ``<=``); met at neither, where it gets better."""
    if q_hi == q_lo:
        return None
    worse_up = (q_hi > q_lo) == (target.op == "<=")
    return worse_up if target.met(q_lo) else not worse_up


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
                   help="the bracket searched, as given (default: a quarter and four times the drive's value, "
                        "widened four times further on the answer's side where the target holds at both ends or at "
                        "neither, up to 64 times the drive's value either way)")
    p.add_argument("--candidates", type=int, default=8, metavar="N",
                   help="values tried at once first, spread geometrically over the range, its ends included "
                        "(default 8; where the batch applies, with --stop-time and no scenario; else the range's "
                        "two ends)")
    p.add_argument("--no-batch", action="store_true",
                   help="run the candidates one after the other (default: as one batch of variants, where the "
                        "drive's FMUs are the toolkit's and the method is jacobi, jacobi-sampled or gauss-seidel; "
                        "the same numbers)")
    p.add_argument("--xtol", type=float, default=1e-3, metavar="SHARE",
                   help="the answer's tolerance as a share of the bracket (default 1e-3)")
    p.add_argument("--stop-time", type=float, default=None, metavar="SECONDS",
                   help="stop time [s] of every run (default: each run goes on to its first steady machine cycle, "
                        "three complete cycles at least, at most 8 times the drive's default stop time)")
    p.add_argument("--scenario", default=None, metavar="NAME|FILE",
                   help="size through a transient: each run is the scenario (a stop runs until settled) and the "
                        "target names one of its quantities (e.g. --vary motor.holding_torque --target "
                        "'stopping_angle <= 60' --scenario estop) (default: a plain run's quantities)")
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
    if args.scenario is None:
        check_target(system, target)
    if args.report is not None:
        from harness.reporting.htmlreport import check_report_path

        check_report_path(args.report)
    if args.scheduler:
        from harness.studies.sweep_cluster import check_scheduler

        check_scheduler(args.scheduler)   # one line for a wrong address, before any run
    more = {"scenario": args.scenario} if args.scenario else {}
    result = size(args.system, args.vary, target, tuple(args.range) if args.range else None, xtol=args.xtol,
                  scheduler=args.scheduler, candidates=args.candidates, batch=not args.no_batch,
                  stop_time=args.stop_time, start_values=parse_sets(args.set), options=RunOptions(progress=None),
                  **more)
    print(result.message)
    print(f"runs ({args.vary} -> {target.quantity}): {_runs(result.runs)}")
    if args.report is not None:
        print(f"report {result.report(args.report)}")
    return 0 if result.answer is not None else 2


__all__ = ["size", "parse_target", "Target", "Sizing"]
