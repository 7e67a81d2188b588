"""Charts of a result, drawn for a press engineer: Matplotlib, written as PNG and SVG.

``run ... --plot DIR`` writes two figures (:func:`plot_result`), as PNG (and SVG with ``--svg``):

* ``<system>.png``: the signals over time, one panel each, titled by the signal and its meaning with its
  unit ("Bed position s [m]"), with time ticks on every panel.  The parts of the machine cycle the system
  declares (``System.chart.zones``: the printing zone, a dwell) are shaded where the result says they are,
  and each scene's time window is a named bar along the top of the panels of the columns it reads.
* ``<system>_cycle.png``: the same signals over the last complete revolution of the main shaft against the
  crank angle in degrees, as the seeds draw them, with the same zones.  Only for a system that declares its
  crank angle column (``System.chart.crank_angle``) and a run that completed a revolution.

What to draw is the system's (``harness.specs.ChartSpec``); a system that declares nothing gets the speed and
effort of every power bond, titled by the FMUs' own variable descriptions.  Angles are drawn in degrees.
This module decides what each figure shows (:func:`figures`); :mod:`harness.reporting.chartdraw` draws it.
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness.reporting import qoi
from harness.reporting.chartdraw import Figure, draw, save_figure  # noqa: F401 (save_figure: the one figure saver, here for the studies)
from harness.specs import Panel


# -- what to draw ---------------------------------------------------------------------------------------------
def _descriptions(system) -> dict[str, str]:
    """``Instance.variable`` -> the FMU's description of it (empty where an FMU cannot be read)."""
    from harness.model import model_description, resolve_fmu

    out = {}
    for inst in system.instances:
        try:
            md = model_description(resolve_fmu(inst.fmu))
        except Exception:  # noqa: BLE001 (a chart without descriptions is still a chart)
            continue
        out.update({f"{inst.name}.{v.name}": (v.description or "") for v in md.modelVariables})
    return out


def _meaning(column: str, descriptions: dict[str, str]) -> str:
    """A title for a column the system did not describe: the FMU's description, a port's cut to the port and
    the quantity ("driven pulley: torque, reaction this component exerts on the driving flange" -> "Driven
    pulley: torque"), and the column, so the reader sees both what it is and where it comes from."""
    text = descriptions.get(column, "").replace("(motion out)", "").strip()
    port, colon, what = text.partition(": ")
    if colon:  # the port's name without how its angle is measured ("Crank O2A, angle from ..., CCW" -> "Crank O2A")
        text = f"{port.split(', ')[0]}: {what.split(', ')[0]}"
    if not text:
        return column
    return f"{text[0].upper()}{text[1:]} ({column})"


def _bond_panels(system, df: pd.DataFrame, descriptions: dict[str, str]) -> list[Panel]:
    panels = []
    for b in system.bonds:
        for speed, effort in (("w", "tau"), ("v", "f")):
            s_col, e_col = f"{b.motion_out}.{speed}", f"{b.motion_in}.{effort}"
            if s_col in df.columns and e_col in df.columns:
                panels.append(Panel(_meaning(s_col, descriptions), (s_col,)))
                panels.append(Panel(_meaning(e_col, descriptions), (e_col,)))
                break
    return panels


def _scene_windows(scene) -> list[tuple[float, float]]:
    """The time windows a scene reads: its declared ``window``, else every ``window(x, t0, t1)`` with
    constant bounds in its quantity."""
    if scene.window is not None:
        return [tuple(scene.window)]
    out = []
    for node in ast.walk(qoi.check(scene.quantity)):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "window"
                and len(node.args) == 3
                and all(isinstance(a, ast.Constant) and isinstance(a.value, (int, float)) for a in node.args[1:])):
            out.append((float(node.args[1].value), float(node.args[2].value)))
    return out


