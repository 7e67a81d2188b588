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
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pandas as pd

from harness import qoi
from harness.specs import Panel

_ZONE_COLOURS = ("#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b")
# font sizes [pt] of the panels' text, drawn by the panels and measured by the layout (_finish)
TITLE_PT, LABEL_PT, SUPTITLE_PT, XLABEL_PAD = 8.5, 7, 9, 1
DPI = 110   # of the run charts' PNGs, and of their figures: the layout's text measures are then the PNG's own


def save_figure(fig, stem: str | Path, dpi: float | None = None, svg: bool = True) -> list[Path]:
    """Write ``fig`` as ``<stem>.png`` and ``<stem>.svg`` (a ``.png``/``.svg`` suffix of ``stem`` is dropped
    first; the folder is made), close it and return the paths.  ``dpi``: of the PNG (None: matplotlib's
    default); the SVG is vector.  ``svg=False``: the PNG only (each format is a full drawing of the figure).
    The one figure saver of the toolkit (charts, studies, benchmarks)."""
    import sys

    stem = Path(stem)
    if stem.suffix.lower() in (".png", ".svg"):
        stem = stem.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_name(stem.name + ext) for ext in ((".png", ".svg") if svg else (".png",))]
    for p in paths:
        fig.savefig(p, dpi=dpi if dpi is not None else "figure")
    if "matplotlib.pyplot" in sys.modules:      # a figure pyplot made (studies): pyplot lets it go
        sys.modules["matplotlib.pyplot"].close(fig)
    return paths


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


# -- drawing --------------------------------------------------------------------------------------------------
def _values(df: pd.DataFrame, column: str, units: dict) -> tuple[np.ndarray, str]:
    """The column and its unit as drawn: angles in degrees, shaft speeds in rpm."""
    y, unit = df[column].to_numpy(dtype=float), units.get(column) or "-"
    if unit == "rad":
        return np.degrees(y), "deg"
    if unit == "rad/s":
        return y * (60.0 / (2 * math.pi)), "rpm"
    return y, unit


def _draw_panel(ax, x, df, panel: Panel, units: dict, rows=slice(None)) -> None:
    """One panel: its columns (angles in degrees), the title with the unit, values as they are on the axis
    (no offset, no "1e-5" above it: a tiny or huge signal carries its power of ten in the unit instead)."""
    import textwrap

    drawn = [(_values(df, c, units), panel.labels[i] if panel.labels else c) for i, c in enumerate(panel.columns)]
    peak = max((float(np.nanmax(np.abs(y[rows]))) for (y, _), _ in drawn if np.isfinite(y[rows]).any()),
               default=0.0)
    power = 3 * math.floor(math.log10(peak) / 3) if peak > 0 and not 1e-2 <= peak < 1e5 else 0
    for (y, _), label in drawn:
        ax.plot(x, y[rows] / 10.0 ** power, lw=0.9, label=label)
    unit = ", ".join(sorted({u for (_, u), _ in drawn}))
    unit = f"1e{power} {unit}" if power else unit
    ax.set_title("\n".join(textwrap.wrap(f"{panel.title} [{unit}]", 95)), fontsize=TITLE_PT, loc="left",
                 y=1.0)   # placed, not re-placed at each drawing after measuring the y axis (nothing above the panels)
    ax.set_ylabel(f"[{unit}]", fontsize=LABEL_PT)
    ax.tick_params(labelsize=LABEL_PT, labelbottom=True)
    ax.ticklabel_format(axis="y", style="plain", useOffset=False)
    ax.grid(alpha=0.3)
    if len(panel.columns) > 1:
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)


def _shade(ax, spans_by_zone) -> None:
    for k, (label, spans) in enumerate(spans_by_zone):
        for a, b in spans:
            ax.axvspan(a, b, color=_ZONE_COLOURS[k % len(_ZONE_COLOURS)], alpha=0.15, lw=0)


