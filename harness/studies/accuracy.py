"""Does a run meet the accuracy its drive declares, and what is the cheapest method and step that does?
``python -m harness study accuracy SYSTEM``.

A drive declares its accuracy in a press engineer's terms (``System.accuracy``, an
:class:`~harness.specs.AccuracySpec` of :class:`~harness.specs.Requirement`): for the bed drive, the bed position
through the printing zone (the register), the bed speed there and the peak shaft torque.  :func:`check` judges
one run against the monolithic reference (:mod:`harness.studies.reference`: the same equations as one ODE,
no coupling error); :func:`search` runs a ladder of methods (master, extrapolation order) and steps and
reports, per run, every requirement's error beside its tolerance, the wall time and the FMU steps taken
(fmi2DoStep calls summed over the FMUs: the cost that holds on any machine), and the cheapest run that meets
all.  Cheapest = fewest FMU steps, then wall time (wall time is noisy on a shared machine).

A transient (:mod:`harness.scenarios`) declares its own accuracy (``Scenario.accuracy``): its transient quantities
(stopping time and angle, peak loads) and signals against the monolithic reference through the same events
(:func:`harness.studies.reference.scenario_reference`).  :func:`search_scenario` runs the same ladder through the
scenario (``study accuracy DRIVE --scenario NAME``); a step whose grid misses one of the scenario's event times
is left out of the ladder, as is one that does not divide the stop time.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from harness.reporting import qoi
from harness.specs import AccuracySpec, Requirement
from harness.studies.trial import StudyInterrupted, keep_interrupted, trial, write_complete

DEFAULT_METHODS = (("jacobi", 1), ("gauss-seidel", 1), ("jacobian", 1))
DEFAULT_STEPS = (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 4e-3)


@dataclass
class Check:
    """One requirement judged on one run: ``error`` in ``unit`` (relative requirements: a fraction) beside
    ``tolerance``; ``note`` says why it could not be judged (then ``ok`` is False)."""
    name: str
    error: float
    tolerance: float
    unit: str
    ok: bool
    note: str = ""


def accuracy_spec(system) -> AccuracySpec:
    spec = getattr(system, "accuracy", None)
    if spec is None:
        raise ValueError(f"system {system.name} declares no accuracy (System.accuracy in systems/{system.name}.py)")
    return spec


def _on_grid(reference: pd.DataFrame, times: np.ndarray) -> pd.DataFrame:
    """The reference's numeric columns interpolated at ``times``."""
    tf = reference.index.to_numpy(dtype=float)
    cols = {c: np.interp(times, tf, reference[c].to_numpy(dtype=float)) for c in reference.columns
            if np.issubdtype(reference[c].dtype, np.number)}
    return pd.DataFrame(cols, index=pd.Index(times, name="time"))


def _judge(req: Requirement, run: pd.DataFrame, reference: pd.DataFrame) -> Check:
    try:
        value = np.asarray(qoi.value(req.quantity, run), dtype=float)
        per_sample = value.shape == (len(run),)
        ref = _on_grid(reference, run.index.to_numpy(dtype=float)) if per_sample else reference
        expected = np.asarray(qoi.value(req.quantity, ref), dtype=float)
        if per_sample and req.where:
            keep = qoi.mask(req.where, ref)
            if not keep.any():
                return Check(req.name, math.nan, req.tolerance, req.unit, False,
                             f"no sample of the run where {req.where} holds on the reference")
            value, expected = value[keep], expected[keep]
    except qoi.QoIError as e:
        return Check(req.name, math.nan, req.tolerance, req.unit, False, str(e))
    if value.shape != expected.shape:
        return Check(req.name, math.nan, req.tolerance, req.unit, False,
                     f"{value.size} values in the run, {expected.size} in the reference")
    if value.size == 0:
        return Check(req.name, 0.0, req.tolerance, req.unit, True, "nothing to compare in either")
    error = float(np.max(np.abs(value - expected)))
    if req.relative:
        scale = float(np.max(np.abs(expected)))
        error = error / scale if scale > 0 else (0.0 if error == 0 else math.inf)
    return Check(req.name, error, req.tolerance, "1" if req.relative else req.unit, error <= req.tolerance)


def check(system, run: pd.DataFrame, reference: pd.DataFrame) -> list[Check]:
    """Every requirement of ``system`` judged on ``run`` against ``reference`` (a result of
    :func:`harness.studies.reference.reference` over at least the run's span).  An incomplete run meets none."""
    spec = accuracy_spec(system)
    if run.attrs.get("complete") is False:
        why = str(run.attrs.get("error") or "incomplete run")
        return [Check(r.name, math.nan, r.tolerance, r.unit, False, f"run incomplete: {why}")
                for r in spec.requirements]
    return [_judge(r, run, reference) for r in spec.requirements]


