"""Isolation of foreign FMUs (harness.fmi.isolated): an FMU that crashes or hangs inside a call stops the run
in one line, the rows computed so far kept.

The broken FMUs are tests/c_fmu/oscillator.c built with ``-DFAIL_AT=0.5 -DFAIL_HOW=n`` (test_c_fmu's build
machinery): from the doStep at t = 0.5 s on, n = 1 writes through a null pointer (SIGSEGV), 2 calls abort()
(SIGABRT), 3 loops forever.  Checked: the run (Python and command line) ends with one line naming the instance,
the FMI call, the time and how the process ended; every row up to t = 0.5 s is kept and equals the healthy
FMU's; an isolated healthy run is bit-identical to the same run in one process (fixed step and the iterative
master's rollback through the child's FMU states); a sweep point whose FMU crashes is recorded as failed and the
sweep goes on; bad isolation settings are one line before the run.
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from test_c_fmu import HERE, _c_build, _pack  # noqa: F401 (_c_build: the session fixture of the compiler)

ROOT = Path(__file__).resolve().parents[1]
FAIL_AT = 0.5
STEP = 0.01
# the isolation's timeout per FMI call: a healthy call of the C oscillator is a pipe round trip and a few
# multiplications, so 60 s (harness.fmi.isolated.DEFAULT_TIMEOUT) never kills one on a loaded machine; only the
# hanging FMU waits its timeout out, and 10 s keeps that case short while still leaving the healthy calls before
# it (1 s failed them under load: issue 57) ten times the margin they had
TIMEOUT = {"segv": 60.0, "abort": 60.0, "hang": 10.0}
HOW = {"segv": (1, r"died \(SIGSEGV, segmentation fault\)"), "abort": (2, r"died \(SIGABRT, abort\)"),
       "hang": (3, r"did not answer within 10 s \(it hangs: its isolated process was killed")}


def _broken_md(identifier: str) -> str:
    text = (HERE / "modelDescription.xml").read_text()
    assert text.count('modelIdentifier="oscillator"') == 1
    return text.replace('modelIdentifier="oscillator"', f'modelIdentifier="{identifier}"')


@pytest.fixture(scope="session")
def broken(_c_build) -> dict:  # noqa: F811
    """{how: path of the oscillator that fails that way in doStep at t >= 0.5 s}, plus "healthy"."""
    out = {how: _pack(_c_build, f"osc_{how}", _broken_md(f"osc_{how}"), [f"FAIL_AT={FAIL_AT}", f"FAIL_HOW={n}"])
           for how, (n, _) in HOW.items()}
    out["segv_if_x0_positive"] = _pack(_c_build, "osc_segv_x0", _broken_md("osc_segv_x0"),
                                       [f"FAIL_AT={FAIL_AT}", "FAIL_HOW=1", "FAIL_ONLY_IF_X0_POSITIVE"])
    out["healthy"] = _pack(_c_build, "osc_healthy", _broken_md("osc_healthy"))
    return out


def _system(fmu: Path, n: int = 1):
    from harness.model import Connection, Instance, System

    insts = [Instance(f"osc{i}" if n > 1 else "osc", fmu=str(fmu)) for i in range(n)]
    conns = [Connection("osc0.x", "osc1.F", factor=-20.0, unit_conversion=True),
             Connection("osc1.x", "osc0.F", factor=-20.0, unit_conversion=True)] if n > 1 else []
    return System("isolation_test", insts, conns)


def _run(system, **kw):
    from harness import simulate
    from harness.model import SystemWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)
        warnings.simplefilter("ignore", UserWarning)
        return simulate(system, **kw)


@pytest.mark.parametrize("how", list(HOW))
def test_crash_or_hang_is_one_line_and_keeps_the_rows(broken, how):
    from harness.fmi.isolated import Isolation

    healthy = _run(_system(broken["healthy"]), stop_time=1.0, step=STEP)
    df = _run(_system(broken[how]), stop_time=1.0, step=STEP, isolate=Isolation("foreign", timeout=TIMEOUT[how]))
    a = df.attrs
    assert a["complete"] is False
    assert "\n" not in a["error"]
    assert a["error"].startswith(f"instance osc: fmi2DoStep(h = {STEP:g} s) failed at t = {FAIL_AT:g} s: "
                                 f"the FMU"), a["error"]
    import re

    assert re.search(HOW[how][1], a["error"]), a["error"]
    # every communication point before the failing step is kept, and is the healthy FMU's
    assert len(df) == round(FAIL_AT / STEP) + 1
    assert df.index[-1] == pytest.approx(FAIL_AT)
    pd.testing.assert_frame_equal(df, healthy.iloc[:len(df)], check_exact=True)


def test_each_instance_of_one_fmu_has_its_own_process_and_the_crash_names_its_instance(broken):
    """Two instances of one foreign FMU, coupled; only osc1 (x0 > 0) segfaults at t = 0.5 s: each runs in a
    process of its own, the error names osc1 (not osc0, which is stepped first), the rows before are kept."""
    from harness.fmi import open_instance
    from harness.fmi.isolated import Isolation
    from harness.model import Connection, Instance, System

    fmu = broken["segv_if_x0_positive"]
    a, b = open_instance(fmu, "osc0", isolate=True), open_instance(fmu, "osc1", isolate=True)
    try:
        assert a._proc.pid != b._proc.pid
    finally:
        a.free(), b.free()
    system = System("two_of_one", [Instance("osc0", str(fmu), {"x0": -0.1}), Instance("osc1", str(fmu), {"x0": 0.1})],
                    [Connection("osc0.x", "osc1.F", factor=-20.0, unit_conversion=True),
                     Connection("osc1.x", "osc0.F", factor=-20.0, unit_conversion=True)])
    df = _run(system, stop_time=1.0, step=STEP, isolate=Isolation("foreign", timeout=TIMEOUT["segv"]))
    assert df.attrs["complete"] is False
    assert df.attrs["error"].startswith(f"instance osc1: fmi2DoStep(h = {STEP:g} s) failed at t = {FAIL_AT:g} s: "
                                        f"the FMU's isolated process died (SIGSEGV"), df.attrs["error"]
    assert len(df) == round(FAIL_AT / STEP) + 1


def test_simulate_raise_names_instance_and_time(broken):
    from harness import simulate
    from harness.errors import SimulationError

    with pytest.raises(SimulationError) as e, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(_system(broken["segv"]), stop_time=1.0, step=STEP, isolate=True, on_error="raise")
    assert e.value.instance == "osc" and e.value.time == pytest.approx(FAIL_AT)
    assert len(e.value.partial) == round(FAIL_AT / STEP) + 1


def test_cli_crash_writes_the_partial_result(broken, tmp_path):
    out = tmp_path / "r.csv"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "harness", "run", str(broken["abort"]), "--stop-time", "1",
                           "--step", str(STEP), "--isolate", "--out", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert proc.returncode == 1, proc.stderr
    err = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(err) == 1, proc.stderr
    assert err[0].startswith(f"error: instance Oscillator: fmi2DoStep(h = {STEP:g} s) failed at t = 0.5 s: the "
                             f"FMU's isolated process died (SIGABRT, abort)"), err[0]
    kept = pd.read_csv(tmp_path / "r.partial.csv")
    assert len(kept) == round(FAIL_AT / STEP) + 1 and not out.exists()


def test_without_isolation_the_crash_takes_the_process(broken, tmp_path):
    """What isolation prevents: the same run in one process dies with SIGSEGV, nothing written."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "harness", "run", str(broken["segv"]), "--stop-time", "1",
                           "--step", str(STEP), "--out", str(tmp_path / "r.csv")],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert proc.returncode < 0 or proc.returncode > 128, (proc.returncode, proc.stderr)
    assert not list(tmp_path.glob("*.csv"))


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel", "iterative"])
def test_isolated_run_is_bit_identical(broken, master):
    system = _system(broken["healthy"], n=2)
    plain = _run(system, stop_time=0.3, step=1e-3, master=master)
    alone = _run(system, stop_time=0.3, step=1e-3, master=master, isolate="all")
    assert plain.attrs["complete"] and alone.attrs["complete"]
    pd.testing.assert_frame_equal(plain, alone, check_exact=True)
    assert plain.attrs["iterations"] == alone.attrs["iterations"]


