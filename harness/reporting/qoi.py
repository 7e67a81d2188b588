"""Quantities of interest: small expressions over a result DataFrame.

An expression is Python syntax over these names only:

* ``r["Instance.variable"]`` -- a result column as a numpy array (``r`` also answers ``in``);
* ``t`` -- the time array;
* reductions ``peak(x)`` (max |x|), ``rms(x)``, ``mean``, ``max``, ``min``, ``ptp`` (max - min), ``final(x)``
  (last value), ``at(x, time)`` (linear interpolation at a time), ``count_rises(x)`` (number of 0 -> nonzero
  transitions of a flag), ``sum``, ``abs``, ``sqrt``, ``where``;
* ``window(x, t0, t1)`` -- the part of ``x`` with ``t0 <= t <= t1``;
* ``rise_times("Instance.counter", t0, t1)`` -- the instants in ``[t0, t1]`` at which an event counter rose:
  where the result carries ``Instance.counter.rise_time`` (a drive FMU's: the instant on the drive's own step,
  read by a host at its coarser step) its value at each rising sample, else the rising sample's time (as
  ``at_rises(window(r["Instance.counter"], t0, t1), window(t, t0, t1))``);
* ``at_rises(s, x)`` -- the values of ``x`` at the samples where ``s`` increases from the previous sample: a
  0 -> 1 flag or an event counter (a flag already set at the first sample is not a rise here: inside a
  window it is a contact that began earlier);
  ``normalize(x)`` -- ``(x - min(x)) / ptp(x)`` (0 at the smallest, 1 at the largest value);
  ``between(x, lo, hi)`` -- the elementwise test ``lo <= x <= hi`` (count with ``sum``);
  ``on_durations(flag, time)`` -- for each rise of a 0/1 flag (the samples ``at_rises(flag, x)`` picks), the
  time from that sample to the next sample where the flag is 0 again: how long each contact lasted (``inf``
  for one still on at the last sample).

The reductions peak, rms, mean, max, min and ptp refuse an empty array unless given a default:
``peak(x, empty=0.0)``.

Example: the number of impacts in 0.4-1 s at intermediate rocker positions (10-90 % of the swing)::

    sum(between(at_rises(window(r["feeder.impact_count"], 0.4, 1.0),
                         normalize(window(r["feeder.rocker.phi"], 0.4, 1.0))), 0.1, 0.9))

Example: ``peak(window(r["fourbar.contact_force"], 0.5, 1.0))``.  Anything else (attributes, imports,
builtins) is refused, with the expression in the message.
"""
from __future__ import annotations

import ast

import numpy as np
import pandas as pd

_ALLOWED_NODES = (ast.Expression, ast.Call, ast.Name, ast.Load, ast.Constant, ast.Subscript, ast.BinOp,
                  ast.UnaryOp, ast.Compare, ast.BoolOp, ast.IfExp, ast.Tuple, ast.List, ast.operator,
                  ast.unaryop, ast.cmpop, ast.boolop, ast.Slice, ast.keyword)


class QoIError(ValueError):
    """A quantity-of-interest expression that cannot be evaluated (one line: :func:`harness.errors.single_line`)."""

    def __init__(self, *args):
        from harness.errors import single_line

        if args and isinstance(args[0], str):
            args = (single_line(args[0].strip()),) + args[1:]
        super().__init__(*args)


class _Columns:
    def __init__(self, df: pd.DataFrame, expr: str):
        self.df, self.expr = df, expr

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.df.columns:
            raise QoIError(f"quantity {self.expr!r}: no result column {name!r}")
        return self.df[name].to_numpy()

    def __contains__(self, name: str) -> bool:
        return name in self.df.columns


def _count_rises(x) -> int:
    b = np.asarray(x) != 0
    return int(np.count_nonzero(b[1:] & ~b[:-1]) + (1 if b.size and b[0] else 0))


def _at_rises(s, x) -> np.ndarray:
    s, x = np.asarray(s, dtype=float), np.asarray(x)
    if s.shape != x.shape:
        raise ValueError(f"at_rises: the two arrays differ in length ({s.size} and {x.size})")
    return x[1:][s[1:] > s[:-1]]


def _reduction(f):
    def g(x, empty=None):
        x = np.asarray(x)
        if x.size == 0:
            if empty is None:
                raise ValueError("reduction of an empty array (give empty=value for a default)")
            return float(empty)
        return float(f(x))
    return g


