"""Quantities of interest (:mod:`harness.reporting.qoi`) of many variants, reduced as a batch run goes
(:class:`Reducers`), so a thousand variants need not keep a thousand time series.

Each expression is read once (:func:`plan`):

* **streamed** when every column it reads enters through ``peak``, ``max``, ``min``, ``ptp`` or ``final`` of the
  column or of ``window(column, t0, t1)`` with constant bounds, and the rest is arithmetic on such values and
  constants: each reduction is kept per variant as the rows come (a running maximum, minimum, last value), O(1)
  memory, and the expression is evaluated on those values at the end.  The values are the numbers the
  expression gives on the whole result: a maximum or a minimum does not depend on the order of the rows;
* **recorded** otherwise: the columns it reads are kept, but only the rows inside the span of time it reads
  (every read inside ``window(..., t0, t1)`` with constant bounds: their union; else the whole run), and the
  expression is evaluated at the end on a frame of those rows by :func:`harness.reporting.qoi.evaluate` itself.
  A windowed array is the same array on the part of the result as on the whole.

An expression whose value cannot be computed gives its one-line :class:`~harness.reporting.qoi.QoIError`, as on
a whole result.
"""
from __future__ import annotations

import ast
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from harness.reporting import qoi

STREAMED = ("peak", "max", "min", "ptp", "final")
_ARITH = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Load, ast.operator, ast.unaryop)


@dataclass(frozen=True)
class Plan:
    """How one expression is reduced: ``reductions`` (kind, column, t0, t1) streamed, or ``columns`` recorded over
    ``span`` (t0, t1; None: the whole run)."""
    expr: str
    streamed: bool
    reductions: tuple = ()
    columns: tuple = ()
    span: tuple | None = None


def _constant(node) -> float | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return float(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _constant(node.operand)
        return None if v is None else (-v if isinstance(node.op, ast.USub) else v)
    return None


def _column(node) -> str | None:
    """``r["name"]`` -> name."""
    if (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id == "r"
            and isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str)):
        return node.slice.value
    return None


def _window(node):
    """``window(r["c"], t0, t1)`` -> (c, t0, t1), ``r["c"]`` -> (c, -inf, inf); None otherwise."""
    c = _column(node)
    if c is not None:
        return c, -math.inf, math.inf
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "window"
            and len(node.args) == 3 and not node.keywords):
        c, a, b = _column(node.args[0]), _constant(node.args[1]), _constant(node.args[2])
        if c is not None and a is not None and b is not None:
            return c, a, b
    return None


def _reduction(node):
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in STREAMED
            and len(node.args) == 1 and not node.keywords):
        w = _window(node.args[0])
        if w is not None:
            return (node.func.id,) + w
    return None


def _streamable(node, found: list) -> bool:
    red = _reduction(node)
    if red is not None:
        found.append(red)
        return True
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("sqrt", "abs") \
            and len(node.args) == 1 and not node.keywords:
        return _streamable(node.args[0], found)
    if isinstance(node, _ARITH) and not isinstance(node, ast.Name):
        return all(_streamable(child, found) for child in ast.iter_child_nodes(node))
    return False


def _span(tree) -> tuple | None:
    """The union of the constant windows every read of a column or of ``t`` lies in; None: the whole run."""
    lo, hi = math.inf, -math.inf

    def visit(node, inside) -> bool:
        nonlocal lo, hi
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "window" \
                and len(node.args) == 3 and not node.keywords:
            a, b = _constant(node.args[1]), _constant(node.args[2])
            if a is not None and b is not None:
                lo, hi = min(lo, a), max(hi, b)
                return visit(node.args[0], True) and all(visit(n, inside) for n in node.args[1:])
        if _column(node) is not None or (isinstance(node, ast.Name) and node.id == "t"):
            return inside
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("rise_times", "at"):
            return False     # reads the whole time axis (a counter's instants; interpolation's neighbours)
        return all(visit(child, inside) for child in ast.iter_child_nodes(node))

    whole = visit(tree, False)
    return (lo, hi) if whole and lo <= hi else None


def plan(expr: str) -> Plan:
    """How ``expr`` is reduced (module docstring); a QoIError for an expression :mod:`qoi` refuses."""
    tree = qoi.check(expr)
    found: list = []
    if _streamable(tree.body, found) and found:
        return Plan(expr, True, tuple(dict.fromkeys(found)))
    return Plan(expr, False, columns=tuple(dict.fromkeys(qoi.columns(expr))), span=_span(tree))