def _panels(system, df: pd.DataFrame) -> list[Panel]:
    """The declared panels (those whose columns the result has), else the bonds'; then a panel for each
    column a scene reads that is not drawn yet; else the first six columns."""
    descriptions = _descriptions(system)
    spec = getattr(system, "chart", None)
    panels = []
    for p in (spec.panels if spec is not None else ()):
        keep = [i for i, c in enumerate(p.columns) if c in df.columns]
        if keep:
            labels = tuple(p.labels[i] for i in keep) if p.labels else ()
            panels.append(Panel(p.title, tuple(p.columns[i] for i in keep), labels, p.cycle))
    if not panels:
        panels = _bond_panels(system, df, descriptions)
    drawn = {c for p in panels for c in p.columns}
    for scene in getattr(system, "scenes", []):
        for c in qoi.columns(scene.quantity):
            if c in df.columns and c not in drawn:
                drawn.add(c)
                panels.append(Panel(_meaning(c, descriptions), (c,)))
    if not panels:
        panels = [Panel(_meaning(c, descriptions), (c,)) for c in list(df.columns)[:6]]
    return panels


def _spans(x: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """The stretches of ``x`` (sorted) where ``on`` holds, as (first, last) values."""
    on = np.asarray(on, dtype=bool)
    if not on.any():
        return []
    edges = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(x[a]), float(x[b])) for a, b in zip(starts, ends)]


def _zones(system, df: pd.DataFrame) -> list[tuple[str, np.ndarray]]:
    """Each declared zone's label and its truth value per sample (a zone whose columns the result lacks is
    left out: a run recording only some outputs still gets a chart)."""
    spec = getattr(system, "chart", None)
    out = []
    for z in (spec.zones if spec is not None else ()):
        if all(c in df.columns for c in qoi.columns(z.where)):
            out.append((z.label, qoi.mask(z.where, df)))
    return out


def _status(df: pd.DataFrame) -> str:
    a = df.attrs
    status = "" if a.get("complete", True) else "  (INCOMPLETE: " + str(a.get("error", ""))[:60] + ")"
    return (f"master {a.get('master', '?')}, extrapolation order {a.get('extrapolation', '?')}, "
            f"step {a.get('step', 0):g} s{status}")


def _drawn_columns(df: pd.DataFrame, panels) -> dict[str, np.ndarray]:
    return {c: df[c].to_numpy(dtype=float) for p in panels for c in p.columns}


def _time_figure(system, df: pd.DataFrame, panels, zones, stem: str) -> Figure:
    t = df.index.to_numpy(dtype=float)
    windows = [(s.name, w, set(qoi.columns(s.quantity))) for s in getattr(system, "scenes", [])
               for w in _scene_windows(s)]
    return Figure(stem=stem, title=f"{system.name} over time: {_status(df)}", x=t, xlabel="time [s]",
                  panels=list(panels), columns=_drawn_columns(df, panels), units=df.attrs.get("units") or {},
                  zones=[(label, _spans(t, on)) for label, on in zones],
                  windows=[[(name, w) for name, w, cols in windows if cols & set(p.columns) and w[0] < t[-1]]
                           for p in panels],
                  startup=_startup(df))


def _startup(df: pd.DataFrame) -> float | None:
    """The end of the start-up [s] (:mod:`harness.reporting.quantities`: the first steady cycle's start), None without
    one."""
    q = df.attrs.get("quantities")
    steady = getattr(getattr(q, "cycles", None), "steady", None)
    t0 = float(df.index[0]) if len(df) else 0.0
    return steady[0] if steady is not None and steady[0] > t0 else None


def last_revolution(angle: np.ndarray, origin: float = 0.0,
                    period: float = 2 * math.pi) -> tuple[np.ndarray, int, np.ndarray] | None:
    """The samples of the last complete revolution (or machine cycle of ``period`` [rad]) of a cumulative
    shaft angle [rad], counted in whole cycles from ``origin`` in the sense the shaft turns: (a boolean mask,
    the cycle's number from 0, the angle within that cycle in degrees, 0 to 360 -- machine degrees for a
    ``period`` other than a turn -- of the masked samples), or None when the run did not complete one."""
    angle = np.asarray(angle, dtype=float)
    if angle.size < 2 or not np.all(np.isfinite(angle)) or angle[-1] == angle[0]:
        return None
    theta = (angle - origin) * math.copysign(1.0, angle[-1] - angle[0])
    k = math.floor(theta[-1] / period) - 1          # the cycle [k, k + 1] that ends inside the run
    if k * period < theta[0]:
        return None
    rows = (theta >= k * period) & (theta <= (k + 1) * period)
    return rows, k, 360.0 * (theta[rows] - k * period) / period


