"""Input signals, FMPy's way: a table of time and one column per free input, set on the FMUs at each
communication point before the step (``simulate(..., input=...)``, ``python -m harness run X --input FILE``).

The table is a structured numpy array (``fmpy.simulate_fmu``'s ``input``: a field ``time``, then one field per
input), a pandas DataFrame (a ``time`` column, or indexed by ``time`` as results are) or a CSV file of that
table.  Columns are ``Instance.variable``; a system of one FMU also takes the FMU's own names (as FMPy does).

Values between the rows are those of ``fmpy.simulation.Input``: a continuous Real input is interpolated
linearly; any other (a discrete Real, Integer, Boolean, String, Enumeration) holds the last row at or before the
time; before the first row the first value holds, after the last row the last.  Two rows at the same time are a
step: from that time on, the second row's value (the first row's at the very start of the table and while the
FMUs initialize).  The value set at a communication point holds over the step that follows.

A column may also name a parameter its FMU declares tunable (FMI 2.0 ``variability="tunable"``): it is set
through setReal between communication steps and held (a scenario's change of a tunable parameter goes so); a
fixed parameter is refused, naming it.

Refused in one line before the run: a column for an input the system connects, for a variable that is neither
an input nor a tunable parameter, or for no variable at all (with the nearest names); a time column that decreases or is not finite; a
value that is not finite, not of the input's type, or outside the ``min``/``max`` its FMU declares.
"""
from __future__ import annotations

import difflib
import math
from pathlib import Path

import numpy as np

from harness.master.clock import NS
from harness.errors import SystemDescriptionError

__all__ = ["Signals", "read_table", "full_name"]


def full_name(system, name: str) -> str:
    """``Instance.variable`` of ``name``: as it is, except in a system of one instance, where a name that does
    not start with that instance's name and a dot is the FMU's own variable name (FMPy's names)."""
    name = str(name)
    if len(system.instances) == 1:
        inst = system.instances[0].name
        if not name.startswith(inst + "."):
            return f"{inst}.{name}"
    return name