class Reducers:
    """The expressions ``exprs`` (name -> expression) of ``n`` variants, fed row by row (:meth:`row`) with the
    batch's signals (signals x alive variants), read per variant at the end (:meth:`values`)."""

    def __init__(self, exprs: dict, signal_index: dict, n: int):
        self.plans = {name: plan(e) for name, e in exprs.items()}
        self.n = n
        for p in self.plans.values():
            for c in (p.columns if not p.streamed else [r[1] for r in p.reductions]):
                if c not in signal_index:
                    raise qoi.QoIError(f"quantity {p.expr!r}: no result column {c!r}")
        keys = {r for p in self.plans.values() if p.streamed for r in p.reductions}
        self.keys = sorted(keys)
        self._idx = np.array([signal_index[k[1]] for k in self.keys], dtype=np.intp)
        self._lo = np.array([k[2] for k in self.keys]) if keys else np.zeros(0)
        self._hi = np.array([k[3] for k in self.keys]) if keys else np.zeros(0)
        m = len(self.keys)
        self.hi_v = np.full((m, n), -np.inf)      # running max (of |x| for peak)
        self.lo_v = np.full((m, n), np.inf)       # running min
        self.last = np.full((m, n), np.nan)
        self.seen = np.zeros((m, n), dtype=bool)
        self.nan = np.zeros((m, n), dtype=bool)   # a NaN seen: max and min are NaN, as numpy's
        self._abs = np.array([k[0] == "peak" for k in self.keys], dtype=bool)
        recorded = [p for p in self.plans.values() if not p.streamed]
        cols = sorted({c for p in recorded for c in p.columns})
        self.rec_cols = cols
        self._rec_idx = np.array([signal_index[c] for c in cols], dtype=np.intp)
        spans = [p.span for p in recorded]
        self.rec_span = (None if any(s is None for s in spans) or not spans else
                         (min(s[0] for s in spans), max(s[1] for s in spans)))
        self.rec_rows: list = []      # (row index, time, values cols x n)

    def columns(self) -> list[str]:
        """The result columns the expressions read."""
        return sorted({k[1] for k in self.keys} | set(self.rec_cols))

    def row(self, t: float, Y: np.ndarray, alive: np.ndarray, k: int, last: bool) -> None:
        """Row ``k`` at time ``t``: ``Y`` the batch's signals (signals x len(alive))."""
        if self.keys:
            inside = (self._lo <= t) & (t <= self._hi)
            if inside.any():
                rows = np.flatnonzero(inside)
                x = Y[self._idx[rows]]
                x = np.where(self._abs[rows][:, None], np.abs(x), x)
                sub = np.ix_(rows, alive)
                self.hi_v[sub] = np.maximum(self.hi_v[sub], x)
                self.lo_v[sub] = np.minimum(self.lo_v[sub], x)
                self.nan[sub] |= np.isnan(x)
                self.last[sub] = x
                self.seen[sub] = True
        if self.rec_cols and (self.rec_span is None or self.rec_span[0] <= t <= self.rec_span[1]):
            values = np.full((len(self.rec_cols), self.n), np.nan)
            values[:, alive] = Y[self._rec_idx]
            self.rec_rows.append((k, t, values))

    def values(self, v: int, time: np.ndarray, out: dict | None = None) -> dict:
        """name -> value of variant ``v``, whose rows are ``time`` (those recorded while it ran), filled into
        ``out`` in the expressions' order; a value that cannot be computed raises its QoIError (those before it
        are in ``out``)."""
        out = {} if out is None else out
        frame = None
        for name, p in self.plans.items():
            if p.streamed:
                out[name] = self._streamed(p, v)
                continue
            if frame is None:
                n = len(time)
                rows = [(t, vals[:, v]) for k, t, vals in self.rec_rows if k < n]
                frame = pd.DataFrame(np.array([r[1] for r in rows]).reshape(len(rows), len(self.rec_cols)),
                                     columns=self.rec_cols, index=pd.Index([r[0] for r in rows], name="time"))
            out[name] = qoi.evaluate(p.expr, frame)
        return out

    def _streamed(self, p: Plan, v: int) -> float:
        got = {}
        for key in p.reductions:
            j = self.keys.index(key)
            if not self.seen[j, v]:
                raise qoi.QoIError(f"quantity {p.expr!r}: ValueError: reduction of an empty array (give empty=value "
                                   f"for a default)")
            kind = key[0]
            if kind == "final":
                got[key] = float(self.last[j, v])
            elif self.nan[j, v]:
                got[key] = math.nan
            elif kind in ("peak", "max"):
                got[key] = float(self.hi_v[j, v])
            elif kind == "min":
                got[key] = float(self.lo_v[j, v])
            else:
                got[key] = float(self.hi_v[j, v] - self.lo_v[j, v])
        try:
            return float(_evaluate(qoi.check(p.expr).body, got))
        except (ArithmeticError, ValueError, TypeError) as e:   # as qoi.evaluate words it on a whole result
            raise qoi.QoIError(f"quantity {p.expr!r}: {type(e).__name__}: {e}") from None


def _evaluate(node, got: dict):
    red = _reduction(node)
    if red is not None:
        return got[red]
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.UnaryOp):
        x = _evaluate(node.operand, got)
        return -x if isinstance(node.op, ast.USub) else (+x if isinstance(node.op, ast.UAdd) else not x)
    if isinstance(node, ast.BinOp):
        a, b = _evaluate(node.left, got), _evaluate(node.right, got)
        return _BINOPS[type(node.op)](a, b)
    if isinstance(node, ast.Call):     # sqrt, abs of a streamed value (numpy's, as qoi's namespace has them)
        x = _evaluate(node.args[0], got)
        return np.sqrt(x) if node.func.id == "sqrt" else np.abs(x)
    raise qoi.QoIError(f"quantity: {ast.dump(node)} cannot be streamed")


_BINOPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a ** b, ast.Mod: lambda a, b: a % b,
           ast.FloorDiv: lambda a, b: a // b}


__all__ = ["Reducers", "Plan", "plan", "STREAMED"]
