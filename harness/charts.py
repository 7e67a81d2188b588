"""Charts of a result: one panel per power bond (its speed and its torque or force), then the columns the
system's scenes ask about.  Matplotlib, written as PNG and SVG."""
from __future__ import annotations

from pathlib import Path

import pandas as pd


def save_figure(fig, stem: str | Path, dpi: float | None = None) -> list[Path]:
    """Write ``fig`` as ``<stem>.png`` and ``<stem>.svg`` (a ``.png``/``.svg`` suffix of ``stem`` is dropped
    first; the folder is made), close it and return the two paths.  ``dpi``: of the PNG (None: matplotlib's
    default); the SVG is vector.  The one figure saver of the toolkit (charts, studies, benchmarks)."""
    import matplotlib.pyplot as plt

    stem = Path(stem)
    if stem.suffix.lower() in (".png", ".svg"):
        stem = stem.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_name(stem.name + ".png"), stem.with_name(stem.name + ".svg")]
    for p in paths:
        fig.savefig(p, dpi=dpi if dpi is not None else "figure")
    plt.close(fig)
    return paths


def _bond_columns(system, df: pd.DataFrame) -> list[tuple[str, list[str]]]:
    panels = []
    for b in system.bonds:
        for speed, effort, unit_s, unit_e in (("w", "tau", "rad/s", "N.m"), ("v", "f", "m/s", "N")):
            s_col, e_col = f"{b.motion_out}.{speed}", f"{b.motion_in}.{effort}"
            if s_col in df.columns and e_col in df.columns:
                panels.append((f"bond {b.label}: speed [{unit_s}]", [s_col]))
                panels.append((f"bond {b.label}: {'torque' if effort == 'tau' else 'force'} [{unit_e}]", [e_col]))
                break
    return panels


def _scene_columns(system, df: pd.DataFrame) -> list[tuple[str, list[str]]]:
    from harness import qoi

    panels, seen = [], set()
    for scene in getattr(system, "scenes", []):
        cols = [c for c in qoi.columns(scene.quantity) if c in df.columns and c not in seen]
        seen.update(cols)
        if cols:
            panels.append((f"scene {scene.name} [{scene.unit}]".replace(" []", ""), cols))
    return panels


def plot_result(system, df: pd.DataFrame, out_dir: str | Path) -> list[Path]:
    """Write <out_dir>/<system>.png and .svg; returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = _bond_columns(system, df) + _scene_columns(system, df)
    if not panels:
        panels = [(c, [c]) for c in list(df.columns)[:6]]
    n = len(panels)
    ncol = 2 if n > 3 else 1
    nrow = -(-n // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6.0 * ncol, 2.1 * nrow), sharex=True, squeeze=False)
    t = df.index.to_numpy()
    units = df.attrs.get("units") or {}
    for ax, (title, cols) in zip(axes.flat, panels):
        for c in cols:
            ax.plot(t, df[c].to_numpy(), lw=0.9, label=c)
        ax.set_title(title, fontsize=8)
        shown = sorted({units.get(c) or "-" for c in cols})  # the columns' declared units ("-": none)
        ax.set_ylabel(f"[{', '.join(shown)}]", fontsize=7)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if len(cols) > 1:
            ax.legend(fontsize=6)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]", fontsize=8)
    status = "" if df.attrs.get("complete", True) else "  (INCOMPLETE: " + str(df.attrs.get("error", ""))[:60] + ")"
    fig.suptitle(f"{system.name}: master {df.attrs.get('master', '?')}, extrapolation order "
                 f"{df.attrs.get('extrapolation', '?')}, step {df.attrs.get('step', 0):g} s{status}",
                 fontsize=9)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.35 / fig.get_figheight()))  # room for the title (inches)
    return save_figure(fig, Path(out_dir) / system.name, dpi=110)
