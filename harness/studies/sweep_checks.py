"""What a sweep checks before its first point, and the file its finished points are appended to.

:func:`preflight` fails with one line (:class:`~harness.studies.sweep.SweepError`) naming the spec file, the
key and the culprit when: the worker count is not an integer from 0 to the CPUs this process may use; the
spec's ``system:`` key names another system; a sweep variable changes nothing (neither ``instance.parameter``
nor read by a ``set:`` expression: a misspelt key), with the close names; a parameter that a point sets is
not a parameter of the system's FMUs (checked at every point, so an expression that fails at one point fails
before any run); a quantity of interest names a variable no FMU has, or does not evaluate on a result of the
right columns (a typo in a function name); the output file cannot be written (unknown suffix, Parquet without
pyarrow or fastparquet, a folder that cannot be created or written: the run command's checks).

:class:`PointLog` appends each finished point to ``<out stem>.partial.csv`` as it finishes (header first).
Beside it ``<out stem>.partial.json`` records the sweep's :func:`identity` (system or file hash, points,
expressions, run settings, toolkit version).  A sweep that completes writes ``--out`` and its identity beside it
(``<out stem>.sweep.json``) and removes the partial files; one that is interrupted (Ctrl-C) or fails leaves it, with every finished point.
``--resume`` refuses a partial file of another sweep in one line, drops a torn or incomplete last line (and
runs that point again), skips the points it holds (matched on the values of the sweep variables), and on a
finished sweep of the same identity says that there is nothing to do.
"""
from __future__ import annotations

import csv
import difflib
import json
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from harness.reporting import qoi
from harness.studies.trial import partial_csv as partial_path  # the point log of an unfinished sweep


class SweepError(ValueError):
    """A sweep that cannot run as specified (one line naming the file, variable, value and allowed range);
    defined here, below :mod:`harness.studies.sweep`, which re-exports it, so the two import without a circle.
    A line break in a name or value the file holds is written as ``\\n`` (:func:`harness.errors.single_line`)."""

    def __init__(self, *args):
        from harness.errors import single_line

        if args and isinstance(args[0], str):
            args = (single_line(args[0].strip()),) + args[1:]
        super().__init__(*args)


def _fail(message: str):
    raise SweepError(message)


def available_cpus() -> int:
    """The CPUs this process may run on (its affinity mask where the system has one, else the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def default_workers() -> int:
    """Two local workers, or one where this process has a single CPU."""
    return min(2, available_cpus())


def check_workers(workers, local: bool = True) -> int:
    """``workers`` local processes, each a full co-simulation that keeps one CPU busy: more than the CPUs
    only queue behind each other while every process holds its FMUs in memory (1000 on 2 CPUs ran the load to
    227 and gave no result in 300 s).  ``local=False``: the points go to an existing scheduler, whose workers
    are its own, so only the type is checked."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        _fail(f"--workers {workers!r} is not admissible: give an integer >= 0 (0 runs the points in this process)")
    cpus = available_cpus()
    if local and workers > cpus:
        _fail(f"--workers {workers} is more than the {cpus} CPU(s) available to this process: give at most "
              f"{cpus} (0 runs the points in this process)")
    return workers


def check_out(out: Path) -> None:
    """``--out`` can be written: the run command's own checks (:func:`harness.results.result_format`: .csv, or
    .parquet where pyarrow or fastparquet is installed; :func:`harness.results.check_writable`: the folder
    is made and writable), said as a :class:`SweepError`."""
    from harness.errors import SystemDescriptionError
    from harness.results import check_writable, result_format

    try:
        result_format(out)
        check_writable(out, "--out")
    except SystemDescriptionError as e:
        _fail(str(e))


def _variables(system) -> dict[str, dict]:
    """``{instance: {variable name: ScalarVariable}}`` of the system's FMUs."""
    from harness.model import model_description, resolve_fmu

    return {inst.name: {v.name: v for v in model_description(resolve_fmu(inst.fmu)).modelVariables}
            for inst in system.instances}