def test_toolkit_fmus_stay_in_process_under_foreign(broken):
    from harness.fmi import open_instance
    from harness.fmi.isolated import IsolatedInstance
    from harness.model import resolve_fmu

    mine = open_instance(resolve_fmu("Gain"), "fw", isolate=True)
    theirs = open_instance(broken["healthy"], "osc", isolate=True)
    try:
        assert not isinstance(mine, IsolatedInstance)
        assert isinstance(theirs, IsolatedInstance) and theirs.path_kind == "isolated fmi"
        assert isinstance(open_instance(resolve_fmu("Gain"), "fw2", isolate="all"), IsolatedInstance)
    finally:
        theirs.free()


def test_a_sweep_point_whose_fmu_crashes_is_recorded(broken):
    """A worker runs foreign FMUs isolated by default: the crashing point is a row with its error, the next
    point runs."""
    from harness.studies.sweep import parse_spec, run_sweep

    spec = parse_spec({"stop_time": 1.0, "step": STEP, "grid": {"Oscillator.x0": [0.1, 0.2]},
                       "outputs": {"x_end": 'final(r["Oscillator.x"])'}}, "crash.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = run_sweep(str(broken["segv"]), spec, workers=0, progress=False)
    assert len(table) == 2
    assert table["error"].str.contains(r"instance Oscillator: fmi2DoStep\(h = 0.01 s\) failed at t = 0.5 s").all(), \
        table["error"].tolist()
    assert table["x_end"].isna().all()


@pytest.mark.parametrize("value, words", [("some", "isolate = 'some' is not admissible"),
                                          (-1.0, "isolation timeout = -1.0 s is not admissible"),
                                          ([1], "isolate = [1] is not admissible")])
def test_bad_isolation_is_one_line(broken, value, words):
    from harness.errors import SystemError_

    with pytest.raises(SystemError_, match=r"^" + words.replace("(", r"\(").replace("[", r"\[")):
        _run(_system(broken["healthy"]), stop_time=0.1, step=STEP, isolate=value)


def test_isolation_timeout_needs_isolate(broken, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "harness", "run", str(broken["healthy"]), "--stop-time", "0.1",
                           "--step", str(STEP), "--isolate-timeout", "5"],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert proc.returncode != 0 and "--isolate-timeout 5 needs --isolate" in proc.stderr, proc.stderr
