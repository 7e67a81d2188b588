"""Results: recording as an observer of the stepping loop, one DataFrame type, CSV (or Parquet) output.

A result is a pandas DataFrame indexed by time (index name ``time``) with columns ``Instance.variable``.
``df.attrs`` carries ``complete`` (False if the run stopped early), ``error`` (the one-line reason),
``system``, ``master``, ``steps`` (accepted communication steps), ``wall_time`` (initialisation and stepping
[s]) with ``init_time`` (the initialisation's share; NaN if it did not finish), ``cpu_time`` (the process's
CPU time over the same span [s]: less disturbed than the wall time by other processes) and ``bonds`` (a
:class:`BondLog`: power on each side of every power bond and the accumulated coupling energy error; see
:func:`bond_energy`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from harness.errors import SystemDescriptionError


class KeptInAttrs:
    """A value kept in a result's ``df.attrs``, immutable once made: pandas copies ``attrs`` with every new
    frame, so its copies are the object itself (cheap) and it equals itself only."""

    def __deepcopy__(self, memo):
        return self

    def __copy__(self):
        return self

    def __eq__(self, other):
        return self is other

    __hash__ = object.__hash__


class BondLog(KeptInAttrs):
    """Per power bond, at each recorded communication point: ``P_out`` (tau held by the motion-output side
    times its own speed, trapezoidal mean over the last step), ``P_in`` (the motion-input side's torque,
    trapezoidal mean, times the speed it held) [W] and ``energy_error`` = integral of ``P_out - P_in`` from
    the start [J].  Positive ``energy_error``: the coupling has put energy into the system.

    Immutable once the run is over; copies and comparisons are by identity (cheap in ``df.attrs``)."""

    def __init__(self, labels: list[str], time: np.ndarray, p_out: np.ndarray, p_in: np.ndarray,
                 energy: np.ndarray):
        self.labels, self.time, self.p_out, self.p_in, self.energy = labels, time, p_out, p_in, energy

    def frame(self, label: str) -> pd.DataFrame:
        if label not in self.labels:
            raise KeyError(f"no power bond {label!r} (bonds: {', '.join(self.labels)})")
        k = self.labels.index(label)
        return pd.DataFrame({"P_out": self.p_out[:, k], "P_in": self.p_in[:, k],
                             "mismatch": self.p_out[:, k] - self.p_in[:, k], "energy_error": self.energy[:, k]},
                            index=pd.Index(self.time, name="time"))


def bond_energy(result: pd.DataFrame, label: str | None = None) -> pd.DataFrame:
    """Power on each side of a power bond and its accumulated coupling energy error, from a result.

    ``label`` is ``"a.port->b.port"`` (default: the only bond).  Columns P_out, P_in, mismatch [W],
    energy_error [J], indexed by time."""
    log = result.attrs.get("bonds")
    if not isinstance(log, BondLog) or not log.labels:
        raise KeyError("this result has no power bonds")
    if label is None:
        if len(log.labels) != 1:
            raise KeyError(f"several power bonds, name one of: {', '.join(log.labels)}")
        label = log.labels[0]
    return log.frame(label)


def _states_of_silent(master) -> list[str]:
    """For instances without outputs (a plain model of one's own, a model exchange FMU), their continuous
    local variables (the states, as such models declare them); a system with nothing at all to record is
    refused in one line that says what to ask for."""
    columns, silent = [], []
    for it in master.insts:
        variables = it.fmu.md.modelVariables
        if any(v.causality == "output" for v in variables):
            continue
        found = [f"{it.name}.{v.name}" for v in variables if v.causality == "local" and v.variability == "continuous"]
        columns += found
        if not found:
            silent.append(it)
    if silent and not master.signal_names and not columns:
        it = silent[0]
        named = [v.name for v in it.fmu.md.modelVariables][:6]
        raise SystemDescriptionError(f"instance {it.name} ({it.fmu.md.modelName}) has no outputs and no continuous "
                                     f"local "
                                     f"variables to record: ask for variables with output=[...] (CLI: --output), e.g. "
                                     f"{', '.join(f'{it.name}.{n}' for n in named) or 'none: it declares no variable'}")
    return columns


class Recorder:
    """Records the requested variables at every accepted communication point.

    ``columns``: ``Instance.variable`` names (Real outputs come from the master's signal vector; other
    variables, e.g. inputs or local states, are read from the FMU; Integer/Enumeration columns come out as
    int64, Boolean as bool, String as object); None records every output.  Buffers are
    preallocated for ``expected_rows`` and doubled when a variable-step run needs more."""

    def __init__(self, master, columns: list[str] | None = None, expected_rows: int = 1024):
        self.master = master
        if columns is None:  # every output: the Real ones (signal vector), then the others
            columns = list(master.signal_names) + [
                f"{it.name}.{v.name}" for it in master.insts for v in it.fmu.md.modelVariables
                if v.causality == "output" and v.type != "Real"]
            columns += _states_of_silent(master)
        seen = set()
        self.columns = [c for c in columns if not (c in seen or seen.add(c))]
        self._from_y = []      # (column position, y index)
        self._extra = []       # (instance, RealBlock, column positions)
        self._typed = []       # (instance, variable, column position, type, values) of non-Real variables
        by_inst: dict[str, list[tuple[int, str]]] = {}
        for k, c in enumerate(self.columns):
            if c in master.signal_index:
                self._from_y.append((k, master.signal_index[c]))
                continue
            inst, dot, var = c.partition(".")
            if not dot or inst not in master.index:
                raise SystemDescriptionError(f"output {c!r}: unknown instance {inst!r} (write 'Instance.variable')")
            fmu = master.insts[master.index[inst]].fmu
            v = fmu.variables.get(var)
            if v is None:
                raise SystemDescriptionError(f"output {c!r}: FMU {fmu.md.modelName} of instance {inst} has no "
                                             f"variable {var!r}")
            if v.type != "Real":
                self._typed.append((fmu, var, k, v.type, []))
                continue
            by_inst.setdefault(inst, []).append((k, var))
        for inst, items in by_inst.items():
            fmu = master.insts[master.index[inst]].fmu
            self._extra.append((fmu, fmu.reals([v for _, v in items]), np.array([k for k, _ in items])))
        self._cols_y = np.array([k for k, _ in self._from_y], dtype=np.intp)
        self._idx_y = np.array([i for _, i in self._from_y], dtype=np.intp)
        self._y_first = [k for k, _ in self._from_y] == list(range(len(self._from_y)))
        n = max(2, int(expected_rows))
        self.time = np.empty(n)
        self.data = np.empty((n, len(self.columns)))
        self.bonds = np.empty((n,) + master.bond_log.shape)  # per row: P_out, P_in, energy of every bond
        self.rows = 0

    def record(self, t: float) -> None:
        k = self.rows
        if k == len(self.time):
            self._grow()
        self.time[k] = t
        row = self.data[k]
        if self._y_first:  # the columns from y come first, in order: one gather into the row
            np.take(self.master.y, self._idx_y, out=row[:len(self._idx_y)])
        else:
            row[self._cols_y] = self.master.y[self._idx_y]
        fresh = getattr(self.master, "fresh", None)   # None: every instance is at a point of its own (one rate)
        if fresh is None or k == 0:
            for fmu, block, cols in self._extra:
                row[cols] = fmu.get(block)
            for fmu, var, _, _, values in self._typed:
                values.append(fmu.get_value(var))
        else:   # an instance amid its own step (harness.master.multirate) keeps the values of its last point
            for fmu, block, cols in self._extra:
                row[cols] = fmu.get(block) if fmu.name in fresh else self.data[k - 1, cols]
            for fmu, var, _, _, values in self._typed:
                values.append(fmu.get_value(var) if fmu.name in fresh else values[-1])
        if self.bonds.shape[2]:
            self.bonds[k] = self.master.bond_log
        self.rows = k + 1

    def _grow(self) -> None:
        for name in ("time", "data", "bonds"):
            a = getattr(self, name)
            b = np.empty((2 * a.shape[0],) + a.shape[1:])
            b[: a.shape[0]] = a
            setattr(self, name, b)

    def frame(self, complete: bool = True, error: str = "", **attrs) -> pd.DataFrame:
        """The result; the recorder hands its buffers over (no copy when they are full, as in a fixed-step run:
        the run never holds its result twice) and is done."""
        n = self.rows
        data = self.data if n == len(self.data) else self.data[:n].copy()
        time = self.time if n == len(self.time) else self.time[:n].copy()
        df = pd.DataFrame(data, columns=self.columns, index=pd.Index(time, name="time", copy=False), copy=False)
        for _, var, k, kind, values in self._typed:  # the FMI type's dtype: int64, bool or object (String)
            dtype = {"Integer": np.int64, "Enumeration": np.int64, "Boolean": bool}.get(kind, object)
            df[self.columns[k]] = np.array(values[:n], dtype=dtype)
        df.attrs.update(attrs)
        df.attrs["complete"] = bool(complete)
        df.attrs["error"] = error
        b = self.bonds[:n]
        df.attrs["bonds"] = BondLog(list(self.master.bond_labels), time, b[:, 0].copy(), b[:, 1].copy(),
                                    b[:, 2].copy())
        return df


def parquet_engine() -> str | None:
    """The Parquet engine pandas would use here (``"pyarrow"`` or ``"fastparquet"``), None if neither imports:
    Parquet is offered only where it can be written, no dependency is added for it."""
    import importlib.util

    for name in ("pyarrow", "fastparquet"):
        if importlib.util.find_spec(name) is not None:
            return name
    return None


def result_format(path: str | Path, option: str = "--out") -> str:
    """``"csv"`` or ``"parquet"`` from ``path``'s suffix; any other suffix, or .parquet without an engine, is a
    one-line :class:`SystemDescriptionError` naming the option, the path and the suffixes this installation writes."""
    path = Path(path)
    suffix = path.suffix.lower()
    engine = parquet_engine()
    allowed = ".csv or .parquet" if engine else ".csv (.parquet needs pyarrow or fastparquet installed)"
    if suffix == ".csv" or (suffix == ".parquet" and engine):
        return suffix[1:]
    if suffix == ".parquet":
        raise SystemDescriptionError(f"{option} {path}: Parquet needs pyarrow or fastparquet, neither is installed; "
                                     f"use .csv")
    raise SystemDescriptionError(f"{option} {path}: unknown result format {path.suffix or '(no suffix)'!r}: use "
                                 f"{allowed}")


def check_writable(path: str | Path, option: str, folder: bool = False) -> Path:
    """Before a run: ``path`` (a file, or with ``folder`` a folder to write into) can be written.  A missing
    folder is made (as ``sweep`` does); a folder that cannot be made or written, or a path of the wrong kind,
    is a one-line :class:`SystemDescriptionError` naming the option and the path, so nothing is computed for a result
    that could not be kept.  Returns the path."""
    path = Path(path)
    where = path if folder else path.parent
    if not folder and path.is_dir():
        raise SystemDescriptionError(f"{option} {path}: is a folder, give a file name")
    blocking = next((a for a in (where, *where.parents) if a.exists() and not a.is_dir()), None)
    if blocking is not None:
        raise SystemDescriptionError(f"{option} {path}: {blocking} is a file, not a folder")
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise SystemDescriptionError(f"{option} {path}: cannot create folder {where}: {e.strerror or e}") from None
    probe = where / f".{path.name}.probe"
    try:
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise SystemDescriptionError(f"{option} {path}: folder {where} is not writable: {e.strerror or e}") from None
    return path


def write_result(result: pd.DataFrame, path: str | Path, units: bool = False) -> Path:
    """Write a result as CSV (:func:`to_csv`) or Parquet, by the suffix (:func:`result_format`).  The file
    appears whole or not at all (written beside it, then renamed): a run stopped while writing never leaves
    a cut file under a result's name.  Parquet keeps the index ``time`` and the plain attrs (units, complete,
    error, master, step ...); ``units`` (a second header row) concerns CSV only."""
    import os

    path = Path(path)
    kind = result_format(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.writing")
    try:
        if kind == "parquet":
            plain = result.copy(deep=False)
            plain.attrs = {k: v for k, v in result.attrs.items() if isinstance(v, (str, int, float, bool, dict))}
            plain.to_parquet(tmp, engine=parquet_engine())
        else:
            to_csv(result, tmp, units=units)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def to_csv(result: pd.DataFrame, path: str | Path, units: bool = False) -> Path:
    """Write a result as CSV with a leading ``time`` column.  ``units``: a second header row with each
    column's unit from ``result.attrs["units"]`` (time in s; '' where none is declared), read back by
    :func:`read_csv` or ``pandas.read_csv(path, header=[0, 1], index_col=0)``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not units:
        result.to_csv(path, index=True, index_label="time")
        return path
    known = result.attrs.get("units") or {}
    with open(path, "w", newline="") as f:
        f.write(",".join(["time", *map(str, result.columns)]) + "\n")
        f.write(",".join(["s", *((known.get(c, "") or "-") for c in result.columns)]) + "\n")
        result.to_csv(f, index=True, header=False)
    return path


def read_csv(path: str | Path) -> pd.DataFrame:
    """Read a CSV written by :func:`to_csv` back into the result shape (a units row goes to
    ``attrs["units"]``)."""
    with open(path) as f:
        f.readline()
        second = f.readline()
    if second.startswith("s,"):
        raw = pd.read_csv(path, header=[0, 1], index_col=0)
        df = raw.copy()
        df.columns = [c for c, _ in raw.columns]
        df.index.name = "time"
        df.attrs["units"] = {c: ("" if u == "-" else u) for c, u in raw.columns}
        return df
    return pd.read_csv(path, index_col="time")


__all__ = ["BondLog", "Recorder", "bond_energy", "to_csv", "read_csv", "write_result", "result_format",
           "check_writable", "parquet_engine"]