def parameter_units(system_name: str, spec) -> dict[str, str]:
    """The unit of each sweep column that is an FMU parameter: a dotted sweep variable and ``set:<name>``, from
    the FMU's modelDescription (its unit, else its declared type's); for the chart's axes and legend."""
    from harness import load
    from harness.model import _unit

    variables = _variables(load(system_name))
    out = {}
    for name in [*spec.variables, *spec.set]:
        inst, _, var = name.partition(".")
        v = variables.get(inst, {}).get(var)
        if v is not None and _unit(v):
            out[name if name in spec.variables else f"set:{name}"] = _unit(v)
    return out


def preflight(system_name: str, spec, out: Path | None, workers, local: bool = True) -> None:
    """Every check of the module docstring, before the first point runs (``local``: see :func:`check_workers`)."""
    from harness import load

    check_workers(workers, local)
    if out is not None and Path(out).suffix.lower() not in (".csv", ".parquet"):
        check_out(Path(out))  # the name alone is wrong: say so first
    system = load(system_name)
    src = spec.source
    if spec.system is not None and str(spec.system) != system.name:
        _fail(f"{src}: system: the spec was written for {spec.system!r}, not {system.name!r}: run "
              f"'sweep {spec.system} --grid {src}' or change the spec's system key")
    variables = _variables(system)
    _check_variables_act(spec, system, variables)
    for k, point in enumerate(spec.points):
        params = spec.parameters(point)
        for name in params:
            inst, _, var = name.partition(".")
            what = f"{src}: " + (f"grid.{name}" if name in point else f"set.{name}")
            if inst not in variables:
                _fail(f"{what}: system {system.name} has no instance {inst!r} (instances: "
                      f"{', '.join(variables)})")
            v = variables[inst].get(var)
            if v is None or v.causality != "parameter":
                own = sorted(n for n, x in variables[inst].items() if x.causality == "parameter")
                _fail(f"{what}: instance {inst} ({system.instance(inst).fmu}) has no parameter {var!r}"
                      f"{_did_you_mean(var, own)} (parameters: {', '.join(own)})")
            value = params[name]
            if isinstance(value, float) and not math.isfinite(value):
                _fail(f"{what}: {value!r} at point {k + 1} ({point}) is not a finite number")
    for name, expr in spec.outputs.items():
        cols = qoi.columns(expr)
        for c in cols:
            inst, _, var = c.partition(".")
            if inst not in variables or var not in variables[inst]:
                _fail(f"{src}: outputs.{name}: {expr!r} names {c!r}, which is no variable of system "
                      f"{system.name}")
        probe = pd.DataFrame({c: np.linspace(0.0, 1.0, 11) for c in cols},
                             index=pd.Index(np.linspace(0.0, 1.0, 11), name="time"))
        try:
            qoi.evaluate(expr, probe)
        except qoi.QoIError as e:
            if "unknown name" in str(e) or "not allowed" in str(e) or "not an expression" in str(e):
                _fail(f"{src}: outputs.{name}: {e}")
        except Exception:  # a value error on made-up data (e.g. no rise) is not a spec error
            pass
    if out is not None:
        check_out(Path(out))  # last: it creates the output folder


def _did_you_mean(name: str, candidates) -> str:
    close = difflib.get_close_matches(name, list(candidates), n=3, cutoff=0.6)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""


def _check_variables_act(spec, system, variables: dict[str, dict]) -> None:
    """Every sweep variable must change the run: a parameter named ``instance.parameter`` is set directly, any
    other name must be read by a ``set:`` expression.  A misspelt key (``speeed``) would otherwise run every
    point with the same parameters and give identical rows that look like a result."""
    read = spec.names_read_by_set()
    params = sorted(f"{i}.{n}" for i, vs in variables.items() for n, x in vs.items() if x.causality == "parameter")
    for name in spec.variables:
        if "." in name or name in read:
            continue
        short: dict[str, list[str]] = {}   # parameter name -> instance.parameter, for a name without instance
        for p in params:
            short.setdefault(p.partition(".")[2], []).append(p)
        guesses = difflib.get_close_matches(name, sorted(read) + params + list(short), n=3, cutoff=0.6)
        guesses = list(dict.fromkeys(g2 for g in guesses for g2 in short.get(g, [g])))
        hint = f" (did you mean {' or '.join(repr(g) for g in guesses)}?)" if guesses else ""
        reads = f" (they read {', '.join(sorted(read))})" if read else ""
        _fail(f"{spec.source}: {spec.variable_key(name)}: {name!r} changes nothing in {system.name}: it is no "
              f"instance.parameter and no set: expression reads it{reads}{hint}; a sweep variable is a parameter "
              f"as instance.parameter (instances: {', '.join(variables)}) or a name a set: expression reads")


