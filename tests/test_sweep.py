"""Parameter sweeps (harness.studies.sweep): spec parsing and errors, Latin hypercube, failed points, charts, and a
2-worker dask LocalCluster giving exactly the serial results."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness.studies import sweep

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "systems" / "studies"

# two_inertia: a (Inertia J, w0) drives b (SpringInertia J, c, d)
TINY = {
    "stop_time": 0.02, "step": 1e-3, "master": "jacobi",
    "grid": {"b.c": [50.0, 200.0], "w": [1.0, 2.0]},
    "set": {"a.w0": "w * 1.5"},
    "outputs": {"w_end": 'final(r["a.flange.w"])', "tau_peak": 'peak(r["b.drive.tau"])'},
    "plot": {"x": "w", "y": ["w_end", "tau_peak"], "hue": "b.c"},
}


def write_yaml(path: Path, data: dict) -> Path:
    import yaml

    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# -- parsing ---------------------------------------------------------------------------------------------------
def test_yaml_and_json_give_the_same_spec(tmp_path):
    a = sweep.read_spec(write_yaml(tmp_path / "s.yaml", TINY))
    (tmp_path / "s.json").write_text(json.dumps(TINY))
    b = sweep.read_spec(tmp_path / "s.json")
    assert a.points == b.points and a.set == b.set and a.outputs == b.outputs and a.run == b.run
    assert a.plot == b.plot
    # full factorial in the order of the keys, the last varying fastest
    assert a.points == [{"b.c": 50.0, "w": 1.0}, {"b.c": 50.0, "w": 2.0},
                        {"b.c": 200.0, "w": 1.0}, {"b.c": 200.0, "w": 2.0}]
    # dotted sweep variables are parameters, the others only feed the set expressions
    assert a.parameters(a.points[3]) == {"b.c": 200.0, "a.w0": 3.0}


def test_linspace_logspace():
    spec = sweep.parse_spec({"grid": {"x": {"linspace": [0, 1, 5]}, "y": {"logspace": [1, 100, 3]}}})
    xs = sorted({p["x"] for p in spec.points})
    ys = sorted({p["y"] for p in spec.points})
    assert xs == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert ys == pytest.approx([1.0, 10.0, 100.0], rel=1e-14)


def test_lhs_reproducible_and_stratified():
    data = {"sample": {"method": "lhs", "n": 8, "seed": 7, "ranges": {"p": [10.0, 20.0], "q": [-1.0, 1.0]}}}
    a, b = sweep.parse_spec(data), sweep.parse_spec(data)
    assert a.points == b.points
    c = sweep.parse_spec({"sample": dict(data["sample"], seed=8)})
    assert c.points != a.points
    # Latin hypercube: each of the n equal strata of every range holds exactly one point
    for name, (lo, hi) in data["sample"]["ranges"].items():
        v = np.array([p[name] for p in a.points])
        strata = np.floor((v - lo) / (hi - lo) * 8).astype(int)
        assert sorted(strata) == list(range(8))


@pytest.mark.parametrize("change, key", [
    ({"colour": 1}, "unknown key(s) ['colour']"),
    ({"grid": {"b.c": "many"}}, "grid.b.c"),
    ({"grid": {"b.c": ["x"]}}, "grid.b.c"),
    ({"set": {"a.w0": "v * 2"}}, "set.a.w0"),
    ({"set": {"a.w0": "__import__('os')"}}, "set.a.w0"),
    ({"outputs": {"bad": "peak(r['a.x'].sum())"}}, "outputs.bad"),
    ({"plot": {"x": "w", "y": ["nope"]}}, "plot.y"),
    ({"plot": {"x": "w", "y": ["w_end"], "reduce": "median"}}, "plot.reduce"),
    ({"plot": {"x": "w", "y": ["w_end"], "xspan": [0.4, 0.3]}}, "plot.xspan"),
    ({"plot": {"x": "w", "y": ["w_end"], "xspan": [0.3, 0.4, 5]}}, "plot.xspan"),
    ({"sample": {"n": 3, "ranges": {"p": [2, 1]}}}, "sample.ranges.p"),
])
def test_spec_errors_are_one_line_naming_file_and_key(tmp_path, change, key):
    data = dict(TINY, **change)
    if "sample" in change:
        data.pop("grid")
    path = write_yaml(tmp_path / "bad.yaml", data)
    with pytest.raises(sweep.SweepError) as e:
        sweep.read_spec(path)
    msg = str(e.value)
    assert msg.startswith(str(path) + ": ") and key in msg and "\n" not in msg


def test_unparsable_and_missing_files(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("{not json")
    with pytest.raises(sweep.SweepError, match=r"x.json: cannot parse"):
        sweep.read_spec(p)
    with pytest.raises(sweep.SweepError, match=r"no such sweep file"):
        sweep.read_spec(tmp_path / "none.yaml")


# -- running ----------------------------------------------------------------------------------------------------
def _without_wall(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["wall_time"])


def test_failed_point_is_recorded_and_does_not_abort():
    data = dict(TINY, grid={"b.c": [-5.0, 100.0], "w": [1.0]})   # c below its bound 0 in the first point
    spec = sweep.parse_spec({k: v for k, v in data.items() if k != "plot"})
    df = sweep.run_sweep("two_inertia", spec, workers=0, progress=False)
    assert len(df) == 2
    assert "c" in df.loc[0, "error"] and "-5" in df.loc[0, "error"]
    assert math.isnan(df.loc[0, "w_end"]) and math.isnan(df.loc[0, "tau_peak"])
    assert df.loc[1, "error"] == "" and np.isfinite(df.loc[1, "w_end"])
    # a bad set expression (division by zero at this point) is recorded too
    spec = sweep.parse_spec(dict(TINY, grid={"w": [0.0]}, set={"a.w0": "1 / w"}, plot={"x": "w", "y": "w_end"}))
    row = sweep.run_point("two_inertia", spec, spec.points[0])
    assert "set.a.w0" in row["error"] and "divides by zero" in row["error"]


def test_two_worker_cluster_equals_serial_exactly():
    spec = sweep.parse_spec(TINY)
    serial = sweep.run_sweep("two_inertia", spec, workers=0, progress=False)
    dist = sweep.run_sweep("two_inertia", spec, workers=2, progress=False)
    assert (serial["error"] == "").all()
    # the physics answers: the quantities differ between points (the test would notice a mix-up of rows)
    assert serial["w_end"].nunique() == 4
    pd.testing.assert_frame_equal(_without_wall(serial), _without_wall(dist), check_exact=True)


@pytest.mark.parametrize("name, system", [("feeder_clearance", "feeder_gto52"),
                                          ("knife_resonance", "spine_knife")])
def test_one_point_of_each_study_runs(name, system):
    """The study spec parses, its set expressions give parameters the FMUs accept, its quantities read
    existing columns; run short (the quantities' windows start later, so read final values here)."""
    spec = sweep.read_spec(STUDIES / f"{name}.yaml")
    assert spec.system == system and spec.plot is not None
    cols = sorted({c for e in spec.outputs.values() for c in sweep.qoi.columns(e)})
    spec.run["stop_time"] = 5 * spec.run["step"]
    spec.outputs = {c: f'final(r["{c}"])' for c in cols}
    row = sweep.run_point(system, spec, spec.points[-1])
    assert row["error"] == "", row["error"]
    assert all(np.isfinite(row[c]) for c in cols)


def test_study_quantities_on_a_synthetic_result():
    """The feeder study's impact quantities on a made-up record of two impacts, one at a rocker extreme and
    one at mid swing."""
    spec = sweep.read_spec(STUDIES / "feeder_clearance.yaml")
    t = np.linspace(0.0, 1.0, 10001)
    phi = 0.3 * np.sin(2 * np.pi * 2.5 * t)                   # rocker: extremes at t = 0.5, 0.7, 0.9
    count = (t >= 0.5).astype(float) + (t >= 0.6).astype(float)   # impacts at 0.5 (extreme) and 0.6 (middle)
    v = np.where(t >= 0.6, 0.03, np.where(t >= 0.5, 0.05, 0.9))   # 0.9 before the window: not an impact in it
    # contact flag: 1.5 ms from the extreme impact (a rebound), 50 ms from the mid-swing one (closed joint)
    contact = (((t >= 0.5) & (t < 0.5015 - 1e-9)) | ((t >= 0.6) & (t < 0.65))).astype(float)
    df = pd.DataFrame({"feeder.impact_count": count, "feeder.rocker.phi": phi, "feeder.v_impact": v,
                       "feeder.pin_force": 2.0 * np.sin(t), "flywheel.shaft_twist": 1e-4 * np.cos(t),
                       "flywheel.crank.w": np.full_like(t, 2 * np.pi * 150 / 60), "feeder.in_contact": contact,
                       "feeder.stone_radius": np.full_like(t, 0.12)}, index=t)
    q = {k: sweep.qoi.evaluate(e, df) for k, e in spec.outputs.items()}
    assert q["impacts"] == 2 and q["impacts_intermediate"] == 1
    assert q["impact_velocity"] == 0.05
    assert q["crank_speed"] == pytest.approx(150.0, rel=1e-12)
    # one period of the contact oscillation at R = 0.12 m: k = 1/(1/5e5 + 0.12^2/1e5), I2 = 0.00043 kg.m2
    k = 1.0 / (1.0 / 5.0e5 + 0.12 ** 2 / 1.0e5)
    period = 2 * np.pi / np.sqrt(k * 0.12 ** 2 / 0.00043)
    assert 1.5e-3 < period < 1.6e-3
    assert q["impacts_classical"] == 1 and q["impacts_classical_intermediate"] == 0
    assert q["shortest_contact_ms"] == pytest.approx(1.5, rel=1e-9)
    # the same record with a 1.7 ms first contact: longer than one period, no classical impact
    df["feeder.in_contact"] = (((t >= 0.5) & (t < 0.5017 - 1e-9)) | ((t >= 0.6) & (t < 0.65))).astype(float)
    assert sweep.qoi.evaluate(spec.outputs["impacts_classical"], df) == 0


def test_cli_one_command_writes_csv_and_charts(tmp_path):
    from harness.__main__ import main

    plot = dict(TINY["plot"], xspan=[1.2, 1.8, "a band"])
    grid = write_yaml(tmp_path / "tiny.yaml", dict(TINY, grid={"b.c": [50.0, 200.0], "w": [1.0, 2.0, -1.0]},
                                                   plot=plot))
    assert sweep.read_spec(grid).plot["xspan"] == [1.2, 1.8, "a band"]
    out, charts = tmp_path / "r.csv", tmp_path / "charts"
    assert main(["sweep", "two_inertia", "--grid", str(grid), "--workers", "0", "--out", str(out),
                 "--plot", str(charts)]) == 0
    df = pd.read_csv(out, keep_default_na=False)
    assert len(df) == 6 and list(df.columns[:2]) == ["b.c", "w"]
    for ext in (".png", ".svg"):
        assert (charts / f"tiny{ext}").stat().st_size > 1000
    # --plot without a plot section: one-line error, exit code 1
    nop = write_yaml(tmp_path / "noplot.yaml", {k: v for k, v in TINY.items() if k != "plot"})
    assert main(["sweep", "two_inertia", "--grid", str(nop), "--workers", "0", "--out", str(out),
                 "--plot", str(charts)]) == 1


# -- resuming safely ----------------------------------------------------------------------------------------------
RESUMABLE = {k: v for k, v in TINY.items() if k != "plot"}


def _cli_sweep(tmp_path, spec_data, *extra, system="two_inertia"):
    import contextlib
    import io

    from harness.__main__ import main

    grid = write_yaml(tmp_path / "s.yaml", spec_data)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["sweep", str(system), "--grid", str(grid), "--workers", "0", "--out", str(tmp_path / "r.csv"),
                   *extra])
    return rc, out.getvalue(), err.getvalue()