def cycle_chart_missing(system, df: pd.DataFrame) -> str:
    """Why :func:`plot_result` draws no chart over one machine cycle for this result ('' when it draws one)."""
    spec = getattr(system, "chart", None)
    if spec is None or spec.crank_angle is None:
        return f"system {system.name} declares no crank angle (ChartSpec.crank_angle)"
    if spec.crank_angle not in df.columns:
        return f"the crank angle {spec.crank_angle} was not recorded (add --output {spec.crank_angle})"
    if not any(p.cycle for p in _panels(system, df)):
        return "none of the recorded columns is drawn over a cycle"
    if last_revolution(df[spec.crank_angle].to_numpy(dtype=float), spec.cycle_origin, spec.cycle_angle) is None:
        return "the run did not complete one machine cycle"
    return ""


def _cycle_figure(system, df: pd.DataFrame, panels, zones, stem: str) -> Figure | None:
    spec = system.chart
    panels = [p for p in panels if p.cycle]
    if spec is None or spec.crank_angle not in df.columns or not panels:
        return None
    angle = df[spec.crank_angle].to_numpy(dtype=float)
    found = last_revolution(angle, spec.cycle_origin, spec.cycle_angle)
    if found is None:
        return None
    rows, k, x = found
    t = df.index.to_numpy(dtype=float)[rows]
    what = "crank angle [deg]" if math.isclose(spec.cycle_angle, 2 * math.pi) else "machine cycle [deg, 360 per cycle]"
    return Figure(stem=f"{stem}_cycle",
                  title=f"{system.name}, one machine cycle: cycle {k + 1} (t = {t[0]:.3g} to {t[-1]:.3g} s), "
                        f"{_status(df)}",
                  x=x, xlabel=what + (f" from the {spec.origin_name}" if spec.origin_name else ""),
                  panels=panels, columns={c: v[rows] for c, v in _drawn_columns(df, panels).items()},
                  units=df.attrs.get("units") or {},
                  zones=[(label, _spans(x, on[rows])) for label, on in zones],
                  xlim=(0.0, 360.0), xticks=np.arange(0.0, 361.0, 45.0))


def figures(system, df: pd.DataFrame, stem: str | None = None) -> list[Figure]:
    """The run's charts as :class:`harness.reporting.chartdraw.Figure` s, ready to draw: over time, then (where the system
    declares its crank angle and the run completed a machine cycle) over one cycle, then a stop's own (where the
    run is a stop scenario); their files are named from ``stem`` (default: the system's name)."""
    from harness.reporting.stopchart import stop_figure

    stem = stem or system.name
    panels, zones = _panels(system, df), _zones(system, df)
    cycle = _cycle_figure(system, df, panels, zones, stem)
    stop = stop_figure(system, df, stem)
    return ([_time_figure(system, df, panels, zones, stem)] + ([cycle] if cycle is not None else [])
            + ([stop] if stop is not None else []))


def plot_result(system, df: pd.DataFrame, out_dir: str | Path, svg: bool = False, stem: str | None = None) -> list[Path]:
    """Write ``<out_dir>/<stem>.png`` (over time; ``stem`` default: the system's name) and, where the system
    declares its crank angle and the run completed a revolution, ``<stem>_cycle.png`` (over one machine cycle)
    and ``<stem>_polar.png`` (its joint and contact forces against the crank angle, polar); a stop scenario's
    run also ``<stem>_stop.png`` (speed to rest, brake and belt torque); ``svg=True``: each also as ``.svg``
    (vector, for a document; a second full drawing of each figure, so not by default).  Returns the paths, the
    time chart's first."""
    from harness.reporting.stopchart import polar_figure

    out_dir = Path(out_dir)
    paths = [p for f in figures(system, df, stem) for p in draw(f, out_dir, svg)]
    chart = getattr(system, "chart", None)
    found = None
    if chart is not None and chart.crank_angle in df.columns:
        found = last_revolution(df[chart.crank_angle].to_numpy(dtype=float), chart.cycle_origin, chart.cycle_angle)
    return paths + polar_figure(system, df, out_dir, stem or system.name, found, svg)
