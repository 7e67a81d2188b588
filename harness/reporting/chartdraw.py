"""Drawing the run charts (:mod:`harness.reporting.charts` decides what to draw): a :class:`Figure` holds everything one
figure needs -- its panels, the arrays they draw, the shaded zones, the scene windows and the titles -- as plain
values, and :func:`draw` turns it into a PNG (and SVG).

This module imports numpy and Matplotlib only (pandas and the system's declarations stay in
:mod:`harness.reporting.charts`): a figure is plain data, drawn the same from a run, a study or a test.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.specs import Panel

_ZONE_COLOURS = ("#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b")
# font sizes [pt] of the panels' text, drawn by the panels and measured by the layout (_finish)
TITLE_PT, LABEL_PT, SUPTITLE_PT, XLABEL_PAD = 8.5, 7, 9, 1
DPI = 110   # of the run charts' PNGs, and of their figures: the layout's text measures are then the PNG's own


@dataclass
class Figure:
    """One chart to draw: ``panels`` over ``x`` (time [s] or the angle within a machine cycle [deg]), their
    columns' values in ``columns`` (the samples drawn) with ``units``.  ``zones``:
    each zone's label and its (first, last) stretches of x, shaded; ``windows``: per panel, the scene windows
    (name, (t0, t1)) barred along its top; ``startup``: the end of the start-up [s], hatched before it.  Written
    as ``<stem>.png`` (and ``.svg``)."""
    stem: str
    title: str
    x: np.ndarray
    xlabel: str
    panels: list[Panel]
    columns: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    zones: list[tuple[str, list[tuple[float, float]]]] = field(default_factory=list)
    windows: list[list[tuple[str, tuple[float, float]]]] = field(default_factory=list)
    startup: float | None = None
    xlim: tuple[float, float] | None = None
    xticks: np.ndarray | None = None


def save_figure(fig, stem: str | Path, dpi: float | None = None, svg: bool = True) -> list[Path]:
    """Write ``fig`` as ``<stem>.png`` and ``<stem>.svg`` (a ``.png``/``.svg`` suffix of ``stem`` is dropped
    first; the folder is made), close it and return the paths.  ``dpi``: of the PNG (None: matplotlib's
    default); the SVG is vector.  ``svg=False``: the PNG only (each format is a full drawing of the figure).
    The one figure saver of the toolkit (charts, studies, benchmarks).  Each file is written beside its place
    and moved there whole, so an interrupted drawing never leaves a torn chart under the chart's name."""
    import os
    import sys

    stem = Path(stem)
    if stem.suffix.lower() in (".png", ".svg"):
        stem = stem.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_name(stem.name + ext) for ext in ((".png", ".svg") if svg else (".png",))]
    for p in paths:
        part = p.with_name(f".{p.name}.part")
        try:
            fig.savefig(part, format=p.suffix[1:], dpi=dpi if dpi is not None else "figure")
            os.replace(part, p)
        except BaseException:
            part.unlink(missing_ok=True)
            raise
    if "matplotlib.pyplot" in sys.modules:      # a figure pyplot made (studies): pyplot lets it go
        sys.modules["matplotlib.pyplot"].close(fig)
    return paths


def values(columns, column: str, units: dict) -> tuple[np.ndarray, str]:
    """The column (of a DataFrame or a mapping of arrays) and its unit as drawn: angles in degrees, shaft
    speeds in rpm."""
    y, unit = np.asarray(columns[column], dtype=float), units.get(column) or "-"
    if unit == "rad":
        return np.degrees(y), "deg"
    if unit == "rad/s":
        return y * (60.0 / (2 * math.pi)), "rpm"
    return y, unit


def draw_panel(ax, x, columns, panel: Panel, units: dict) -> None:
    """One panel: its columns (angles in degrees), the title with the unit, values as they are on the axis
    (no offset, no "1e-5" above it: a tiny or huge signal carries its power of ten in the unit instead)."""
    import textwrap

    drawn = [(values(columns, c, units), panel.labels[i] if panel.labels else c) for i, c in enumerate(panel.columns)]
    peak = max((float(np.nanmax(np.abs(y))) for (y, _), _ in drawn if np.isfinite(y).any()),
               default=0.0)
    power = 3 * math.floor(math.log10(peak) / 3) if peak > 0 and not 1e-2 <= peak < 1e5 else 0
    for (y, _), label in drawn:
        ax.plot(x, y / 10.0 ** power, lw=0.9, label=label)
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


