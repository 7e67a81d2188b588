"""The run's chart workers (harness/chartworkers.py): processes that draw the figures side by side.

They must give the very files the command's own process draws, lose no chart when a worker dies (drawn in
process, one warning line), report a drawing's own error as the process would, and be gone when the command
ends."""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from harness import chartdraw, charts, chartworkers, load, simulate
from harness.model import SystemWarning
from harness.specs import Panel


@pytest.fixture(scope="module")
def bed(fmu_dir):
    system = load("bed_drive").on_fmus(fmu_dir)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)
        df = simulate(system, stop_time=1.1, on_error="raise")
    return system, df


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:          # a zombie is gone for the user
        return f.read().split(")")[-1].split()[0] != "Z"


def test_workers_draw_the_same_files_as_the_process(bed, tmp_path):
    system, df = bed
    here = charts.plot_result(system, df, tmp_path / "here")
    with chartworkers.ChartWorkers(2) as workers:
        there = charts.plot_result(system, df, tmp_path / "there", workers=workers)
        assert workers.drawn == 2
    assert [p.name for p in there] == [p.name for p in here] == ["bed_drive.png", "bed_drive_cycle.png"]
    for a, b in zip(here, there):
        assert a.read_bytes() == b.read_bytes(), f"{b.name} differs from the one drawn in process"


def test_a_dead_worker_loses_no_chart_and_says_so(bed, tmp_path, capsys):
    system, df = bed
    with chartworkers.ChartWorkers(2) as workers:
        victim = workers._workers[1][0]
        victim.kill()
        victim.wait()
        paths = charts.plot_result(system, df, tmp_path, workers=workers)
        assert workers.drawn == 1
    assert [p.name for p in paths] == ["bed_drive.png", "bed_drive_cycle.png"]
    assert all(p.stat().st_size > 0 for p in paths)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "chart worker failed" in err[0] and "exit status -9" in err[0], err


def test_a_drawing_error_is_the_one_the_process_raises(tmp_path):
    bad = chartdraw.Figure(stem="bad", title="bad", x=np.linspace(0.0, 1.0, 5), xlabel="time [s]",
                           panels=[Panel("Missing", ("a.b",))], columns={})
    with pytest.raises(KeyError, match="a.b"):
        chartdraw.draw(bad, tmp_path)
    with chartworkers.ChartWorkers(1) as workers, pytest.raises(KeyError, match="a.b"):
        workers.draw([bad], tmp_path)


def test_one_cpu_draws_in_process(monkeypatch):
    monkeypatch.setattr(chartworkers, "available_cpus", lambda: 1)
    chartworkers.start_early()
    assert chartworkers.take() is None and chartworkers.for_run() is None


def test_the_run_command_ends_its_workers(fmu_dir, tmp_path, monkeypatch, capsys):
    from harness.__main__ import main

    if chartworkers.available_cpus() < 2:
        pytest.skip("one CPU available: the run command draws its charts in process, without workers")
    started = []
    real = chartworkers.ChartWorkers._start

    def spy():
        worker = real()
        started.append(worker[0].pid)
        return worker

    monkeypatch.setattr(chartworkers.ChartWorkers, "_start", staticmethod(spy))
    monkeypatch.setenv("PRESSDRIVE_FMU_DIR", str(fmu_dir))
    monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)   # main() sets its own
    assert main(["run", "bed_drive", "--stop-time", "1.05", "--quiet-quantities", "--plot", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bed_drive.png", "bed_drive_cycle.png"]
    assert len(started) == 2, started
    assert not [pid for pid in started if _alive(pid)], "a chart worker outlived the command"
    # a command that stops before its run (an unknown system) ends the worker it started early too
    started.clear()
    assert main(["run", "no_such_drive", "--plot", str(tmp_path)]) == 1
    assert started and not [pid for pid in started if _alive(pid)]
    assert "no_such_drive" in capsys.readouterr().err


def test_an_interrupted_drawing_leaves_no_torn_chart(tmp_path, monkeypatch):
    from matplotlib.figure import Figure as MplFigure

    def torn(self, fname, **kw):               # half a file written, then Ctrl-C
        Path(fname).write_bytes(b"\x89PNG\r\n")
        raise KeyboardInterrupt

    fig = MplFigure()
    monkeypatch.setattr(MplFigure, "savefig", torn)
    with pytest.raises(KeyboardInterrupt):
        chartdraw.save_figure(fig, tmp_path / "chart", svg=False)
    assert list(tmp_path.iterdir()) == []
