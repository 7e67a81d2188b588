"""The run chart (``run ... --plot DIR``, harness/reporting/charts.py) as a press engineer reads it: panels titled by the
signal and its meaning with its unit, time ticks on every panel, the zones the system declares shaded where
the result puts them, and a second chart over one machine cycle against the crank angle.

The zones are checked against the physics, not against numbers copied from the systems: the bed drive's
printing zone must lie inside the working stroke with the bed in the declared travel, the feeder's dwell where
the head stands still.
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from harness import load, simulate
from harness.reporting import chartdraw, charts
from harness.model import SystemWarning



def run(system, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)
        df = simulate(system, on_error="raise", **kw)
    assert df.attrs["complete"], df.attrs["error"]
    return df


@pytest.fixture(scope="module")
def bed(fmu_dir):
    system = load("bed_drive").on_fmus(fmu_dir)
    return system, run(system, stop_time=1.1)   # one complete turn of the main shaft at 60 rpm


@pytest.fixture(scope="module")
def feeder(fmu_dir):
    system = load("feeder_gto52").on_fmus(fmu_dir)
    return system, run(system, stop_time=0.9)


@pytest.fixture()
def figures(monkeypatch):
    """The figures plot_result makes, by file stem, kept open for inspection instead of written."""
    made = {}

    def keep(fig, stem, dpi=None, svg=True):
        made[Path(stem).name] = fig
        return [Path(f"{stem}.png")] + ([Path(f"{stem}.svg")] if svg else [])

    monkeypatch.setattr(chartdraw, "save_figure", keep)
    return made


def visible_axes(fig):
    return [ax for ax in fig.axes if ax.get_visible() and ax.get_title(loc="left")]


def assert_laid_out(fig):
    """Every panel with its title, tick labels, axis labels and legend inside the figure, clear of the other
    panels, of the title above them and of the key below them (what the fixed margins must leave room for)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    inside = fig.bbox.padded(0.5)
    boxes = [(ax.get_title(loc="left"), ax.get_tightbbox(renderer)) for ax in visible_axes(fig)]
    boxes += [("figure title", fig._suptitle.get_window_extent(renderer))]
    boxes += [("key", leg.get_window_extent(renderer)) for leg in fig.legends]
    for i, (name, box) in enumerate(boxes):
        assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 and box.y1 <= inside.y1, \
            f"{name!r} {box.extents} clipped by the figure {fig.bbox.extents}"
        for other, box2 in boxes[i + 1:]:
            assert not box.overlaps(box2), f"{name!r} {box.extents} overlaps {other!r} {box2.extents}"


def test_charts_leave_room_for_every_label(bed, feeder, figures, tmp_path):
    for system, df in (bed, feeder):
        charts.plot_result(system, df, tmp_path)
    assert {"bed_drive", "bed_drive_cycle", "feeder_gto52", "feeder_gto52_cycle"} <= set(figures)
    for fig in figures.values():
        assert_laid_out(fig)