def point_key(spec, row) -> tuple:
    return tuple(float(row[v]) for v in spec.variables)


def toolkit_version() -> str:
    from importlib import metadata

    try:
        return metadata.version("pressdrive")
    except metadata.PackageNotFoundError:  # pragma: no cover - a tree that was never installed
        return "(not installed)"


def identity(system_name: str, spec) -> dict:
    """What makes two sweeps the same: the system (a drive's name, or a file's name and SHA-256), the points
    (their count and a hash of the variables and values), the ``set:`` and ``outputs:`` expressions, the run
    settings (stop time, step, master, extrapolation) and the toolkit's version.  Written beside the partial
    file and beside the result; ``--resume`` compares it field by field."""
    import hashlib

    path = Path(str(system_name))
    if path.is_file():
        system = f"{path.name} sha256:{hashlib.sha256(path.read_bytes()).hexdigest()}"
    else:
        system = str(system_name)
    grid = json.dumps([spec.variables, [[float(p[v]) for v in spec.variables] for p in spec.points]])
    return {"system": system,
            "points": f"{len(spec.points)} points sha256:{hashlib.sha256(grid.encode()).hexdigest()[:16]}",
            "set": {k: str(v) for k, v in spec.set.items()},
            "outputs": {k: str(v) for k, v in spec.outputs.items()},
            **{k: spec.run.get(k) for k in ("stop_time", "step", "master", "extrapolation")},
            "version": toolkit_version()}


def identity_mismatch(stored: dict, now: dict, where: Path) -> str | None:
    """The one-line refusal when ``stored`` (read from ``where``) is not ``now``, naming the first field that
    differs with both values; None when they agree."""
    for key in now:
        if stored.get(key) != now[key]:
            return (f"--resume: {where} is of another sweep: {key} {_shown(stored.get(key))} there, "
                    f"{_shown(now[key])} now; run without --resume to start afresh, or give the same "
                    f"system, spec and toolkit")
    return None


def _shown(value) -> str:
    return "(default)" if value is None else repr(value) if isinstance(value, (str, dict)) else str(value)


