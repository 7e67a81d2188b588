"""Two more charts of a run (:func:`harness.reporting.charts.plot_result` writes them):

* ``<stem>_stop.png`` (a stop scenario's run, :mod:`harness.reporting.stops`): from shortly before the command
  to the run's end, the main shaft's speed to rest, each brake's torque and the belt's and shafts' torques,
  the braking (command to first standstill) and the ring-down (first standstill to settled) shaded;
* ``<stem>_polar.png`` (a drive that declares its crank angle and loads in newtons, over its last complete
  machine cycle): each joint, contact, mesh or rack force as a polar diagram, |F| as the radius against the
  crank angle, the designer's view of where in the cycle a joint is loaded.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from harness.reporting import chartdraw
from harness.reporting.chartdraw import Figure
from harness.specs import Panel

BEFORE = 0.1     # s of the run before the stop command the stop chart shows


def stop_figure(system, df, stem: str) -> Figure | None:
    """The stop's chart (module docstring), or None where the run is not a stop with its transient quantities."""
    q = df.attrs.get("transient")
    spec = getattr(system, "quantities", None)
    if q is None or spec is None or "stopping_time" not in q or q["stopping_time"] is None:
        return None
    command = df.attrs.get("stop_command")
    if command is None:
        return None
    from harness.reporting.stops import brakes

    t = df.index.to_numpy(dtype=float)
    rows = t >= command - BEFORE
    panels = [Panel("Main-shaft speed to rest", (spec.shaft_speed,))]
    found = brakes(spec, df)
    if found:
        panels.append(Panel("Brake torque", tuple(b[1] for b in found), tuple(b[3] for b in found)))
    torques = [ld for ld in spec.loads if ld.column in df.columns and (df.attrs.get("units") or {}).get(
        ld.column) == "N.m" and df[ld.column].any()]
    if torques:
        panels.append(Panel("Belt and shaft torques in the stop", tuple(ld.column for ld in torques),
                            tuple(ld.what for ld in torques)))
    x = t[rows]
    first = command + q["stopping_time"]
    settled = command + q["settle_time"] if q["settle_time"] is not None else float(t[-1])
    zones = [("braking: command to the first standstill", [(command, first)]),
             ("ring-down: first standstill to settled", [(first, settled)])]
    columns = {c: df[c].to_numpy(dtype=float)[rows] for p in panels for c in p.columns}
    return Figure(stem=f"{stem}_stop", title=f"{system.name}: the stop (command at t = {command:g} s, first standstill "
                                             f"{q['stopping_time']:.3g} s later)", x=x, xlabel="time [s]",
                  panels=panels, columns=columns, units=df.attrs.get("units") or {}, zones=zones)


def polar_figure(system, df, out_dir: str | Path, stem: str, found, svg: bool = False) -> list[Path]:
    """The joint forces' polar chart (module docstring): ``<out_dir>/<stem>_polar.png``; ``found``: the last
    complete cycle (:func:`harness.reporting.charts.last_revolution`, None: none); [] where the drive declares no
    crank angle or no force, or the run completed no cycle."""
    chart, spec = getattr(system, "chart", None), getattr(system, "quantities", None)
    if chart is None or chart.crank_angle is None or spec is None or found is None:
        return []
    units = df.attrs.get("units") or {}
    forces = [ld for ld in spec.loads if ld.column in df.columns and units.get(ld.column) == "N" and df[ld.column].any()]
    if not forces:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, k, degrees = found
    n = len(forces)
    cols = min(n, 3)
    fig, axes = plt.subplots(-(-n // cols), cols, subplot_kw={"projection": "polar"}, figsize=(4.2 * cols,
                                                                                             4.2 * -(-n // cols)),
                             squeeze=False)
    for ax, ld in zip(axes.flat, forces):
        f = np.abs(df[ld.column].to_numpy(dtype=float)[rows])
        ax.plot(np.radians(degrees), f, lw=1.0)
        ax.set_theta_zero_location("E")
        ax.set_title(f"{ld.name}: |F| [N], peak {f.max():.4g} N", fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    origin = f" from the {chart.origin_name}" if chart.origin_name else ""
    import textwrap

    fig.suptitle("\n".join(textwrap.wrap(f"{system.name}: joint and contact forces over machine cycle {k + 1}, radius "
                                         f"|F|, angle the crank angle{origin} (counter-clockwise)", 50 * cols)),
                 fontsize=9)
    fig.tight_layout()
    return [p for p in chartdraw.save_figure(fig, Path(out_dir) / f"{stem}_polar", dpi=110, svg=svg)
            if svg or p.suffix == ".png"]
