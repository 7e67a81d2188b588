"""Issue 30, a press engineer's first day with the studies: nothing lost, nothing that hurts the machine,
no spec mistake that runs quietly, no noise.  Each test names the case a newcomer met."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from harness.__main__ import main
from harness.studies import sweep, sweep_checks

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
    assert bench.main(["--quick", "--cases", "ring", "--tools", "jacobi-sampled", "--modes", "unpinned",
                       "--no-realtime"]) == 0
    tracked = bench.ROOT / "docs" / "images" / "benchmark.png"
    assert seen["chart"] != tracked and seen["chart"].parent == seen["work"]
    assert seen["work"] != bench.ROOT / "results" / "benchmark"        # nor over a full run's CSV
    out = capsys.readouterr().out
    assert str(seen["chart"]) in out and "timings mean nothing" in out
    # a full run still writes the README's chart
    bench.main(["--cases", "ring", "--tools", "jacobi-sampled", "--modes", "unpinned", "--no-realtime"])
    assert seen["chart"] == tracked