def _partial_of_a_finished_sweep(tmp_path, data=RESUMABLE, system="two_inertia"):
    """The partial file a sweep leaves just before it writes its result (every point logged)."""
    from harness.studies.sweep_checks import PointLog, identity, partial_path

    spec = sweep.parse_spec(data, str(tmp_path / "s.yaml"))
    log = PointLog(partial_path(tmp_path / "r.csv"), spec, resume=False, identity=identity(str(system), spec))
    full = sweep.run_sweep(str(system), spec, workers=0, progress=False, log=log)
    return log.path, full


@pytest.mark.parametrize("cut", ["in the outputs", "in the key values"])
def test_resume_runs_a_torn_last_row_again(tmp_path, cut):
    """A crash mid-write leaves a last line without its newline: cut inside the outputs it used to count as done
    with blank outputs, cut inside the key values as a point of another value (200.0 read as 20.0 or 2.0)."""
    path, full = _partial_of_a_finished_sweep(tmp_path)
    text = path.read_text()
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    keep = last.index(",", last.index(",") + 1) + 3 if cut == "in the outputs" else 2
    path.write_text(text[:len(text) - len(last) - 1] + last[:keep])
    rc, out, err = _cli_sweep(tmp_path, RESUMABLE, "--resume")
    assert rc == 0, err
    assert "4 points (3 taken from r.partial.csv), 0 failed" in out, out
    assert "1 torn or incomplete line(s) dropped" in err
    df = pd.read_csv(tmp_path / "r.csv", keep_default_na=False)
    pd.testing.assert_frame_equal(_without_wall(df), _without_wall(full), check_exact=True, check_dtype=False)


