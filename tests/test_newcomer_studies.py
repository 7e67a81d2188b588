"""Issue 30, a press engineer's first day with the studies: nothing lost, nothing that hurts the machine,
no spec mistake that runs quietly, no noise.  Each test names the case a newcomer met."""
from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
import yaml

from harness.__main__ import main
from harness.studies import sweep, sweep_checks

ROOT = Path(__file__).resolve().parents[1]

TINY = {"stop_time": 0.02, "step": 1e-3, "master": "jacobi",
        "grid": {"b.c": [50.0, 200.0], "w": [1.0, 2.0]}, "set": {"a.w0": "w * 1.5"},
        "outputs": {"w_end": 'final(r["a.flange.w"])'}}


def _spec(tmp_path: Path, data: dict) -> Path:
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# -- item 1: --workers beyond the CPUs -------------------------------------------------------------------------
def test_more_workers_than_cpus_is_refused_before_anything_starts(tmp_path, capsys):
    cpus = sweep_checks.available_cpus()
    out = tmp_path / "r.csv"
    assert main(["sweep", "two_inertia", "--grid", str(_spec(tmp_path, TINY)), "--workers", str(cpus + 1),
                 "--out", str(out)]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--workers {cpus + 1}" in err and f"{cpus} CPU" in err
    assert not out.exists() and not sweep_checks.partial_path(out).exists()   # nothing started
    # an existing scheduler brings its own workers: the local count is not the limit there
    assert sweep_checks.check_workers(cpus + 1, local=False) == cpus + 1


def test_the_default_worker_count_fits_the_cpus():
    assert 1 <= sweep_checks.default_workers() <= sweep_checks.available_cpus()


# -- item 2: a misspelt grid key -------------------------------------------------------------------------------
def test_a_grid_variable_that_changes_nothing_is_refused_with_a_close_match(tmp_path, capsys):
    data = dict(TINY, grid={"b.c": [50.0, 200.0], "w": [1.0, 2.0], "w0": [1.0, 2.0]})  # meant a.w0 or b.w0
    path = _spec(tmp_path, data)
    assert main(["sweep", "two_inertia", "--grid", str(path), "--workers", "0",
                 "--out", str(tmp_path / "r.csv")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(path) in err and "grid.w0" in err and "'a.w0'" in err and "instances: a, b" in err
    assert not (tmp_path / "r.csv").exists()


def test_a_misspelt_name_that_no_expression_reads_is_refused(tmp_path, capsys):
    data = dict(TINY, grid={"b.c": [50.0, 200.0], "w": [1.0], "speeed": [1.0, 2.0]})
    assert main(["sweep", "two_inertia", "--grid", str(_spec(tmp_path, data)), "--workers", "0",
                 "--out", str(tmp_path / "r.csv")]) != 0
    err = capsys.readouterr().err.strip()
    assert "grid.speeed" in err and "they read w" in err


def test_a_sampled_variable_that_changes_nothing_is_refused(tmp_path):
    data = {k: v for k, v in TINY.items() if k != "grid"}
    data["sample"] = {"n": 2, "ranges": {"w": [1.0, 2.0], "spede": [1.0, 2.0]}}
    spec = sweep.read_spec(_spec(tmp_path, data))
    with pytest.raises(sweep.SweepError, match=r"sample\.ranges\.spede"):
        sweep_checks.preflight("two_inertia", spec, None, 0)


def test_a_set_expression_with_a_misspelt_variable_suggests_it(tmp_path):
    data = dict(TINY, set={"a.w0": "ww * 1.5"})
    with pytest.raises(sweep.SweepError, match=r"unknown name 'ww' \(did you mean 'w'\?\); known names: pi, sqrt, w"):
        sweep.read_spec(_spec(tmp_path, data))


def test_a_misspelt_parameter_suggests_the_close_one(tmp_path):
    data = dict(TINY, grid={"b.cc": [50.0, 200.0], "w": [1.0]})
    spec = sweep.read_spec(_spec(tmp_path, data))
    with pytest.raises(sweep.SweepError, match=r"grid\.b\.cc: .* no parameter 'cc'; did you mean 'c'"):
        sweep_checks.preflight("two_inertia", spec, None, 0)


# -- item 4: a quick benchmark run leaves the README's chart alone ----------------------------------------------
def test_quick_benchmark_writes_its_chart_beside_its_csv_not_over_the_tracked_one(monkeypatch, capsys):
    from benchmarks import bench

    seen = {}
    monkeypatch.setattr(bench, "run_all", lambda cases, tools, modes, quick, work, *a: seen.update(work=work) or [])
    monkeypatch.setattr(bench, "write_csv", lambda rows, path: path)
    monkeypatch.setattr(bench, "report", lambda rows: None)
    monkeypatch.setattr(bench, "chart", lambda rows, path: seen.update(chart=path) or [path])
    # --no-batch: the batches of variants are benchmarks.batch's, tested in test_benchmarks (a full one takes minutes)
    assert bench.main(["--quick", "--cases", "ring", "--tools", "jacobi-sampled", "--modes", "unpinned",
                       "--no-realtime", "--no-batch"]) == 0
    tracked = bench.ROOT / "docs" / "images" / "benchmark.png"
    assert seen["chart"] != tracked and seen["chart"].parent == seen["work"]
    assert seen["work"] != bench.ROOT / "results" / "benchmark"        # nor over a full run's CSV
    out = capsys.readouterr().out
    assert str(seen["chart"]) in out and "timings mean nothing" in out
    # a full run still writes the README's chart
    bench.main(["--cases", "ring", "--tools", "jacobi-sampled", "--modes", "unpinned", "--no-realtime", "--no-batch"])
    assert seen["chart"] == tracked


# -- item 3: a study stopped by Ctrl-C or SIGTERM keeps its finished rows; a bad value loses nothing -----------
class _Sigterm(KeyboardInterrupt):
    """What the command line raises on SIGTERM (harness.run.Terminated): an interrupt with status 143."""
    status = 143


def _interrupt_after(n: int, real, exc=KeyboardInterrupt):
    calls = []

    def wrapped(*a, **k):
        calls.append(1)
        if len(calls) > n:
            raise exc()
        return real(*a, **k)
    return wrapped


@pytest.mark.parametrize("exc, status, how", [(KeyboardInterrupt, 130, "interrupted (Ctrl-C)"),
                                              (_Sigterm, 143, "terminated (SIGTERM)")])
def test_precision_study_interrupted_keeps_its_finished_runs(tmp_path, monkeypatch, capsys, exc, status, how):
    from harness.studies import precision

    monkeypatch.setattr(precision, "quiet_simulate", _interrupt_after(2, precision.quiet_simulate, exc))
    assert main(["study", "precision", "two_inertia", "--quick", "--stop-time", "0.05",
                 "--out", str(tmp_path)]) == status
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"error: {how}") and "after 2 runs" in err[-1]
    assert not (tmp_path / "precision_two_inertia.csv").exists()   # an incomplete table never looks complete
    kept = pd.read_csv(tmp_path / "precision_two_inertia.partial.csv")
    assert set(kept["master"]) == {"reference", "jacobi"}
    assert int((kept["quantity"] & (kept["master"] == "jacobi")).sum()) == 2


def test_stability_study_interrupted_keeps_its_finished_rows(tmp_path, monkeypatch, capsys):
    from harness.studies.stability import measured

    monkeypatch.setattr(measured, "stability_boundary", _interrupt_after(5, measured.stability_boundary, _Sigterm))
    assert main(["study", "stability", "two_inertia", "--quick", "--values", "0.5", "2",
                 "--out", str(tmp_path)]) == 143
    kept = pd.read_csv(tmp_path / "stability_two_inertia_inertia.partial.csv")
    assert len(kept) == 2 and (kept["ratio"] == 0.5).all()       # rk4 + exact per row: 5 calls = 2 rows
    assert "terminated (SIGTERM)" in capsys.readouterr().err
    assert not (tmp_path / "stability_two_inertia_inertia.csv").exists()


def test_a_completed_study_removes_the_partial_table_of_an_interrupted_one(tmp_path):
    from harness.studies.trial import partial_csv, write_complete

    csv = tmp_path / "x.csv"
    partial_csv(csv).write_text("a\n1\n")
    write_complete(pd.DataFrame({"a": [1, 2]}), csv)
    assert csv.exists() and not partial_csv(csv).exists()


@pytest.mark.parametrize("values", [["0.5", "-1"], ["-1", "0.5"]])
def test_stability_values_negative_anywhere_get_one_line_before_any_run(tmp_path, capsys, values):
    assert main(["study", "stability", "two_inertia", "--quick", "--values", *values, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--values: -1.0 is not admissible" in err and "nothing was run" in err


def test_press_stability_value_the_drive_refuses_is_a_failed_row_and_the_others_are_kept(tmp_path, monkeypatch,
                                                                                        capsys):
    """Every value's reference runs first; one that fails (here: the FMU refusing a negative inertia) is
    recorded with its one-line reason on every method's row, the other values are measured."""
    from harness.studies.stability import cli, press

    class Run:
        def __init__(self, system, master, order, parameters, duration, reference=None):
            (value,) = parameters.values()
            if value < 0:
                raise ValueError(f"rocker_inertia = {value} is below its minimum 0")
            self.ref = "ref"

    monkeypatch.setattr(press, "PressRun", Run)
    monkeypatch.setattr(press, "press_boundary", lambda prun, rtol, cap: dict(
        h_stable=1e-3, h_unstable=2e-3, h_boundary=1.5e-3, status="bracketed", runs=3))
    monkeypatch.setattr(cli, "plot_press_map", lambda table, stem: [])
    assert main(["study", "stability", "bed_drive", "--values", "0.5", "-1", "--masters", "jacobi",
                 "--orders", "0", "1", "--out", str(tmp_path)]) == 1
    table = pd.read_csv(tmp_path / "stability_bed_drive_fourbar_rocker_inertia.csv", keep_default_na=False)
    assert list(table["status"]) == ["bracketed", "bracketed", "failed", "failed"]
    assert table["error"].iloc[2].startswith("ValueError: rocker_inertia = -1.0 is below")
    err = capsys.readouterr().err
    assert "2 of 4 rows failed" in err and "nan" not in err


def test_stability_progress_says_why_a_boundary_was_not_measured(capsys):
    from harness.studies.stability.measured import stability_table

    lines = []
    table = stability_table(values=[0.5], measure=False, progress=lines.append)
    assert lines and not any("nan" in line for line in lines)
    assert all("not measured: theory only" in line for line in lines)
    assert (table["note"] == "not measured: theory only").all()


# -- item 5 (scenes): a candidate that blows up is a row naming its configuration, not an anonymous warning -----
def _unstable_scene():
    import dataclasses

    from harness import load

    system = load("two_inertia")
    scene = next(s for s in system.scenes if s.name == "mean_speed")
    return system, dataclasses.replace(scene, stop_time=5.0)     # jacobi at 10 ms diverges at 0.32 s


def test_a_scene_candidate_that_stops_early_warns_nothing_and_keeps_its_reason():
    import warnings

    from harness.studies import scenes

    system, scene = _unstable_scene()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        c = scenes._run(system, scene, {}, 0.01, 1.0, "jacobi")
    assert [str(w.message) for w in seen] == []
    assert not c.ok and c.error is None and "diverged" in c.note


def test_each_scene_candidate_is_named_by_what_differs_from_the_full_model():
    from harness.studies.scenes import Candidate, configuration

    full = Candidate({"motor": 2, "fourbar": 2}, 2e-4, 1.0, 0.0, 2.5, True, "", "jacobi")
    assert configuration(full, full) == "full model"
    c = Candidate({"motor": 2, "fourbar": 1}, 4e-4, None, None, 0.1, False, "blew up", "gauss-seidel")
    assert configuration(c, full) == "fourbar level 1, step 0.4 ms, gauss-seidel"


def test_scene_interrupted_keeps_the_candidates_run_so_far(tmp_path, monkeypatch, capsys):
    import dataclasses

    from harness import load
    from harness.studies import scenes

    system = load("two_inertia")
    scene = dataclasses.replace(next(s for s in system.scenes if s.name == "mean_speed"), stop_time=0.06)
    monkeypatch.setattr(system, "scenes", [scene])
    monkeypatch.setattr(scenes, "_run", _interrupt_after(2, scenes._run, _Sigterm))
    assert main(["scene", "two_inertia", "mean_speed", "--out", str(tmp_path)]) == 143
    kept = pd.read_csv(tmp_path / "scene_two_inertia_mean_speed.partial.csv")
    assert len(kept) == 2 and kept["ok"].iloc[0]
    assert not (tmp_path / "scene_two_inertia_mean_speed.csv").exists()
    assert "terminated (SIGTERM)" in capsys.readouterr().err


# -- item 5 (inputs): a shipped drive declares the inputs it leaves free; a user's forgotten one still warns ------
def _validate(system):
    import warnings

    from harness.model import SystemWarning, model_description, resolve_fmu

    mds = {i.name: model_description(resolve_fmu(i.fmu)) for i in system.instances}
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        system.validate(mds)
    return [str(w.message) for w in seen if issubclass(w.category, SystemWarning)]


@pytest.mark.parametrize("name", ["bed_drive", "feeder_gto52", "proof_press", "spine_knife", "two_inertia"])
def test_a_shipped_system_warns_about_no_input(name):
    from harness import load

    assert _validate(load(name)) == []


def test_an_undeclared_unconnected_input_still_warns_with_the_way_out():
    import dataclasses

    from harness import load

    mine = dataclasses.replace(load("proof_press"), free_inputs={})     # a user's copy that declares nothing
    seen = _validate(mine)
    # flywheel.aux.tau, press.bed.f and the motor's supply and brake
    assert len(seen) == 4 and any("input press.bed.f is not connected" in w for w in seen)
    assert any("input motor.brake is not connected" in w for w in seen)
    assert all("free_inputs" in w for w in seen)


@pytest.mark.parametrize("free, message", [
    ({"press.bed.s": "x"}, "free_inputs names press.bed.s, which is output, not an input"),
    ({"press.crank.tau": "x"}, "free_inputs names press.crank.tau, which is output"),
    ({"press.crank.phi": "x"}, "free_inputs names press.crank.phi, but it is connected from flywheel.crank.phi"),
    ({"press.bed.f": " "}, "say why its start value is right"),
    ({"press.nothing": "x"}, "has no variable 'nothing'"),
])
def test_a_wrong_free_input_declaration_is_one_line(free, message):
    import dataclasses

    from harness import load
    from harness.errors import SystemError_

    bad = dataclasses.replace(load("proof_press"), free_inputs=free)
    with pytest.raises(SystemError_) as info:
        _validate(bad)
    assert message in str(info.value) and "\n" not in str(info.value)


# -- item 7: study charts a press engineer reads: units everywhere, legends off the data ------------------------
def _capture(monkeypatch, module):
    """The figure ``module`` hands to save_figure, drawn, instead of written."""
    figs = []

    def keep(fig, stem, dpi=None):
        fig.canvas.draw()
        figs.append(fig)
        return []
    monkeypatch.setattr(module, "save_figure", keep)
    return figs


def _check_chart(fig):
    import re

    unit = re.compile(r"\[[^\]]+\]")
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert any(ax.get_xlabel() for ax in axes)
    for ax in axes:
        assert unit.search(ax.get_xlabel()) or not ax.get_xlabel(), ax.get_xlabel()   # shared x: the lowest row
        assert unit.search(ax.get_ylabel()), ax.get_ylabel()
    legends = [*fig.legends, *(ax.get_legend() for ax in axes if ax.get_legend() is not None)]
    assert legends
    for leg in legends:
        box = leg.get_window_extent()
        for ax in axes:
            assert not box.overlaps(ax.get_window_extent()), "a legend covers a panel"
    return legends


def test_sweep_chart_has_units_on_axes_and_legend_and_the_legend_off_the_panels(monkeypatch):
    data = dict(TINY, plot={"x": "w", "y": ["w_end"], "hue": "b.c", "units": {"w": "rad/s", "w_end": "rad/s"}})
    spec = sweep.parse_spec(data)
    df = pd.DataFrame({"b.c": [50.0, 50.0, 200.0, 200.0], "w": [1.0, 2.0, 1.0, 2.0], "w_end": [1.0, 2.0, 3.0, 4.0],
                       "error": ["", "", "", ""], "wall_time": [0.1] * 4})
    figs = _capture(monkeypatch, sweep)
    sweep.plot_sweep(df, spec, "unused", units=sweep_checks.parameter_units("two_inertia", spec))
    (legend,) = _check_chart(figs[0])
    assert [t.get_text() for t in legend.get_texts()] == ["b.c = 50 N.m/rad", "b.c = 200 N.m/rad"]
    assert figs[0].axes[0].get_xlabel() == "w [rad/s]"


def test_sweep_chart_marks_a_column_without_a_unit():
    spec = sweep.parse_spec(dict(TINY, plot={"x": "w", "y": ["w_end"]}))
    assert spec.plot["units"] == {}
    with pytest.raises(sweep.SweepError, match=r"plot\.units: unknown column 'nope'"):
        sweep.parse_spec(dict(TINY, plot={"x": "w", "y": ["w_end"], "units": {"nope": "m"}}))


def test_shipped_sweep_specs_give_a_unit_to_every_plotted_column():
    for name, system in [("feeder_clearance", "feeder_gto52"), ("knife_resonance", "spine_knife")]:
        spec = sweep.read_spec(ROOT / "systems" / "studies" / f"{name}.yaml")
        known = {**sweep_checks.parameter_units(system, spec), **spec.plot["units"]}
        pl = spec.plot
        assert [c for c in [*pl["x"], *pl["y"], *pl["hue"], *pl["facet"]] if c not in known] == [], name


def test_stability_maps_have_units_and_legends_off_the_data(monkeypatch):
    from harness.studies.stability import measured, press

    t = pd.read_csv(ROOT / "docs" / "images" / "stability_two_inertia_inertia.csv")
    figs = _capture(monkeypatch, measured)
    measured.plot_stability_map(t, "unused")
    _check_chart(figs[0])
    assert figs[0].axes[0].get_xlabel() == "J2/J1 [1]"
    t = pd.read_csv(ROOT / "docs" / "images" / "stability_bed_drive_fourbar_rocker_inertia.csv")
    figs = _capture(monkeypatch, press)
    press.plot_press_map(t, "unused")
    _check_chart(figs[0])
    assert figs[0].axes[0].get_xlabel() == "fourbar.rocker_inertia [kg.m2]"


def test_scene_chart_names_every_candidate_and_keeps_its_legends_off_the_data(monkeypatch):
    from harness.specs import Scene
    from harness.studies import scenes
    from harness.studies.scenes import Candidate, SceneResult

    full = Candidate({"motor": 2, "fourbar": 2}, 2e-4, 1.0, 0.0, 2.5, True, "", "jacobi")
    cands = [full, Candidate({"motor": 0, "fourbar": 2}, 2e-4, 1.2, 0.2, 0.7, False, "", "jacobi"),
             Candidate({"motor": 2, "fourbar": 1}, 2e-4, 1.01, 0.01, 1.1, True, "", "jacobi"),
             Candidate({"motor": 2, "fourbar": 1}, 4e-4, None, None, 0.1, False, "blew up", "jacobi")]
    scene = Scene("q", "What?", 'final(r["a.flange.w"])', tolerance=0.05, unit="m/s")
    figs = _capture(monkeypatch, scenes)
    scenes.chart(SceneResult(scene, full, cands[2], cands, 2.3), "unused")
    legends = _check_chart(figs[0])
    texts = [t.get_text() for leg in legends for t in leg.get_texts()]
    assert " 1  motor level 0" in texts and " 2  fourbar level 1" in texts
    assert " 3  fourbar level 1, step 0.4 ms (stopped early)" in texts
    numbers = [t.get_text() for t in figs[0].axes[0].texts]
    assert numbers == ["1", "2", "3"]


def test_sigterm_from_outside_keeps_a_precision_study_s_finished_runs(tmp_path):
    """The whole path: ``timeout``/``kill`` sends SIGTERM to the command while it runs its grid."""
    import os
    import signal
    import subprocess
    import sys
    import time

    env = dict(os.environ, PRESSDRIVE_NORMAL_EXIT="1")
    proc = subprocess.Popen([sys.executable, "-m", "harness", "study", "precision", "two_inertia", "--stop-time", "0.3",
                             "--steps", "1e-4", "2e-4", "4e-4", "--masters", "jacobi", "gauss-seidel",
                             "--out", str(tmp_path)], cwd=ROOT, env=env, stderr=subprocess.PIPE, text=True)
    lines = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        lines.append(line)
        if "order" in line:            # the first co-simulation of the grid has finished
            break
    proc.send_signal(signal.SIGTERM)
    rest = proc.stderr.read()
    assert proc.wait(timeout=60) == 143, "".join(lines) + rest
    assert "terminated (SIGTERM)" in rest and "precision_two_inertia.partial.csv" in rest
    kept = pd.read_csv(tmp_path / "precision_two_inertia.partial.csv")
    assert (kept["master"] == "reference").any() and (kept["master"] == "jacobi").any()
    assert not (tmp_path / "precision_two_inertia.csv").exists()


def test_study_takeup_keeps_its_finished_take_ups_on_sigterm(tmp_path):
    """Issue 30: SIGTERM during `study takeup` threw every finished take-up away (nothing written, exit 0)."""
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "harness", "study", "takeup", "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    first = ""
    while time.time() < deadline and "done" not in first:   # one block of take-ups finished
        first = proc.stderr.readline()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    partial = tmp_path / "takeup.partial.csv"
    assert partial.is_file() and not (tmp_path / "takeup.csv").exists()
    import pandas as pd

    assert len(pd.read_csv(partial)) > 0
    assert "kept in" in err and "\n" not in err.strip().splitlines()[-1]