def _on_durations(flag, time) -> np.ndarray:
    flag, time = np.asarray(flag, dtype=float), np.asarray(time, dtype=float)
    if flag.shape != time.shape:
        raise ValueError(f"on_durations: the two arrays differ in length ({flag.size} and {time.size})")
    rises = np.flatnonzero(flag[1:] > flag[:-1]) + 1          # the samples at_rises uses
    offs = np.flatnonzero(flag == 0.0)
    if offs.size == 0:
        return np.full(rises.size, np.inf)
    nxt = np.searchsorted(offs, rises)                          # first sample after each rise with flag 0
    ends = np.where(nxt < offs.size, time[offs[np.minimum(nxt, offs.size - 1)]], np.inf)
    return ends - time[rises]


def _normalize(x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    span = float(np.ptp(x))
    if not span > 0.0:
        raise ValueError("normalize: the values are constant (or empty)")
    return (x - np.min(x)) / span


def _namespace(df: pd.DataFrame, expr: str) -> dict:
    t = df.index.to_numpy(dtype=float)

    def window(x, t0, t1):
        x = np.asarray(x)
        return x[(t >= t0) & (t <= t1)]

    def at(x, time):
        return float(np.interp(time, t, np.asarray(x, dtype=float)))

    def rise_times(name, t0, t1):
        inside = (t >= t0) & (t <= t1)
        count = _Columns(df, expr)[name]
        instants = df[f"{name}.rise_time"].to_numpy(dtype=float) if f"{name}.rise_time" in df.columns else t
        return _at_rises(count[inside], instants[inside])

    return {
        "r": _Columns(df, expr), "t": t,
        "peak": _reduction(lambda x: np.max(np.abs(x))), "rms": _reduction(lambda x: np.sqrt(np.mean(np.square(x)))),
        "mean": _reduction(np.mean), "max": _reduction(np.max), "min": _reduction(np.min), "ptp": _reduction(np.ptp), "final": lambda x: float(np.asarray(x)[-1]), "at": at,
        "window": window, "count_rises": _count_rises, "abs": np.abs, "sqrt": np.sqrt, "where": np.where,
        "sum": lambda x: float(np.sum(x)), "at_rises": _at_rises, "normalize": _normalize,
        "between": lambda x, lo, hi: (np.asarray(x) >= lo) & (np.asarray(x) <= hi),
        "on_durations": _on_durations, "rise_times": rise_times,
    }


def check(expr: str) -> ast.Expression:
    try:
        tree = ast.parse(expr, mode="eval")
    except SyntaxError as e:
        raise QoIError(f"quantity {expr!r}: not an expression ({e.msg})") from None
    for node in ast.walk(tree):
        if not isinstance(node, _ALLOWED_NODES):
            raise QoIError(f"quantity {expr!r}: {type(node).__name__} is not allowed")
    return tree


def evaluate(expr: str, df: pd.DataFrame) -> float:
    """Value of the expression on a result; a QoIError names the expression on any problem."""
    return float(_value(expr, df))


def value(expr: str, df: pd.DataFrame):
    """Value of the expression as it is: a number, or an array (one value per sample, or per event)."""
    return _value(expr, df)


def mask(expr: str, df: pd.DataFrame) -> np.ndarray:
    """The expression as one truth value per sample of ``df`` (e.g. ``between(r["bed.bed.s"], 0.08, 0.24)``:
    where a chart shades a zone); a QoIError names the expression when it is not one per sample."""
    value = np.asarray(_value(expr, df))
    if value.shape != (len(df),):
        raise QoIError(f"quantity {expr!r}: gives shape {value.shape}, not one value per sample ({len(df)})")
    return value.astype(bool)


def _value(expr: str, df: pd.DataFrame):
    tree = check(expr)
    ns = _namespace(df, expr)
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id not in ns:
            raise QoIError(f"quantity {expr!r}: unknown name {node.id!r}")
    try:
        value = eval(compile(tree, "<qoi>", "eval"), {"__builtins__": {}}, ns)  # noqa: S307 (names checked above)
    except QoIError:
        raise
    except Exception as e:  # empty window, shape mismatch, ...
        raise QoIError(f"quantity {expr!r}: {type(e).__name__}: {e}") from None
    return value


def columns(expr: str) -> list[str]:
    """Result columns an expression reads (so a run can record only those)."""
    out = []
    for node in ast.walk(check(expr)):
        if (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id == "r"
                and isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str)):
            out.append(node.slice.value)
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "rise_times"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            out.append(node.args[0].value)
    return out