# every field of the sweep's identity (harness.studies.sweep_checks.identity) and a change of the spec that moves
# it; "system" (a file's SHA-256) and "version" (the toolkit's) change outside the spec, in the test below
IDENTITY_CHANGES = {
    "points": {"grid": {"b.c": [50.0, 200.0], "w": [1.0, 3.0]}},
    "set": {"set": {"a.w0": "w * 2.5"}},
    "outputs": {"outputs": {"w_end": 'final(r["a.flange.w"])'}},
    "stop_time": {"stop_time": 0.01},
    "step": {"step": 5e-4},
    "master": {"master": "gauss-seidel"},
    "extrapolation": {"extrapolation": 1},
    "system": None,
    "version": None,
}


def test_every_field_of_the_identity_has_a_refusal_case():
    from harness.studies.sweep_checks import identity

    assert set(identity("two_inertia", sweep.parse_spec(RESUMABLE))) == set(IDENTITY_CHANGES)


def _refused(tmp_path, path, field, before, rc, out, err):
    assert rc == 1 and out == ""
    line = err.strip()
    assert "\n" not in line and line.startswith("error: --resume: ") and f": {field} " in line, line
    assert "run without --resume" in line
    assert path.read_text() == before            # the kept points are not touched


@pytest.mark.parametrize("field", [f for f, change in IDENTITY_CHANGES.items() if change is not None])
def test_resume_refuses_a_partial_file_of_other_settings(tmp_path, field):
    path, _ = _partial_of_a_finished_sweep(tmp_path)
    before = path.read_text()
    _refused(tmp_path, path, field, before,
             *_cli_sweep(tmp_path, dict(RESUMABLE, **IDENTITY_CHANGES[field]), "--resume"))