def test_time_chart_panels_name_the_signal_unit_and_carry_time_ticks(bed, figures, tmp_path):
    system, df = bed
    paths = charts.plot_result(system, df, tmp_path)
    assert [p.name for p in paths] == ["bed_drive.png", "bed_drive_cycle.png", "bed_drive_polar.png"]   # SVG only when asked
    axes = visible_axes(figures["bed_drive"])
    titles = [ax.get_title(loc="left") for ax in axes]
    assert "Bed position s [m]" in titles and "Bed speed v [m/s]" in titles
    for ax, title in zip(axes, titles):
        assert not title.lower().startswith(("scene", "bond")), title
        assert title.endswith("]"), f"no unit in panel title {title!r}"
        assert ax.get_xlabel() == "time [s]"
        labels = [t for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        assert len(labels) >= 3, f"panel {title!r} has no time ticks"


def test_printing_zone_is_read_from_the_system_and_lies_on_the_working_stroke(bed):
    from systems.bed_drive import PRINT_ZONE

    system, df = bed
    (label, on), = charts._zones(system, df)
    assert "printing zone" in label
    s, v, t = df["bed.bed.s"].to_numpy(), df["bed.bed.v"].to_numpy(), df.index.to_numpy()
    assert on.any() and np.all(v[on] > 0)
    travel = np.max(np.abs(v)) * (t[1] - t[0])                 # the bed's largest travel in one step
    assert s[on].min() == pytest.approx(PRINT_ZONE[0], abs=travel)
    assert s[on].max() == pytest.approx(PRINT_ZONE[1], abs=travel)
    # against the crank angle: within the working stroke, where the four-bar's rocker (the ring) turns one way
    rows, k, _deg = charts.last_revolution(df[system.chart.crank_angle].to_numpy(), system.chart.cycle_origin)
    ring_w = np.gradient(df["fourbar.rocker.phi"].to_numpy(), t)
    assert (rows & on).any()
    assert np.all(np.sign(ring_w[rows & on]) == np.sign(ring_w[rows][len(ring_w[rows]) // 8]))


def test_cycle_chart_runs_over_one_turn_against_crank_angle_with_the_zone(bed, figures, tmp_path):
    system, df = bed
    charts.plot_result(system, df, tmp_path)
    fig = figures["bed_drive_cycle"]
    axes = visible_axes(fig)
    titles = [ax.get_title(loc="left") for ax in axes]
    assert "Bed position s [m]" in titles and any("Torques" in t for t in titles)
    assert "Motor torque [N.m]" in titles                           # the motor's torque against the crank angle
    for ax in axes:
        assert ax.get_xlim() == (0.0, 360.0) and "crank angle [deg]" in ax.get_xlabel()
        xs = np.concatenate([line.get_xdata() for line in ax.get_lines() if len(line.get_xdata()) > 2])
        assert xs.min() >= 0.0 and xs.max() <= 360.0 and xs.max() - xs.min() > 350.0
        assert ax.patches, "the printing zone is not shaded"
    # the bed starts and ends the cycle at its starting extreme (working stroke from the origin, return to it)
    bed_ax = axes[titles.index("Bed position s [m]")]
    y = bed_ax.get_lines()[0].get_ydata()
    assert abs(y[0] - y[-1]) < 0.02 * np.ptp(y)


def test_last_revolution_needs_a_complete_turn():
    t = np.linspace(0.0, 1.0, 101)
    assert charts.last_revolution(2 * math.pi * 0.9 * t) is None            # 0.9 of a turn
    rows, k, deg = charts.last_revolution(2 * math.pi * 2.5 * t)            # 2.5 turns: the second one
    assert k == 1 and t[rows][0] == pytest.approx(0.4) and t[rows][-1] == pytest.approx(0.8)
    assert deg[0] == pytest.approx(0.0, abs=1e-9) and deg[-1] == pytest.approx(360.0)
    np.testing.assert_allclose(deg, 360.0 * 2.5 * t[rows] - 360.0)        # the angle within that turn
    rows, k, deg = charts.last_revolution(-2 * math.pi * 1.5 * t, origin=0.0)  # turning backwards
    assert k == 0 and t[rows][-1] == pytest.approx(2 / 3, abs=0.01)
    np.testing.assert_allclose(deg, 360.0 * 1.5 * t[rows])                # counted in the sense it turns


def test_feeder_dwell_is_shaded_where_the_head_stands_still(feeder, figures, tmp_path):
    system, df = feeder
    (label, on), = charts._zones(system, df)
    assert "dwell" in label and on.any()
    w = df["feeder.rocker.w"].to_numpy()
    assert np.max(np.abs(w[on])) < 0.02 * np.max(np.abs(w))
    just_outside = np.flatnonzero(np.diff(on.astype(int)) != 0)
    assert just_outside.size >= 2
    charts.plot_result(system, df, tmp_path)
    assert "feeder_gto52_cycle" in figures


def test_a_system_that_declares_nothing_gets_its_bonds_titled_by_the_fmus(fmu_dir, figures, tmp_path):
    system = load("two_inertia").on_fmus(fmu_dir)
    assert system.chart is None
    df = run(system, stop_time=0.01, step=1e-3)
    paths = charts.plot_result(system, df, tmp_path)
    assert [p.name for p in paths] == ["two_inertia.png"]   # no crank: no cycle chart
    titles = [ax.get_title(loc="left") for ax in visible_axes(figures["two_inertia"])]
    assert titles and all(not t.startswith(("bond", "scene")) and "(" in t and t.endswith("]") for t in titles)
    assert_laid_out(figures["two_inertia"])


def test_run_plot_writes_and_names_both_charts(fmu_dir, tmp_path, monkeypatch, capsys):
    from harness.__main__ import main

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    import warnings

    monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)   # main() sets its own
    assert main(["run", "bed_drive", "--stop-time", "1.05", "--plot", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bed_drive.png", "bed_drive_cycle.png",
                                                          "bed_drive_polar.png"]   # PNG only
    assert str(tmp_path / "bed_drive.png") in out and str(tmp_path / "bed_drive_cycle.png") in out
    svg = tmp_path / "svg"
    assert main(["run", "bed_drive", "--stop-time", "1.05", "--plot", str(svg), "--svg", "--quiet-quantities"]) == 0
    assert sorted(p.name for p in svg.iterdir()) == ["bed_drive.png", "bed_drive.svg", "bed_drive_cycle.png",
                                                     "bed_drive_cycle.svg", "bed_drive_polar.png",
                                                     "bed_drive_polar.svg"]
    # named after --out: two runs into one folder keep their charts apart
    assert main(["run", "bed_drive", "--stop-time", "1.05", "--plot", str(svg), "--out", str(tmp_path / "x.csv"),
                 "--quiet-quantities"]) == 0
    assert {"x.png", "x_cycle.png", "x_polar.png", "bed_drive.png"} <= {p.name for p in svg.iterdir()}
    assert (svg / "bed_drive_cycle.svg").read_text().lstrip().startswith("<?xml")


def test_svg_without_plot_is_refused_before_the_run(tmp_path, capsys):
    from harness.__main__ import main

    assert main(["run", "bed_drive", "--svg", "--out", str(tmp_path / "r.csv")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--svg needs --plot" in err[0]
    assert not any(tmp_path.iterdir())


def test_a_tiny_signal_carries_its_power_of_ten_in_the_unit_and_ports_are_titled_short():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    from harness.specs import Panel

    t = np.linspace(0.0, 1.0, 11)
    df = pd.DataFrame({"press.sync_error": 1.4e-5 * np.sin(6 * t)}, index=t)
    fig, ax = plt.subplots()
    chartdraw.draw_panel(ax, t, df, Panel("Synchronisation error", ("press.sync_error",)), {"press.sync_error": "m"})
    fig.canvas.draw()
    assert ax.get_ylabel() == "[1e-6 m]" and ax.yaxis.get_offset_text().get_text() == ""
    assert max(abs(v) for v in ax.get_lines()[0].get_ydata()) == pytest.approx(14.0, rel=0.01)
    plt.close(fig)
    title = charts._meaning("motor.pulley.tau", {"motor.pulley.tau": "driven pulley (on the flywheel shaft): "
                                                 "torque, reaction this component exerts on the driving flange"})
    assert title == "Driven pulley (on the flywheel shaft): torque (motor.pulley.tau)"


# -- every drive against its machine cycle --------------------------------------------------------------------
def test_every_press_drive_declares_a_cycle_chart_with_a_work_zone_and_a_power_panel():
    from harness.run import system_names

    for name in system_names():
        system = load(name)
        if name == "two_inertia":
            assert system.chart is None
            continue
        spec = system.chart
        assert spec is not None and spec.crank_angle and spec.zones, name
        if system.quantities.motor is not None:   # spine_knife_rigid: the paper's rigid drive end, no motor
            assert any(c.endswith("power_electrical") for p in spec.panels if p.cycle for c in p.columns), name
        assert all("angle from" not in p.title for p in spec.panels), name


@pytest.mark.parametrize("name, stop, zone_column", [("spine_knife", 0.25, "knife.cutting"),
                                                     ("trimmer_conveyor", 0.6, "trim.blocks_cut")])
def test_cycle_chart_of_the_knife_and_the_trimmer(fmu_dir, figures, tmp_path, name, stop, zone_column):
    system = load(name).on_fmus(fmu_dir)
    df = run(system, stop_time=stop)
    paths = charts.plot_result(system, df, tmp_path)
    assert f"{name}_cycle.png" in [p.name for p in paths]
    assert_laid_out(figures[name])
    assert_laid_out(figures[f"{name}_cycle"])
    axes = visible_axes(figures[f"{name}_cycle"])
    for ax in axes:
        assert ax.get_xlim() == (0.0, 360.0)
        assert ax.patches, f"{ax.get_title(loc='left')}: the work zone is not shaded"
    label = axes[0].get_xlabel()
    # the trimmer's machine cycle is a block pitch, not a turn of its shaft: machine degrees
    assert ("machine cycle" in label) == (name == "trimmer_conveyor"), label
    (zone_label, on), = charts._zones(system, df)
    assert on.any() and not on.all()
    assert np.all(df[zone_column].to_numpy()[on] > (0 if name == "spine_knife" else 3))
    # speeds in rpm: the crank / drive shaft panel reads its speed in rpm
    speed = next(ax for ax in axes if "speed" in ax.get_title(loc="left").lower() and "[rpm]" in ax.get_title(loc="left"))
    y = speed.get_lines()[0].get_ydata()
    w = df[system.quantities.shaft_speed].to_numpy() * 60 / (2 * math.pi)
    assert w.min() - 1e-9 <= np.median(y) <= w.max() + 1e-9


def test_start_up_is_marked_on_the_time_chart(fmu_dir, figures, tmp_path):
    system = load("spine_knife").on_fmus(fmu_dir)
    df = run(system, stop_time=0.25)
    end = df.attrs["quantities"].cycles.steady[0]
    charts.plot_result(system, df, tmp_path)
    ax = visible_axes(figures["spine_knife"])[0]
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert hatched and max(p.get_x() + p.get_width() for p in hatched) == pytest.approx(end)
    assert any("start-up" in t.get_text() for leg in figures["spine_knife"].legends for t in leg.get_texts())


def test_a_port_described_with_its_angle_convention_is_titled_by_its_name():
    title = charts._meaning("linkage.crank.tau", {"linkage.crank.tau": "Crank O2A, angle from the frame line "
                                                  "O2->O5, CCW: torque, reaction on the driving flange"})
    assert title == "Crank O2A: torque (linkage.crank.tau)"


def test_run_plot_says_why_there_is_no_cycle_chart(fmu_dir, tmp_path, monkeypatch, capsys):
    from harness.__main__ import main

    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    assert main(["run", "spine_knife", "--stop-time", "0.05", "--output", "knife.knife.tau", "--plot",
                 str(tmp_path), "--out", str(tmp_path / "k.csv")]) == 0
    out = capsys.readouterr().out
    assert "no cycle chart: the crank angle shaft.crank.phi was not recorded (add --output shaft.crank.phi)" in out
    assert not (tmp_path / "spine_knife_cycle.png").exists()