def read_table(source) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(times [s], {column: values}) of an input table: a structured numpy array, a DataFrame or a CSV file."""
    import pandas as pd

    if isinstance(source, (str, Path)):
        path = Path(source)
        if not path.is_file():
            raise SystemDescriptionError(f"input file {path} does not exist")
        try:
            source = pd.read_csv(path, skipinitialspace=True)
        except Exception as e:  # an empty or unreadable file: one line naming it
            raise SystemDescriptionError(f"input file {path}: cannot be read as CSV ({type(e).__name__}: "
                                         f"{' '.join(str(e).split())})") from None
        where = f"input file {path}"
    else:
        where = "input"
    if isinstance(source, pd.DataFrame):
        if "time" not in source.columns and source.index.name == "time":
            source = source.reset_index()
        columns = {str(c): source[c].to_numpy() for c in source.columns}
    elif isinstance(source, np.ndarray) and source.dtype.names:
        columns = {str(n): np.asarray(source[n]) for n in source.dtype.names}
    else:
        raise SystemDescriptionError(f"{where}: {type(source).__name__} is not an input table: give a structured numpy "
                           f"array (fmpy.simulate_fmu's input), a pandas DataFrame or a CSV file, with a 'time' "
                           f"column and one column per input")
    if "time" not in columns:
        raise SystemDescriptionError(f"{where}: no 'time' column (columns: {', '.join(columns) or 'none'}); the table "
                                     f"has a 'time' column [s] and one column per input")
    try:
        times = np.asarray(columns.pop("time"), dtype=float)
    except (TypeError, ValueError):
        raise SystemDescriptionError(f"{where}: the 'time' column holds values that are not numbers") from None
    if times.size == 0:
        raise SystemDescriptionError(f"{where}: the table has no rows")
    if not np.isfinite(times).all():
        k = int(np.argmax(~np.isfinite(times)))
        raise SystemDescriptionError(f"{where}: time = {float(times[k])!r} in row {k + 1} is not a finite number [s]")
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise SystemDescriptionError(f"{where}: the time column decreases in row {k + 1} ({float(times[k])!r} s after "
                                     f"{float(times[k - 1])!r} s); it must not (two rows at the same time are a step)")
    if not columns:
        raise SystemDescriptionError(f"{where}: no column besides 'time': one column per input is needed")
    return times, columns


def _typed(values: np.ndarray, v, ref: str, times: np.ndarray, origin: str = "", fmu: str = "its FMU") -> list:
    """The column as values of the input's FMI type; the first that does not fit is a one-line error
    (``origin``: where the table came from, e.g. ``input file x.csv: ``; ``fmu``: the FMU's model name)."""
    out = []
    for t, x in zip(times, values.tolist()):
        where = f"{origin}input signal {ref!r} = {x!r} at t = {t:g} s"
        if v.type == "String":
            out.append(str(x))
            continue
        if isinstance(x, str) and v.type == "Boolean" and x.strip().lower() in ("true", "false"):
            x = x.strip().lower() == "true"
        if isinstance(x, str) or x is None:
            raise SystemDescriptionError(f"{where}: not a number ({v.name} is {v.type})")
        x = float(x) if v.type == "Real" else x
        if not math.isfinite(float(x)):
            raise SystemDescriptionError(f"{where}: not a finite number")
        if v.type in ("Integer", "Enumeration"):
            if float(x) != int(x):
                raise SystemDescriptionError(f"{where}: not an integer ({v.name} is {v.type})")
            x = int(x)
        elif v.type == "Boolean":
            if x not in (0, 1):
                raise SystemDescriptionError(f"{where}: not a Boolean (allowed: true/false, 1/0)")
            x = bool(x)
        lo, hi = getattr(v, "min", None), getattr(v, "max", None)
        lo = -math.inf if lo in (None, "") else float(lo)
        hi = math.inf if hi in (None, "") else float(hi)
        if v.type != "Boolean" and not lo <= float(x) <= hi:
            raise SystemDescriptionError(f"{where}: outside the range [{lo:g}, {hi:g}] that {fmu} declares for "
                                         f"{v.name}")
        items = getattr(getattr(v, "declaredType", None), "items", None) if v.type == "Enumeration" else None
        if items and x not in {int(i.value) for i in items}:
            raise SystemDescriptionError(f"{where}: not one of the values of its enumeration ("
                                         f"{', '.join(f'{i.value} = {i.name}' for i in items)})")
        out.append(x)
    return out


def _nearest(name: str, candidates: list[str]) -> str:
    close = difflib.get_close_matches(name, candidates, n=3, cutoff=0.5)
    return f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""


class Signals:
    """A checked input table bound to a system: :meth:`start_values` for initialization, :meth:`apply` at each
    communication point (after :meth:`bind` to the run's FMU instances)."""

    def __init__(self, system, model_descriptions: dict, connections, source):
        times, columns = read_table(source)
        origin = f"input file {source}: " if isinstance(source, (str, Path)) else ""
        self.t_ns = np.round(times * NS).astype(np.int64)
        self.n = len(times)
        targets = {c.target: c.source for c in connections}
        names = [i.name for i in system.instances]
        self.columns: list[tuple[str, str, bool, list]] = []  # (instance, variable, continuous, values)
        seen: dict[str, str] = {}
        for column, values in columns.items():
            ref = full_name(system, column)
            inst, _, var = ref.partition(".")
            if inst not in model_descriptions:
                raise SystemDescriptionError(f"input signal {column!r}: unknown instance "
                                             f"{inst!r}{_nearest(inst, names)} "
                                             f"(instances: {', '.join(names)}; write 'Instance.variable')")
            md = model_descriptions[inst]
            variables = {v.name: v for v in md.modelVariables}
            inputs = [v.name for v in md.modelVariables if v.causality == "input"]
            free = [n for n in inputs if f"{inst}.{n}" not in targets]
            listed = f"free inputs of {inst}: {', '.join(free) or 'none'}"
            v = variables.get(var)
            if v is None:
                near = _nearest(var, inputs) or _nearest(var, list(variables))
                raise SystemDescriptionError(f"input signal {column!r}: FMU {md.modelName} of instance {inst} has no "
                                             f"variable {var!r}{near}; {listed}")
            tunable = v.causality == "parameter" and v.variability == "tunable"
            if v.causality == "parameter" and not tunable:
                raise SystemDescriptionError(f"input signal {column!r}: parameter {var} of instance {inst} is not "
                                             f"tunable "
                                   f"(its FMU declares variability {v.variability!r}): it cannot change during the "
                                   f"run; set it before the run (start_values, --set), or drive a free input or a "
                                   f"tunable parameter ({listed})")
            if v.causality != "input" and not tunable:
                article = "an" if v.causality[:1] in "aeiou" else "a"
                raise SystemDescriptionError(f"input signal {column!r}: {var} of instance {inst} is {article} "
                                             f"{v.causality}, "
                                   f"not an input; a signal drives inputs and tunable parameters only ({listed})")
            if ref in targets:
                raise SystemDescriptionError(f"input signal {column!r}: input {ref} is connected from {targets[ref]}; "
                                             f"a "
                                             f"signal drives a free input only ({listed})")
            if ref in seen:
                raise SystemDescriptionError(f"input signal {column!r}: input {ref} is given twice (also as "
                                             f"{seen[ref]!r})")
            seen[ref] = column
            continuous = v.type == "Real" and v.variability not in ("discrete", "tunable")
            self.columns.append((inst, var, continuous, _typed(np.asarray(values), v, ref, times, origin,
                                                               f"FMU {md.modelName} of instance {inst}")))
        self._bound: list = []
        times, counts = np.unique(self.t_ns, return_counts=True)
        self.step_times = frozenset(int(t) for t in times[counts > 1])  # ns: where the table steps

    def next_time(self, t_ns: int) -> int | None:
        """The table's first row time after ``t_ns`` [ns] (a step, a ramp's corner), None after the last: a
        variable-step run lands a communication point on it."""
        k = int(np.searchsorted(self.t_ns, t_ns, "right"))
        return int(self.t_ns[k]) if k < self.n else None

    @property
    def instances(self) -> set[str]:
        """The instances that have a signal."""
        return {inst for inst, _, _, _ in self.columns}

    @property
    def names(self) -> list[str]:
        """``Instance.variable`` of every signal."""
        return [f"{inst}.{var}" for inst, var, _, _ in self.columns]

    def values(self, t_ns: int, after_event: bool = True) -> list:
        """Every signal's value at ``t_ns`` [ns], in the order of :attr:`names` (see the module's rules)."""
        T = self.t_ns
        left = int(np.searchsorted(T, t_ns, "left"))
        out = []
        for _, _, continuous, v in self.columns:
            if self.n == 1 or left == 0:
                out.append(v[0])
            elif left == self.n:
                out.append(v[-1])
            elif T[left] == t_ns:  # on a row: after a step its last row, before it its first
                out.append(v[int(np.searchsorted(T, t_ns, "right")) - 1] if after_event else
                           v[left] if continuous else v[left - 1])
            elif continuous:
                t0, t1 = T[left - 1], T[left]
                w1 = (t_ns - t0) / (t1 - t0)
                out.append((1.0 - w1) * v[left - 1] + w1 * v[left])
            else:
                out.append(v[left - 1])
        return out

    def start_values(self, t_ns: int) -> dict[str, dict]:
        """``{instance: {input: value}}`` at the start (before a step there): set with the parameters, before
        the FMUs initialize."""
        out: dict[str, dict] = {}
        for (inst, var, _, _), value in zip(self.columns, self.values(t_ns, after_event=False)):
            out.setdefault(inst, {})[var] = value
        return out

    def bind(self, fmus: dict) -> None:
        """Resolve the signals on the run's FMU instances (Real ones in one block per instance)."""
        by_inst: dict[str, list[int]] = {}
        for k, (inst, var, _, _) in enumerate(self.columns):
            by_inst.setdefault(inst, []).append(k)
        self._bound = []
        for inst, ks in by_inst.items():
            fmu = fmus[inst]
            reals = [k for k in ks if fmu.variables[self.columns[k][1]].type == "Real"]
            others = [(k, self.columns[k][1]) for k in ks if k not in reals]
            block = fmu.reals([self.columns[k][1] for k in reals])
            self._bound.append((fmu, block, reals, others))

    def apply(self, t_ns: int) -> None:
        """Set every signal's value at communication point ``t_ns`` (after a step at that time)."""
        values = self.values(t_ns)
        for fmu, block, reals, others in self._bound:
            if reals:
                fmu.set_list(block, [float(values[k]) for k in reals])
            for k, var in others:
                fmu.set_value(var, values[k])