def zone_key(zones) -> list:
    """Legend entries of the zones that are shaded somewhere in the chart (colour as :func:`_shade` draws it)."""
    return [(label, dict(color=_ZONE_COLOURS[k % len(_ZONE_COLOURS)], alpha=0.3))
            for k, (label, spans) in enumerate(zones) if spans]


def draw(spec: Figure, out_dir: str | Path, svg: bool = False) -> list[Path]:
    """Draw ``spec`` into ``out_dir`` (``<stem>.png``, and ``.svg`` with ``svg``) and return the paths."""
    fig, axes = _figure(len(spec.panels))
    x = np.asarray(spec.x, dtype=float)
    barred = False
    for i, (ax, panel) in enumerate(zip(axes.flat, spec.panels)):
        draw_panel(ax, x, spec.columns, panel, spec.units)
        _shade(ax, spec.zones)
        mine = spec.windows[i] if i < len(spec.windows) else []
        if mine:                                      # headroom, so the bars stay off the curves
            lo, hi = ax.get_ylim()
            ax.set_ylim(lo, hi + 0.13 * len(mine) * (hi - lo))
        for j, (name, (a, b)) in enumerate(mine):   # a bar along the top per scene window, named
            y = 0.97 - 0.11 * j
            ax.plot([a, min(b, x[-1])], [y, y], transform=ax.get_xaxis_transform(), color="0.3", lw=2.2,
                    solid_capstyle="butt")
            ax.text(a, y - 0.025, f" scene {name}", transform=ax.get_xaxis_transform(), fontsize=6,
                    va="top", color="0.2", bbox=dict(facecolor="white", edgecolor="none", alpha=0.7, pad=0.5))
            barred = True
        ax.set_xlim(*(spec.xlim if spec.xlim is not None else (x[0], x[-1])))
        if spec.xticks is not None:
            ax.set_xticks(spec.xticks)
        ax.set_xlabel(spec.xlabel, fontsize=LABEL_PT, labelpad=XLABEL_PAD)
    key = zone_key(spec.zones)
    if spec.startup is not None:
        for ax in list(axes.flat)[:len(spec.panels)]:
            ax.axvspan(x[0], spec.startup, facecolor="none", edgecolor="0.8", hatch="//", lw=0)
            ax.axvline(spec.startup, color="0.4", lw=0.8, ls="--")
        key.append((f"start-up: until the main shaft's cycle mean speed settles (t = {spec.startup:.3g} s)",
                    dict(facecolor="none", edgecolor="0.6", hatch="//")))
    if barred:
        key.append(("time window a scene reads (bar at the top)", dict(color="0.3")))
    _key(fig, key)
    fig.suptitle(spec.title, fontsize=SUPTITLE_PT)
    _finish(fig, axes, len(spec.panels), -(-len(key) // 3))
    return save_figure(fig, Path(out_dir) / spec.stem, dpi=DPI, svg=svg)


def _shade(ax, spans_by_zone) -> None:
    for k, (label, spans) in enumerate(spans_by_zone):
        for a, b in spans:
            ax.axvspan(a, b, color=_ZONE_COLOURS[k % len(_ZONE_COLOURS)], alpha=0.15, lw=0)


def _figure(n: int):
    """A figure of ``n`` panels, made without pyplot (its import and backend set-up cost a run's charts about
    a third of a second, and no window is ever shown); saved through the Agg and SVG canvases."""
    from matplotlib.figure import Figure as MplFigure

    ncol = 2 if n > 3 else 1
    nrow = -(-n // ncol)
    fig = MplFigure(figsize=(7.0 * ncol, 2.3 * nrow + 0.9), dpi=DPI)
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