def test_resume_refuses_another_toolkit_version_and_another_file_of_the_same_name(tmp_path, monkeypatch, fmu_dir):
    import zipfile

    from harness import load
    from harness.ssp import export_ssp
    from harness.studies import sweep_checks

    ssp = export_ssp(load("two_inertia").on_fmus(fmu_dir), tmp_path / "t.ssp")
    path, _ = _partial_of_a_finished_sweep(tmp_path, system=ssp)
    before = path.read_text()
    assert _cli_sweep(tmp_path, RESUMABLE, "--resume", system=ssp)[0] == 0         # the same: resumed
    path, _ = _partial_of_a_finished_sweep(tmp_path, system=ssp)
    before = path.read_text()
    with monkeypatch.context() as m:
        m.setattr(sweep_checks, "toolkit_version", lambda: "0.0.0+another")
        _refused(tmp_path, path, "version", before, *_cli_sweep(tmp_path, RESUMABLE, "--resume", system=ssp))
    with zipfile.ZipFile(ssp, "a") as z:         # the same archive but for its comment: other bytes
        z.comment = b"edited"
    _refused(tmp_path, path, "system", before, *_cli_sweep(tmp_path, RESUMABLE, "--resume", system=ssp))


def test_resume_of_a_finished_sweep_has_nothing_to_do(tmp_path):
    rc, out, _ = _cli_sweep(tmp_path, RESUMABLE)
    assert rc == 0 and (tmp_path / "r.sweep.json").is_file() and not (tmp_path / "r.partial.csv").exists()
    stamp = (tmp_path / "r.csv").stat().st_mtime_ns
    rc, out, err = _cli_sweep(tmp_path, RESUMABLE, "--resume")
    assert rc == 0 and "complete, nothing to do (4 points" in out, (out, err)
    assert (tmp_path / "r.csv").stat().st_mtime_ns == stamp
    rc, out, err = _cli_sweep(tmp_path, dict(RESUMABLE, stop_time=0.01), "--resume")
    assert rc == 1 and "r.sweep.json is of another sweep: stop_time 0.02 there, 0.01 now" in err, err


