"""Error metrics of a co-simulation result against a reference (e.g. the monolithic reference).

:func:`error_metrics` compares the columns of a result with the same columns of a reference and returns,
per variable, the maximum and the RMS of the error, absolute and relative:

* The error is taken at the result's own communication points (a co-simulation only defines its outputs
  there).  The reference is read at those times by linear interpolation of its grid; when a result time
  lies on a reference grid point (fixed-step runs whose step is a multiple of the reference step) that is
  the reference value itself.  A result time outside the reference's time span is an error.
* ``max_abs = max |e|``; ``rms_abs = sqrt( (1/T) * integral e^2 dt )`` by the trapezoidal rule over the
  compared points (time-weighted, so variable-step results with uneven points are not biased toward where
  the steps were short; on an even grid it is the sample RMS with half weight on the two end points; one
  point: ``|e|``).
* Relative errors are norm ratios in the same norm, normalised by the REFERENCE over the compared time
  window on the reference's own grid: ``max_rel = max_abs / max |ref|``, ``rms_rel = rms_abs / rms(ref)``.
  They do not depend on how a run samples the window, so every method of a study shares one normaliser, and
  they stay finite where the reference crosses zero (a pointwise |e|/|ref| would not).  A reference that is
  identically zero gives ``nan`` (``0`` if the error is zero as well).
* ``t_start``/``t_end`` restrict the window (inclusive).  Non-finite result values make the metrics ``nan``.

A missing column (in the result or the reference) is a :class:`MetricsError` naming it.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

METRICS = ("max_abs", "rms_abs", "max_rel", "rms_rel")


class MetricsError(ValueError):
    """A comparison that cannot be made (missing column, disjoint time spans, empty window)."""


def _times(df: pd.DataFrame, what: str) -> np.ndarray:
    t = df.index.to_numpy(dtype=float)
    if t.size == 0:
        raise MetricsError(f"the {what} has no rows")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise MetricsError(f"the {what}'s time index is not strictly increasing")
    return t


def _column(df: pd.DataFrame, name: str, what: str) -> np.ndarray:
    if name not in df.columns:
        raise MetricsError(f"column {name!r} is not in the {what} (it has {len(df.columns)} columns, e.g. "
                           f"{', '.join(map(str, list(df.columns)[:4]))})")
    return df[name].to_numpy(dtype=float)


def _rms(t: np.ndarray, x: np.ndarray) -> float:
    """Time-weighted RMS by the trapezoidal rule (one point: |x|)."""
    if x.size == 1:
        return float(abs(x[0]))
    sq = x * x
    span = t[-1] - t[0]
    return float(math.sqrt(np.sum(0.5 * (sq[1:] + sq[:-1]) * np.diff(t)) / span))


def _ratio(num: float, den: float) -> float:
    if den > 0:
        return num / den
    return 0.0 if num == 0 else math.nan


def align(result: pd.DataFrame, reference: pd.DataFrame, columns, t_start: float | None = None,
          t_end: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, y_result, y_reference)``: the result's times inside the window and, per column (axis 1), the
    result values and the reference interpolated at those times."""
    columns = [columns] if isinstance(columns, str) else list(columns)
    if not columns:
        raise MetricsError("no columns to compare")
    tr = _times(result, "result")
    tf = _times(reference, "reference")
    lo = tr[0] if t_start is None else float(t_start)
    hi = tr[-1] if t_end is None else float(t_end)
    keep = (tr >= lo) & (tr <= hi)
    t = tr[keep]
    if t.size == 0:
        raise MetricsError(f"no result point in the window [{lo:g}, {hi:g}] s (result covers "
                           f"[{tr[0]:g}, {tr[-1]:g}] s)")
    slack = 1e-9 * max(1.0, abs(tf[-1]))
    if t[0] < tf[0] - slack or t[-1] > tf[-1] + slack:
        raise MetricsError(f"result times [{t[0]:g}, {t[-1]:g}] s are not inside the reference's time span "
                           f"[{tf[0]:g}, {tf[-1]:g}] s")
    y = np.empty((t.size, len(columns)))
    r = np.empty((t.size, len(columns)))
    for k, c in enumerate(columns):
        y[:, k] = _column(result, c, "result")[keep]
        r[:, k] = np.interp(t, tf, _column(reference, c, "reference"))
    return t, y, r


def error_metrics(result: pd.DataFrame, reference: pd.DataFrame, columns=None, t_start: float | None = None,
                  t_end: float | None = None) -> pd.DataFrame:
    """Per column (index ``variable``): ``max_abs``, ``rms_abs``, ``max_rel``, ``rms_rel``, ``t_max`` (time of
    the largest error), ``n`` (points compared) and ``t_last`` (last result time compared).

    ``columns``: a name or a list (default: every result column that the reference also has)."""
    if columns is None:
        columns = [c for c in result.columns if c in reference.columns]
        if not columns:
            raise MetricsError("the result and the reference have no column in common")
    columns = [columns] if isinstance(columns, str) else list(columns)
    t, y, r = align(result, reference, columns, t_start, t_end)
    tf = _times(reference, "reference")
    lo, hi = t[0] if t_start is None else float(t_start), t[-1] if t_end is None else float(t_end)
    win = (tf >= lo - 1e-12) & (tf <= hi + 1e-12)
    if not win.any():  # a window narrower than one reference step: use the aligned values
        win = None
    rows = []
    for k, c in enumerate(columns):
        e = y[:, k] - r[:, k]
        finite = bool(np.all(np.isfinite(e)))
        ref = _column(reference, c, "reference")
        tw, rw = (tf[win], ref[win]) if win is not None else (t, r[:, k])
        max_abs = float(np.max(np.abs(e))) if finite else math.nan
        rms_abs = _rms(t, e) if finite else math.nan
        rows.append(dict(variable=c, max_abs=max_abs, rms_abs=rms_abs,
                         max_rel=_ratio(max_abs, float(np.max(np.abs(rw)))) if finite else math.nan,
                         rms_rel=_ratio(rms_abs, _rms(tw, rw)) if finite else math.nan,
                         t_max=float(t[int(np.argmax(np.abs(e)))]) if finite else math.nan,
                         n=int(t.size), t_last=float(t[-1])))
    return pd.DataFrame(rows).set_index("variable")


__all__ = ["METRICS", "MetricsError", "align", "error_metrics"]
