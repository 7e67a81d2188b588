"""Issue 30, the command line's part: what a press engineer meets on the first day.  Output paths and formats
are checked before a run (nothing computed is lost), SIGTERM keeps the finished part as Ctrl-C does, an
incomplete run never replaces a complete result, a system is found by the names a newcomer tries, `list` and
`show` say what there is, a diverged run says what to change, help texts are whole, synth errors are one
`error:` line in the user's words, and simulate() speaks FMPy's names."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from childproc import wait_for_cpu

from harness import simulate
from harness.results import parquet_engine

ROOT = Path(__file__).resolve().parents[1]


def cli(*args, cwd=ROOT, timeout=120):
    r = subprocess.run([sys.executable, "-m", "harness", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


def one_error(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in stderr, stderr
    return lines[0]


# a run far longer than the test waits: if it were started before the check, the subprocess would time out
LONG = ("run", "bed_drive", "--stop-time", "300")


# -- 1. output places checked before the run -----------------------------------------------------------------
@pytest.mark.parametrize("option, target", [("--out", "blocker/x.csv"), ("--plot", "blocker/charts"),
                                            ("--out", "folder")])
def test_an_output_place_that_cannot_be_written_is_refused_before_the_run(tmp_path, option, target):
    (tmp_path / "blocker").write_text("a file where a folder is needed")
    (tmp_path / "folder").mkdir()
    rc, out, err = cli(*LONG, option, tmp_path / target, timeout=60)
    line = one_error(err)
    assert rc == 1 and out == ""
    assert f"{option} {tmp_path / target}" in line, line


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_folder_is_refused_before_the_run(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    rc, _, err = cli(*LONG, "--out", ro / "x.csv", timeout=60)
    assert rc == 1 and "is not writable" in one_error(err)


# -- 2. result formats ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["x.txt", "x", "x.parquet"])
def test_an_unwritable_format_is_refused_before_the_run_naming_the_allowed_suffixes(tmp_path, name):
    if name == "x.parquet" and parquet_engine():
        pytest.skip("a Parquet engine is installed: .parquet is written")
    rc, out, err = cli(*LONG, "--out", tmp_path / name, timeout=60)
    line = one_error(err)
    assert rc == 1 and out == "" and ".csv" in line and str(tmp_path / name) in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(parquet_engine() is None, reason="neither pyarrow nor fastparquet is installed")
def test_parquet_is_real_parquet(tmp_path):
    out = tmp_path / "x.parquet"
    rc, _, err = cli("run", "two_inertia", "--stop-time", "0.01", "--out", out)
    assert rc == 0, err
    assert out.read_bytes()[:4] == b"PAR1"
    df = pd.read_parquet(out)
    assert len(df) == 11 and "a.flange.w" in df.columns


def test_parquet_gets_the_plain_attrs_and_appears_whole(tmp_path, monkeypatch):
    """Without an engine here, the Parquet branch is driven with a stand-in writer: it must receive only
    attrs a Parquet file can keep (JSON: the bond log is left out), and the file appears under its name only
    once written."""
    import json

    from harness import results

    seen = {}

    def fake_to_parquet(self, path, engine=None):
        seen["attrs"] = json.loads(json.dumps(self.attrs))     # what pandas does with attrs in Parquet
        seen["path"], seen["engine"] = Path(path), engine
        Path(path).write_bytes(b"PAR1")

    monkeypatch.setattr(results, "parquet_engine", lambda: "pyarrow")
    monkeypatch.setattr(pd.DataFrame, "to_parquet", fake_to_parquet)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = simulate("two_inertia", stop_time=0.01, step=1e-3)
    out = results.write_result(df, tmp_path / "x.parquet")
    assert out.read_bytes() == b"PAR1" and [p.name for p in tmp_path.iterdir()] == ["x.parquet"]
    assert seen["engine"] == "pyarrow" and seen["path"] != out
    assert seen["attrs"]["units"]["a.flange.w"] == "rad/s" and seen["attrs"]["complete"] is True
    assert "bonds" not in seen["attrs"]


# -- 3. SIGTERM keeps the finished part ----------------------------------------------------------------------
def test_sigterm_keeps_the_finished_part_marked_as_ctrl_c_does(tmp_path):
    out = tmp_path / "bed.csv"
    p = subprocess.Popen([sys.executable, "-m", "harness", "run", "bed_drive", "--stop-time", "60", "--out",
                          str(out)], cwd=ROOT, env=dict(os.environ, PYTHONUNBUFFERED="1"), text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    wait_for_cpu(p, 6.0)          # the loading takes about 3 s of CPU: stepping by then
    p.send_signal(signal.SIGTERM)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 143, (p.returncode, stdout, stderr)
    assert not out.exists()
    partial = tmp_path / "bed.partial.csv"
    df = pd.read_csv(partial, index_col="time")
    assert len(df) > 10 and 0 < df.index[-1] < 60
    line = one_error(stderr)
    assert "terminated (SIGTERM)" in line and str(partial) in line and "INCOMPLETE" in line


# -- 4. an incomplete run never replaces a complete result ---------------------------------------------------
def test_a_diverged_run_keeps_the_complete_chart_and_csv_of_an_earlier_run(tmp_path):
    charts, out = tmp_path / "charts", tmp_path / "bed.csv"
    rc, _, err = cli("run", "bed_drive", "--stop-time", "0.1", "--out", out, "--plot", charts)
    assert rc == 0, err
    before = {p.name: p.read_bytes() for p in charts.iterdir()}
    csv_before = out.read_bytes()
    assert "bed.png" in before                      # the charts are named after --out
    rc, _, err = cli("run", "bed_drive", "--master", "jacobi-sampled", "--stop-time", "0.5", "--out", out,
                     "--plot", charts)
    line = one_error(err)
    assert rc == 1 and "diverged" in line
    for name, data in before.items():
        assert (charts / name).read_bytes() == data, name
    assert out.read_bytes() == csv_before
    assert (charts / "bed.partial.png").exists() and (tmp_path / "bed.partial.csv").exists()
    assert "bed.partial.png" in line


# -- 5. systems by the names a newcomer tries ----------------------------------------------------------------
@pytest.mark.parametrize("given", ["systems/bed_drive.py", "bed_drive.py"])
def test_a_shipped_system_by_its_file_name(given):
    rc, out, err = cli("run", given, "--stop-time", "0.01")
    assert rc == 0 and out.startswith("bed_drive: 21 points"), err


def test_any_python_file_defining_system(tmp_path):
    own = tmp_path / "my_pair.py"
    own.write_text((ROOT / "systems" / "two_inertia.py").read_text().replace('name="two_inertia"', 'name="my_pair"'))
    rc, out, err = cli("run", own, "--stop-time", "0.01", cwd=tmp_path)
    assert rc == 0 and out.startswith("my_pair: 11 points"), err


@pytest.mark.parametrize("given, expected", [
    ("g.txt", "system 'g.txt' is neither a system name nor a .py, .ssp, .ssd or OspSystemStructure.xml file"),
    ("bed_drvie", "unknown system 'bed_drvie' (did you mean 'bed_drive'?)"),
    ("nothing_here.py", "system file 'nothing_here.py' does not exist"),
])
def test_anything_else_is_one_line_listing_the_known_systems(given, expected):
    rc, out, err = cli("run", given)
    line = one_error(err)
    assert rc == 1 and out == "" and expected in line, line
    from harness.run import system_names

    assert "known systems: " + ", ".join(system_names()) in line
    assert "ModuleNotFound" not in line


# -- 6. list and show ----------------------------------------------------------------------------------------
def test_list_names_every_system_with_its_description():
    from harness.run import load, system_names

    rc, out, _ = cli("list")
    lines = out.strip().splitlines()
    assert rc == 0 and len(lines) == len(system_names())
    for name, line in zip(system_names(), lines):
        assert line.split()[0] == name and load(name).description[:40] in line


def test_show_lists_instances_bonds_scenes_and_variables_with_units():
    rc, out, err = cli("show", "two_inertia")
    assert rc == 0, err
    for text in ("a  Inertia", "b  SpringInertia", "a.flange->b.drive", "peak_torque", "[default]",
                 "drive.tau [N.m]", "J = 0.02 kg.m2", "c = 100 N.m/rad", "default run: stop time 1 s, step 0.001 s"):
        assert text in out, (text, out)
    assert max(len(ln) for ln in out.splitlines()) <= 110
    rc, out, _ = cli("show", "two_inertia", "b")
    assert rc == 0 and "SpringInertia" in out and "flange.w" not in out
    rc, _, err = cli("show", "two_inertia", "c")
    assert rc == 1 and "unknown instance 'c' (instances: a, b)" in one_error(err)


# -- 7. a diverged run says what to change -------------------------------------------------------------------
TEXTBOOK = ("--master", "jacobi", "--extrapolation", "0")   # undamped two_inertia diverges under it at any step


@pytest.mark.parametrize("step", ["0.002", "0.001"])
def test_a_diverged_run_ends_with_a_hint_from_its_own_step_and_master(step):
    rc, _, err = cli("run", "two_inertia", "--step", step, *TEXTBOOK)
    line = one_error(err)
    assert rc == 1 and "diverged" in line
    assert line.endswith(f"; reduce the step (now {float(step):g} s) or use --master jacobian"), line
    rc, _, err = cli("run", "two_inertia", "--step", "0.002", "--master", "gauss-seidel", "--extrapolation", "0",
                     "--stop-time", "40")
    line = one_error(err)
    assert rc == 1 and "diverged" in line and line.endswith("(now 0.002 s) or use --master jacobian"), line
    # and the hint is right: the same run under the interface-Jacobian master completes
    rc, _, err = cli("run", "two_inertia", "--step", "0.002", "--master", "jacobian", "--stop-time", "40")
    assert rc == 0, err


def test_a_run_stopped_by_the_blow_up_check_gets_the_hint_too():
    """Blow-ups faster than the divergence detector's first verdict are stopped by the master's blow-up check
    (issue 30: those got no hint).  Quadratic extrapolation at 1 ms blows the bed drive up within 31 steps (measured
    on the seed's branch -1 drive; jacobi at 2 ms with its linear extrapolation is now stopped by the detector)."""
    rc, _, err = cli("run", "bed_drive", "--step", "0.001", "--master", "jacobi", "--extrapolation", "2",
                     "--stop-time", "0.2")
    line = one_error(err)
    assert rc == 1 and "exceeds the blow-up limit" in line, line
    assert line.endswith("; reduce the step (now 0.001 s) or use --master jacobian"), line


# -- 8. help ---------------------------------------------------------------------------------------------------
def test_help_texts_are_whole_and_say_the_real_default():
    _, out, _ = cli("synth", "carrier", "--help")
    assert "the disc-cam geometry for the seed's maximum pressure angle" in " ".join(out.split())
    for tool in ("fourbar", "groove"):
        _, out, _ = cli("synth", tool, "--help")
        assert "(default: none)" not in " ".join(out.split()), tool
    _, out, _ = cli("sweep", "--help")
    assert "(required, no default)" in " ".join(out.split())
    _, out, _ = cli("export", "--help")
    assert "Write a system as an SSP 1.0 archive" in out


def test_debug_anywhere_and_version_from_the_package_metadata():
    from importlib import metadata

    rc, out, err = cli("run", "two_inertia", "--stop-time", "0.01", "--debug")
    assert rc == 0 and "11 points" in out, err
    rc, out, _ = cli("--version")
    assert rc == 0 and out.split()[-1] == metadata.version("pressdrive")


# -- 9. synth errors -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, expected, hidden", [
    (("carrier", "--zone", "0.3", "0.1", "--no-cam"), "--zone 0.3 0.1 m: the printing zone must lie inside", "1.011"),
    (("carrier", "--stroke", "-1", "--no-cam"), "--stroke -1 m must be > 0", "-0.08"),
    (("fourbar", "--swing", "200", "--min-transmission", "30"), "--swing 200: must be in (0, 180) deg", "200.0"),
    (("fourbar", "--analyse", "--coupler", "0.1", "--frame", "5", "--rocker", "1"),
     "--coupler 0.1 --frame 5 --rocker 1 (crank = 1)", "parameter crank"),
    (("knife", "--T-cut", "-1"), "--T-cut -1 s must be > 0", "T_cut ="),
    (("groove", "--crank-radius", "-1", "--lambda2", "4"), "--crank-radius -1 m must be > 0", "-1.0"),
    (("sectors", "--D-Ci", "-5"), "--D-Ci -5", "D_Ci ="),
])
def test_synth_errors_are_one_error_line_in_the_users_words(args, expected, hidden):
    rc, _, err = cli("synth", *args)
    line = one_error(err)
    assert rc == 2 and line.startswith(f"error: synth {args[0]}: ") and expected in line, line
    assert hidden not in line, line