def test_a_point_is_logged_once(tmp_path):
    """dask may run a point twice (its worker lost after the point finished): the file keeps it once."""
    from harness.studies.sweep_checks import PointLog

    spec = sweep.parse_spec(RESUMABLE)
    log = PointLog(tmp_path / "p.csv", spec, resume=False)
    row = sweep.run_point("two_inertia", spec, spec.points[0])
    log.add(row)
    log.add(dict(row))
    assert len(log.rows) == 1 and len(tmp_path.joinpath("p.csv").read_text().splitlines()) == 2


@pytest.mark.parametrize("grid, expected", [
    ({"w": {"linspace": [1, 2, 0]}}, "grid.w: linspace: the count 0 gives no point"),
    ({"w": {"linspace": [1, 2, 2.7]}}, "grid.w: linspace: the count 2.7 is not a whole number"),
    ({"w": {"logspace": [1, 100, True]}}, "grid.w: logspace: the count True is not a whole number"),
    ({"w": [True, False]}, "grid.w: True is not a number"),
    ({"w": {"linspace": [1, False, 3]}}, "grid.w: False is not a number"),
    ({"w": [1.0, float("inf")]}, "grid.w: inf is not a finite number"),
    ({"w": {"logspace": [0, 10, 3]}}, "grid.w: logspace: lo and hi must be > 0"),
])
def test_grid_values_are_checked_at_load(tmp_path, grid, expected):
    path = write_yaml(tmp_path / "g.yaml", dict(RESUMABLE, grid=grid))
    with pytest.raises(sweep.SweepError) as e:
        sweep.read_spec(path)
    assert str(e.value).startswith(f"{path}: {expected}"), str(e.value)
    assert sweep.parse_spec(dict(RESUMABLE, grid={"w": {"linspace": [1, 2, 3.0]}})).points[-1] == {"w": 2.0}