def search(system, methods=DEFAULT_METHODS, steps=DEFAULT_STEPS, progress=None) -> pd.DataFrame:
    """One row per (method, step) with the wall time, FMU steps, whether it completed, every requirement's
    error (column ``<name>``) and ``meets`` (all requirements met).  Steps that do not divide the stop time
    are skipped.  Ctrl-C / SIGTERM: :class:`StudyInterrupted` with the rows finished."""
    from harness.studies.reference import reference

    spec = accuracy_spec(system)
    with np.errstate(over="ignore", invalid="ignore"):  # Radau's Newton probes states far off (feeder: x3)
        ref = reference(system, stop_time=spec.stop_time, step=spec.reference_step)
    rows = []
    try:
        for master, order in methods:
            for h in steps:
                n = spec.stop_time / h
                if abs(n - round(n)) > 1e-9 * n:
                    continue
                t = trial(system, stop_time=spec.stop_time, step=h, master=master, extrapolation=order)
                checks = check(system, t.result, ref) if t.result is not None else [
                    Check(r.name, math.nan, r.tolerance, r.unit, False, t.error) for r in spec.requirements]
                rows.append(_row(dict(master=master, order=order, step=h), t, checks, spec.stop_time, progress))
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    return pd.DataFrame(rows)


def scenario_spec(system, scenario):
    """The scenario (by name, file or :class:`~harness.specs.Scenario`) with its declared accuracy; one line
    if it declares none."""
    from harness.scenarios import find

    sc = find(system, scenario)
    if not sc.accuracy:
        declared_ = [s.name for s in system.scenarios if s.accuracy]
        raise ValueError(f"system {system.name}, scenario {sc.name}: declares no accuracy (Scenario.accuracy in "
                         f"systems/{system.name}.py); scenarios that do: {', '.join(declared_) or 'none'}")
    return sc


def _judge_transient(req: Requirement, run_q, ref_q) -> Check:
    """A transient quantity (by name) of the run against the reference's."""
    if req.quantity not in ref_q:
        return Check(req.name, math.nan, req.tolerance, req.unit, False,
                     f"no transient quantity {req.quantity!r} (the scenario's: {', '.join(ref_q.names)})")
    expected = ref_q[req.quantity]
    value = run_q[req.quantity] if req.quantity in run_q else None
    if expected is None or value is None:
        which = "reference" if expected is None else "run"
        return Check(req.name, math.nan, req.tolerance, req.unit, False, f"{req.quantity} not reached in the {which}")
    error = abs(float(value) - float(expected))
    if req.relative:
        error = error / abs(expected) if expected else (0.0 if error == 0 else math.inf)
    return Check(req.name, error, req.tolerance, "1" if req.relative else req.unit, error <= req.tolerance)


def check_scenario(system, scenario, run: pd.DataFrame, reference: pd.DataFrame, reference_transient=None):
    """Every requirement of the scenario judged on ``run`` (a run through it) against ``reference`` (its
    monolithic reference): a transient quantity's name compares the two runs' :func:`harness.scenarios.transient`
    values, anything else is judged as :func:`check` judges a drive's requirement.  An incomplete run meets none."""
    from harness.scenarios import transient

    if run.attrs.get("complete") is False:
        why = str(run.attrs.get("error") or "incomplete run")
        return [Check(r.name, math.nan, r.tolerance, r.unit, False, f"run incomplete: {why}")
                for r in scenario.accuracy]
    ref_q = reference_transient if reference_transient is not None else transient(system, scenario, reference)
    run_q = run.attrs.get("transient") or transient(system, scenario, run)
    return [_judge_transient(r, run_q, ref_q) if r.quantity.isidentifier() else _judge(r, run, reference)
            for r in scenario.accuracy]


def search_scenario(system, scenario, methods=DEFAULT_METHODS, steps=DEFAULT_STEPS, progress=None,
                    reference: pd.DataFrame | None = None) -> pd.DataFrame:
    """:func:`search` through a scenario (by name, file or :class:`~harness.specs.Scenario`) judged by its own
    accuracy (:func:`check_scenario`); the table has the same columns.  ``reference``: the scenario's
    monolithic reference if already computed (else computed at the ladder's finest step, at most 0.1 ms)."""
    from harness.scenarios import prepare, transient
    from harness.studies.reference import scenario_reference

    sc = scenario_spec(system, scenario)
    usable = []
    for h in steps:
        points = [sc.stop_time / h, *(c.time / h for c in sc.changes)]
        if all(abs(n - round(n)) <= 1e-9 * max(1.0, abs(n)) for n in points):
            usable.append(h)
    if not usable:
        raise ValueError(f"system {system.name}, scenario {sc.name}: none of the steps "
                         f"{', '.join(f'{h:g}' for h in steps)} s has the scenario's stop time and event times "
                         f"({', '.join(f'{c.time:g}' for c in sc.changes) or 'none'} s) on its grid")
    if reference is None:
        with np.errstate(over="ignore", invalid="ignore"):
            reference = scenario_reference(system, sc, step=min(1e-4, *usable))
    ref_q = transient(system, sc, reference)
    rows = []
    try:
        for master, order in methods:
            for h in usable:
                _, options = prepare(system, sc, dict(step=h, master=master, extrapolation=order))
                t = trial(system, **options)
                if t.complete:
                    t.result.attrs["transient"] = transient(system, sc, t.result)
                checks = check_scenario(system, sc, t.result, reference, ref_q) if t.result is not None else [
                    Check(r.name, math.nan, r.tolerance, r.unit, False, t.error) for r in sc.accuracy]
                rows.append(_row(dict(scenario=sc.name, master=master, order=order, step=h), t, checks,
                                 sc.stop_time, progress))
    except KeyboardInterrupt as e:
        raise StudyInterrupted(pd.DataFrame(rows), e) from None
    return pd.DataFrame(rows)