class PointLog:
    """Appends finished points to ``path`` (a plain CSV: the header, one line per point, each written whole and
    ended by a newline) and keeps the sweep's :func:`identity` beside it (``id_path``: ``x.partial.csv`` ->
    ``x.partial.json``).  ``done`` holds the keys already there.

    With ``resume`` the file must be of the same sweep (its identity file, else one line naming the field);
    a line without its newline (a crash mid-write), of another field count, with a value that is no number or
    a point that is not in the spec is dropped and its point run again (``dropped`` counts them); the file is
    rewritten with the good lines so the appended ones follow on a clean line.  A point is logged once."""

    def __init__(self, path: Path, spec, resume: bool, identity: dict | None = None):
        self.path = Path(path)
        self.spec = spec
        self.identity = dict(identity or {})
        self.columns = [*spec.variables, *(f"set:{k}" for k in spec.set if k not in spec.variables),
                        *spec.outputs, "error", "wall_time"]
        self.rows: list[dict] = []
        self.dropped = 0
        self.id_path = self.path.with_suffix(".json")
        if resume and self.path.exists():
            self.rows = self._read()
            self._write(self.rows)
        else:
            self.path.unlink(missing_ok=True)
            self.id_path.write_text(json.dumps(self.identity, indent=1, sort_keys=True) + "\n")
        self.done = {point_key(spec, r) for r in self.rows}
        if not self.path.exists():
            self._write([])

    def _read(self) -> list[dict]:
        try:
            stored = json.loads(self.id_path.read_text())
        except (OSError, ValueError):
            stored = None
        if not isinstance(stored, dict):
            _fail(f"--resume: {self.path} does not say which sweep wrote it (no readable {self.id_path.name} "
                  f"beside it); run without --resume to start afresh")
        problem = identity_mismatch(stored, self.identity, self.id_path)
        if problem:
            _fail(problem)
        body = self.path.read_text().splitlines(keepends=True)
        if body and not body[-1].endswith("\n"):   # the last line of a crash mid-write
            body.pop()
            self.dropped += 1
        records = csv.reader(body)
        header = next(records, None)
        if header is not None and header != self.columns:
            missing = [c for c in self.columns if c not in header]
            _fail(f"--resume: {self.path} was written by another sweep (columns "
                  f"{'no ' + repr(missing[0]) if missing else 'in another order'})")
        wanted = {point_key(self.spec, p) for p in self.spec.points}
        rows, seen = [], set()
        for rec in records:
            row = self._row(rec)
            key = point_key(self.spec, row) if row is not None else None
            if row is None or key not in wanted or key in seen:
                self.dropped += row is None or key not in wanted
                continue
            seen.add(key)
            rows.append(row)
        return rows

    def _row(self, rec: list[str]) -> dict | None:
        if len(rec) != len(self.columns):
            return None
        row = {}
        for c, text in zip(self.columns, rec):
            if c == "error":
                row[c] = text
                continue
            try:
                row[c] = float(text) if text != "" else math.nan
            except ValueError:
                return None
            if c in self.spec.variables and not math.isfinite(row[c]):
                return None
        return row

    def _line(self, row: dict) -> list:
        return [repr(row.get(c)) if isinstance(row.get(c), float) else row.get(c, "") for c in self.columns]

    def _write(self, rows: list[dict]) -> None:
        import io

        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for r in rows:
            w.writerow(self._line(r))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_name(self.path.name + ".tmp")
        tmp.write_text(buf.getvalue())
        os.replace(tmp, self.path)

    def add(self, row: dict) -> None:
        key = point_key(self.spec, row)
        if key in self.done:   # a point dask ran twice (its worker lost after it finished): logged once
            return
        self.done.add(key)
        self.rows.append(row)
        with open(self.path, "a", newline="") as f:
            csv.writer(f, lineterminator="\n").writerow(self._line(row))
            f.flush()

    def frame(self) -> pd.DataFrame:
        order = {tuple(float(p[v]) for v in self.spec.variables): i for i, p in enumerate(self.spec.points)}
        rows = sorted(self.rows, key=lambda r: order.get(point_key(self.spec, r), len(order)))
        return pd.DataFrame(rows, columns=self.columns)


def identity_path(out: Path) -> Path:
    """Where a finished sweep keeps its :func:`identity`: ``x.csv`` -> ``x.sweep.json``."""
    out = Path(out)
    return out.with_name(f"{out.stem}.sweep.json")


def finished(out: Path, spec, ident: dict) -> bool:
    """True when ``out`` is the finished result of this very sweep (its identity file agrees and it holds
    every point); one line when the identity file names another sweep."""
    ipath = identity_path(out)
    if not (Path(out).is_file() and ipath.is_file()):
        return False
    try:
        stored = json.loads(ipath.read_text())
    except ValueError:
        return False
    problem = identity_mismatch(stored if isinstance(stored, dict) else {}, ident, ipath)
    if problem:
        _fail(problem)
    try:
        df = pd.read_parquet(out) if Path(out).suffix.lower() == ".parquet" else pd.read_csv(out)
    except Exception:
        return False
    try:
        keys = {point_key(spec, r) for r in df[spec.variables].to_dict("records")}
    except (KeyError, ValueError, TypeError):
        return False
    return keys == {point_key(spec, p) for p in spec.points}


__all__ = ["preflight", "check_workers", "check_out", "PointLog", "partial_path", "point_key", "identity",
           "identity_path", "finished"]