def _figure(n: int):
    """A figure of ``n`` panels, made without pyplot (its import and backend set-up cost a run's charts about
    a third of a second, and no window is ever shown); saved through the Agg and SVG canvases."""
    from matplotlib.figure import Figure

    ncol = 2 if n > 3 else 1
    nrow = -(-n // ncol)
    fig = Figure(figsize=(7.0 * ncol, 2.3 * nrow + 0.9), dpi=DPI)
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return fig, axes


def _key(fig, entries) -> None:
    """A legend of the shaded zones and hatched windows below the panels, off the data."""
    from matplotlib.patches import Patch

    if entries:
        fig.legend(handles=[Patch(**style, label=label) for label, style in entries], loc="lower center",
                   ncol=min(len(entries), 3), fontsize=7, frameon=False)


def _status(df: pd.DataFrame) -> str:
    a = df.attrs
    status = "" if a.get("complete", True) else "  (INCOMPLETE: " + str(a.get("error", ""))[:60] + ")"
    return (f"master {a.get('master', '?')}, extrapolation order {a.get('extrapolation', '?')}, "
            f"step {a.get('step', 0):g} s{status}")


def _finish(fig, axes, n: int, key_rows: int) -> None:
    """Margins and gaps of the panel grid from what is drawn around the panels, measured once: the titles' lines,
    the y tick labels' widths (from each axis's own ticks), the legends beside the panels, the key below.  It
    replaces Matplotlib's tight layout, which measures every tick label of every panel with a full layout (about
    a third of a chart's time) and arrives at the same room for them."""
    from matplotlib import rcParams
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.font_manager import FontProperties

    pt = 1.0 / 72.0                                                   # inch
    width_in, height_in = fig.get_size_inches()
    nrow, ncol = axes.shape
    shown = list(axes.flat)[:n]
    renderer = FigureCanvasAgg(fig).get_renderer()
    fonts = {}

    def text_width(text: str, size: float) -> float:                  # inch, the widest line
        prop = fonts.setdefault(size, FontProperties(size=size))
        return max((renderer.get_text_width_height_descent(line, prop, ismath=False)[0] for line in
                    text.split("\n") if line), default=0.0) / fig.dpi

    tick = (rcParams["xtick.major.size"] + rcParams["xtick.major.pad"]) * pt
    line = 1.2 * pt                                                   # a line of text per point of font size
    below = tick + LABEL_PT * line + XLABEL_PAD * pt + LABEL_PT * line + 3 * pt   # x tick labels, the x label
    above = [rcParams["axes.titlepad"] * pt + 3 * pt
             + max(ax.get_title(loc="left").count("\n") + 1 for ax in shown[r * ncol:(r + 1) * ncol]) * TITLE_PT * line
             for r in range(nrow)]
    top = 0.02 * height_in + SUPTITLE_PT * line + 4 * pt + above[0]   # the suptitle (at 0.98, top-aligned)
    bottom = below + 4 * pt + ((0.3 + 0.18 * key_rows) if key_rows else 0.0)
    gap_v = below + max(above[1:], default=0.0)
    panel_h = (height_in - top - bottom - (nrow - 1) * gap_v) / nrow
    fig.subplots_adjust(top=1.0 - top / height_in, bottom=bottom / height_in, hspace=gap_v / panel_h)

    # the y ticks follow the panels' height, now set; the widths of their labels set the left margins
    left_of, right_of, title_of = [0.0] * ncol, [0.0] * ncol, [0.0] * ncol
    for i, ax in enumerate(shown):
        c = i % ncol
        lo, hi = sorted(ax.get_ylim())
        locs = [v for v in ax.yaxis.get_majorticklocs() if lo - 1e-9 * (hi - lo) <= v <= hi + 1e-9 * (hi - lo)]
        labels = ax.yaxis.get_major_formatter().format_ticks(locs)
        left_of[c] = max(left_of[c], tick + max((text_width(s, LABEL_PT) for s in labels), default=0.0)
                         + rcParams["axes.labelpad"] * pt + LABEL_PT * line + 3 * pt)
        legend = ax.get_legend()
        if legend is not None:
            right_of[c] = max(right_of[c], (legend.get_window_extent(renderer).x1 - ax.bbox.x1) / fig.dpi + 3 * pt)
        title_of[c] = max(title_of[c], text_width(ax.get_title(loc="left"), TITLE_PT))
    overhang = text_width("0.000", LABEL_PT) / 2 + 3 * pt   # the last x tick label, centred on the edge
    left = left_of[0] + 2 * pt
    right = max(right_of[-1], overhang)
    gap_h = max((max(right_of[c], overhang) + left_of[c + 1] for c in range(ncol - 1)), default=0.0)
    for _ in range(2):                                                # a title longer than its panel
        panel_w = (width_in - left - right - (ncol - 1) * gap_h) / ncol
        right = max(right, title_of[-1] - panel_w + 3 * pt)
        gap_h = max([gap_h] + [title_of[c] - panel_w + 3 * pt for c in range(ncol - 1)])
    panel_w = (width_in - left - right - (ncol - 1) * gap_h) / ncol
    fig.subplots_adjust(left=left / width_in, right=1.0 - right / width_in, wspace=gap_h / panel_w)


def _time_chart(system, df: pd.DataFrame, panels, zones, out_dir: Path, svg: bool) -> list[Path]:
    fig, axes = _figure(len(panels))
    t = df.index.to_numpy(dtype=float)
    units = df.attrs.get("units") or {}
    zone_spans = [(label, _spans(t, on)) for label, on in zones]
    windows = [(s.name, w, set(qoi.columns(s.quantity))) for s in getattr(system, "scenes", [])
               for w in _scene_windows(s)]
    barred = False
    for ax, panel in zip(axes.flat, panels):
        _draw_panel(ax, t, df, panel, units)
        _shade(ax, zone_spans)
        mine = [(name, w) for name, w, cols in windows if cols & set(panel.columns) and w[0] < t[-1]]
        if mine:                                      # headroom, so the bars stay off the curves
            lo, hi = ax.get_ylim()
            ax.set_ylim(lo, hi + 0.13 * len(mine) * (hi - lo))
        for i, (name, (a, b)) in enumerate(mine):   # a bar along the top per scene window, named
            y = 0.97 - 0.11 * i
            ax.plot([a, min(b, t[-1])], [y, y], transform=ax.get_xaxis_transform(), color="0.3", lw=2.2,
                    solid_capstyle="butt")
            ax.text(a, y - 0.025, f" scene {name}", transform=ax.get_xaxis_transform(), fontsize=6,
                    va="top", color="0.2", bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=0.5))
            barred = True
        ax.set_xlabel("time [s]", fontsize=LABEL_PT, labelpad=XLABEL_PAD)
        ax.set_xlim(t[0], t[-1])
    key = _zone_key(zone_spans)
    startup = _startup(df)
    if startup is not None:
        for ax in list(axes.flat)[:len(panels)]:
            ax.axvspan(t[0], startup, facecolor="none", edgecolor="0.8", hatch="//", lw=0)
            ax.axvline(startup, color="0.4", lw=0.8, ls="--")
        key.append((f"start-up: until the main shaft's cycle mean speed settles (t = {startup:.3g} s)",
                    dict(facecolor="none", edgecolor="0.6", hatch="//")))
    if barred:
        key.append(("time window a scene reads (bar at the top)", dict(color="0.3")))
    _key(fig, key)
    fig.suptitle(f"{system.name} over time: {_status(df)}", fontsize=SUPTITLE_PT)
    _finish(fig, axes, len(panels), -(-len(key) // 3))
    return save_figure(fig, out_dir / system.name, dpi=DPI, svg=svg)


def _startup(df: pd.DataFrame) -> float | None:
    """The end of the start-up [s] (:mod:`harness.quantities`: the first steady cycle's start), None without
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


def _zone_key(zone_spans) -> list:
    """Legend entries of the zones that are shaded somewhere in the chart (colour as :func:`_shade` draws it)."""
    return [(label, dict(color=_ZONE_COLOURS[k % len(_ZONE_COLOURS)], alpha=0.3))
            for k, (label, spans) in enumerate(zone_spans) if spans]


def _cycle_chart(system, df: pd.DataFrame, panels, zones, out_dir: Path, svg: bool) -> list[Path]:
    spec = system.chart
    panels = [p for p in panels if p.cycle]
    if spec is None or spec.crank_angle not in df.columns or not panels:
        return []
    angle = df[spec.crank_angle].to_numpy(dtype=float)
    found = last_revolution(angle, spec.cycle_origin, spec.cycle_angle)
    if found is None:
        return []
    rows, k, x = found
    t = df.index.to_numpy(dtype=float)[rows]
    units = df.attrs.get("units") or {}
    zone_spans = [(label, _spans(x, on[rows])) for label, on in zones]
    fig, axes = _figure(len(panels))
    for ax, panel in zip(axes.flat, panels):
        _draw_panel(ax, x, df, panel, units, rows)
        _shade(ax, zone_spans)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0.0, 361.0, 45.0))
        what = ("crank angle [deg]" if math.isclose(spec.cycle_angle, 2 * math.pi)
                else "machine cycle [deg, 360 per cycle]")
        ax.set_xlabel(what + (f" from the {spec.origin_name}" if spec.origin_name else ""), fontsize=LABEL_PT,
                      labelpad=XLABEL_PAD)
    key = _zone_key(zone_spans)
    _key(fig, key)
    fig.suptitle(f"{system.name}, one machine cycle: cycle {k + 1} (t = {t[0]:.3g} to {t[-1]:.3g} s), "
                 f"{_status(df)}", fontsize=SUPTITLE_PT)
    _finish(fig, axes, len(panels), -(-len(key) // 3))
    return save_figure(fig, out_dir / f"{system.name}_cycle", dpi=DPI, svg=svg)


def plot_result(system, df: pd.DataFrame, out_dir: str | Path, svg: bool = False) -> list[Path]:
    """Write ``<out_dir>/<system>.png`` (over time) and, where the system declares its crank angle and the run
    completed a revolution, ``<system>_cycle.png`` (over one machine cycle); ``svg=True``: each also as
    ``.svg`` (vector, for a document; a second full drawing of each figure, so not by default).  Returns the
    paths, the time chart's first."""
    out_dir = Path(out_dir)
    panels, zones = _panels(system, df), _zones(system, df)
    return (_time_chart(system, df, panels, zones, out_dir, svg)
            + _cycle_chart(system, df, panels, zones, out_dir, svg))