def _row(key: dict, t, checks, stop_time: float, progress) -> dict:
    """One row of a study's table: ``key`` (the method and step), the trial ``t``'s outcome and cost, and each
    check's error; said through ``progress`` when given."""
    attrs = t.result.attrs if t.result is not None else {}
    row = dict(key, complete=t.complete, wall_time=t.wall_time, fmu_steps=attrs.get("fmu_steps", math.nan),
               realtime=stop_time / t.wall_time if t.complete else math.nan,
               meets=t.complete and all(c.ok for c in checks), error=t.error)
    row.update({c.name: c.error for c in checks})
    if progress:
        verdict = "meets" if row["meets"] else ("fails" if t.complete else f"stopped: {t.error}")
        progress(f"{key['master']:12s} order {key['order']} step {key['step']:g} s: {verdict}; "
                 + ", ".join(f"{c.name} {c.error:.3g}/{c.tolerance:g}" for c in checks))
    return row

def cheapest(table: pd.DataFrame) -> pd.Series | None:
    """The row that meets every requirement with the fewest FMU steps (then the shortest wall time)."""
    ok = table[table["meets"]] if len(table) else table
    if not len(ok):
        return None
    return ok.sort_values(["fmu_steps", "wall_time"]).iloc[0]


def register(study_subparsers) -> None:
    p = study_subparsers.add_parser(
        "accuracy", help="the cheapest method and step that meets a drive's declared accuracy",
        description="Runs a ladder of methods and steps, judges each run against the monolithic reference by "
                    "the accuracy the drive declares (System.accuracy), and names the cheapest that meets it.")
    p.add_argument("system", help="a system with a declared accuracy, e.g. bed_drive")
    p.add_argument("--masters", nargs="+", default=None,
                   help="methods as MASTER:ORDER, e.g. jacobi:1 jacobian:1 (default: "
                        + " ".join(f"{m}:{o}" for m, o in DEFAULT_METHODS) + ")")
    p.add_argument("--steps", nargs="+", type=float, default=None,
                   help="communication steps [s] (default: " + " ".join(f"{h:g}" for h in DEFAULT_STEPS) + ")")
    p.add_argument("--scenario", default=None,
                   help="judge a transient instead (a scenario NAME of the drive or a FILE): the accuracy the "
                        "scenario declares, against the monolithic reference through the same events (default: the "
                        "drive's steady accuracy)")
    p.add_argument("--out", default="results", help="folder of accuracy_<system>.csv "
                                                    "(accuracy_<system>_<scenario>.csv with --scenario)")
    p.set_defaults(func=_cli)


def _methods(items) -> list[tuple[str, int]]:
    from harness.master import MASTERS

    out = []
    for item in items:
        master, _, order = str(item).partition(":")
        if master not in MASTERS or order not in ("", "0", "1", "2"):
            raise ValueError(f"--masters {item!r} is not admissible: write MASTER:ORDER with MASTER one of "
                             f"{', '.join(MASTERS)} and ORDER 0, 1 or 2")
        out.append((master, int(order or 1)))
    return out


def _cli(args) -> int:
    from harness import load

    system = load(args.system)
    sc = scenario_spec(system, args.scenario) if args.scenario else None
    if sc is None:
        accuracy_spec(system)
    methods = _methods(args.masters) if args.masters else DEFAULT_METHODS
    steps = args.steps or DEFAULT_STEPS
    for h in steps:
        if not (math.isfinite(h) and h > 0):
            raise ValueError(f"--steps {h!r} is not admissible: steps must be positive numbers [s]")
    what = system.name if sc is None else f"{system.name}, scenario {sc.name}"
    out = Path(args.out) / (f"accuracy_{system.name}.csv" if sc is None else f"accuracy_{system.name}_{sc.name}.csv")
    progress = lambda s: print(s, file=sys.stderr)  # noqa: E731
    try:
        table = (search(system, methods, steps, progress=progress) if sc is None else
                 search_scenario(system, sc, methods, steps, progress=progress))
    except StudyInterrupted as e:
        return keep_interrupted(e, out, f"study accuracy {system.name}")
    write_complete(table, out)
    best = cheapest(table)
    if best is None:
        print(f"no method and step of the ladder meets the accuracy of {what} ({len(table)} runs); table: {out}")
        return 1
    print(f"{what}: cheapest that meets its accuracy: {best['master']} (order {best['order']}) at "
          f"{best['step']:g} s, {int(best['fmu_steps'])} FMU steps, {best['realtime']:.2f} x real time; table: {out}")
    return 0