# -- 10. simulate() with FMPy's names --------------------------------------------------------------------------
def test_simulate_takes_start_values_and_output():
    df = simulate("two_inertia", stop_time=0.01, step=1e-3, start_values={"a.w0": 2.0}, output=["a.flange.w"])
    assert list(df.columns) == ["a.flange.w"] and df["a.flange.w"].iloc[0] == 2.0
    with pytest.warns(DeprecationWarning, match="parameters= is now start_values="):
        old = simulate("two_inertia", stop_time=0.01, step=1e-3, parameters={"a.w0": 2.0}, outputs=["a.flange.w"])
    assert old.equals(df)
    assert simulate("two_inertia", stop_time=0.01, step_size=1e-3, start_values={"a.w0": 2.0},
                    output=["a.flange.w"]).equals(df)  # FMPy's name of the step (tests/test_fmpy_names.py)


def test_start_time_shifts_the_run_of_an_autonomous_system():
    h = 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = simulate("two_inertia", stop_time=0.05, step=h)
        late = simulate("two_inertia", start_time=0.02, stop_time=0.07, step=h)
    assert late.index[0] == pytest.approx(0.02) and late.index[-1] == pytest.approx(0.07) and len(late) == 51
    assert late.attrs["start_time"] == 0.02 and late.attrs["complete"]
    np.testing.assert_allclose(late.to_numpy(), base.to_numpy(), rtol=1e-9, atol=1e-12)
    with pytest.raises(Exception, match=r"start_time = 0.1 is not admissible"):
        simulate("two_inertia", start_time=0.1, stop_time=0.05, step=h)