def _server(reply: bytes | None):
    """A tiny TCP server on localhost that answers every connection with ``reply`` (None: says nothing)."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    held = []

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return srv, srv.getsockname()[1]


@pytest.mark.parametrize("reply, expected", [
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", "is no dask scheduler"),
    (None, "no dask scheduler greeted within 2 s"),
])
def test_a_wrong_service_at_the_scheduler_address_is_one_line(tmp_path, monkeypatch, reply, expected):
    import dask
    import time

    srv, port = _server(reply)
    try:
        with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
            t0 = time.perf_counter()
            rc, out, err = _cli_sweep(tmp_path, RESUMABLE, "--scheduler", f"127.0.0.1:{port}")
            took = time.perf_counter() - t0
    finally:
        srv.close()
    assert rc == 1 and out == "", out
    line = err.strip()
    assert "\n" not in line and line.startswith(f"error: --scheduler 127.0.0.1:{port}: ") and expected in line, err
    assert took < 30, took
    assert not list(tmp_path.glob("r.*"))      # nothing written for a sweep that could not start


@pytest.mark.slow
def test_an_ssp_sweep_on_a_scheduler_and_two_workers_that_share_no_folder_with_the_client(tmp_path, monkeypatch):
    """A scheduler and two workers started in empty folders of their own; the client, in a third, sweeps an
    exported drive (.ssp) by its relative name: the workers receive the file and give the serial results."""
    import os
    import subprocess
    import sys
    import time

    from harness.ssp import export_ssp
    from harness import load

    client_dir, sched_dir = tmp_path / "client", tmp_path / "scheduler"
    worker_dirs = [tmp_path / "worker1", tmp_path / "worker2"]
    for d in (client_dir, sched_dir, *worker_dirs):
        d.mkdir()
    export_ssp(load("two_inertia"), client_dir / "drive.ssp")
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    procs = [subprocess.Popen([*dask, "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
                               str(sched_file)], cwd=sched_dir, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        for _ in range(600):
            if sched_file.exists() and sched_file.read_text().strip().endswith("}"):
                break
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        for d in worker_dirs:
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "1", "--nthreads",
                 "1", "--no-dashboard", "--local-directory", str(d)], cwd=d, env=env,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from dask.distributed import Client

        with Client(address, timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        monkeypatch.chdir(client_dir)   # the system's path as a user types it, relative to the client's folder
        spec = sweep.parse_spec(RESUMABLE)
        dist = sweep.run_sweep("drive.ssp", spec, scheduler=address, progress=False)
        serial = sweep.run_sweep("drive.ssp", spec, workers=0, progress=False)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
    assert (dist["error"] == "").all(), dist["error"].tolist()
    assert serial["w_end"].nunique() == 4
    pd.testing.assert_frame_equal(_without_wall(serial), _without_wall(dist), check_exact=True)
    for d in worker_dirs:   # the workers wrote no system file into their own folders
        assert not list(d.rglob("drive.ssp"))


KILLER = '''\
"""two_inertia, whose first load inside a dask worker ends that worker's process (a lost worker)."""
import os
from pathlib import Path

from harness import load

try:
    from distributed import get_worker

    get_worker()
    in_worker = True
except (ImportError, ValueError):
    in_worker = False
marker = Path(os.environ["SWEEP_TEST_MARKER"])
if in_worker and not marker.exists():
    marker.write_text(str(os.getpid()))
    os._exit(1)
SYSTEM = load("two_inertia")
'''


@pytest.mark.slow
def test_a_lost_worker_s_point_is_run_again_and_written_once(tmp_path, monkeypatch):
    """The first point's worker dies inside it: dask runs the point again on a worker of the restarted pool; the
    result and the partial file hold every point once, as the serial run gives them."""
    from harness.studies.sweep_checks import PointLog, identity

    system = tmp_path / "killer.py"
    system.write_text(KILLER)
    marker = tmp_path / "killed"
    monkeypatch.setenv("SWEEP_TEST_MARKER", str(marker))
    spec = sweep.parse_spec(RESUMABLE)
    log = PointLog(tmp_path / "k.partial.csv", spec, resume=False, identity=identity(str(system), spec))
    dist = sweep.run_sweep(str(system), spec, workers=2, progress=False, log=log)
    assert marker.exists()                       # a worker was lost
    serial = sweep.run_sweep(str(system), spec, workers=0, progress=False)
    assert (dist["error"] == "").all(), dist["error"].tolist()
    pd.testing.assert_frame_equal(_without_wall(serial), _without_wall(dist[serial.columns]), check_exact=True,
                                  check_dtype=False)
    kept = pd.read_csv(log.path)
    assert len(kept) == 4 and not kept[spec.variables].duplicated().any()
