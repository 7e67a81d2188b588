"""System model validation, the FMU wrapper, results and the CLI: every bad input has a clear message."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from harness import load, simulate
from harness.errors import FMUError, SystemError_
from harness.fmi.fmu import FMU
from harness.model import Connection, Experiment, Instance, System, SystemWarning, bond
from harness.results import read_csv, to_csv

ROOT = Path(__file__).resolve().parents[1]


def system(fmu_dir, connections=(), bonds=None, **b_params):
    return System("t", [Instance("a", fmu_dir / "Inertia.fmu", {"J": 0.01, "w0": 1.0}),
                        Instance("b", fmu_dir / "SpringInertia.fmu", {"J": 0.02, **b_params}),
                        Instance("g", fmu_dir / "Gain.fmu")],
                  connections=list(connections),
                  bonds=[bond("a.flange", "b.drive")] if bonds is None else bonds,
                  experiment=Experiment(0.01, 1e-3))


@pytest.mark.parametrize("conn,message", [
    (Connection("x.flange.phi", "g.u"), "connection source x.flange.phi: unknown instance 'x'"),
    (Connection("a.flange.nope", "g.u"), "FMU Inertia of instance a has no variable 'flange.nope'"),
    (Connection("a.flange.phi", "b.drive.phi"), "input b.drive.phi is connected twice"),
    (Connection("g.u", "a.flange.tau"), "causality mismatch: source g.u is input"),
    (Connection("b.drive.tau", "g.y"), "causality mismatch: target g.y is output"),
    (Connection("a.flange.phi", "g.u"), "unit mismatch: a.flange.phi is in rad but g.u is in 1"),
    (Connection("g.y", "g.u", factor=float("nan")), "factor = nan must be a finite number"),
    (Connection("gu", "g.u"), "must be written 'Instance.variable'"),
])
def test_bad_connections_are_named(fmu_dir, conn, message):
    with pytest.raises(SystemError_) as info:
        simulate(system(fmu_dir, [conn]))
    assert message in str(info.value) and "\n" not in str(info.value)


def test_unit_conversion_must_be_declared_and_then_applies_factor_and_offset(fmu_dir):
    s = system(fmu_dir, [Connection("a.flange.phi", "g.u", factor=180 / np.pi, offset=1.0, unit_conversion=True)])
    df = simulate(s, outputs=["a.flange.phi", "g.u", "g.y"])
    np.testing.assert_allclose(df["g.u"], 180 / np.pi * df["a.flange.phi"] + 1.0, rtol=1e-12)
    np.testing.assert_allclose(df["g.y"], 0.5 * df["g.u"], rtol=1e-12)  # Gain default k = 0.5


def test_unconnected_input_is_a_warning_and_keeps_its_start_value(fmu_dir):
    with pytest.warns(SystemWarning, match="input g.u is not connected: it keeps its start value 0.0"):
        df = simulate(system(fmu_dir), outputs=["g.u", "g.y"])
    assert (df["g.u"] == 0.0).all()


@pytest.mark.parametrize("kwargs,message", [
    (dict(parameters={"a.nope": 1.0}), "parameter a.nope: FMU Inertia of instance a has no variable 'nope'"),
    (dict(parameters={"z.J": 1.0}), "parameter z.J: unknown instance 'z'"),
    (dict(parameters={"a.flange.w": 1.0}), "only parameters (and inputs) can be set"),
    (dict(parameters={"a.J": "heavy"}), "parameter a.J = 'heavy' must be a number"),
    (dict(master="newton-raphson"), "master = 'newton-raphson' is not admissible"),
    (dict(extrapolation=3), "extrapolation = 3 is not admissible"),
    (dict(step_control="pid"), "step_control = 'pid' is not admissible"),
    (dict(step=-1e-3), "step = -0.001 is not admissible"),
    (dict(stop_time=float("nan")), "stop_time = nan is not admissible"),
    (dict(step=1.0, stop_time=0.1), "longer than stop_time"),
    (dict(outputs=["a.nothing"]), "output 'a.nothing': FMU Inertia of instance a has no variable 'nothing'"),
    (dict(step_control="ecco", bonds=[]), "needs at least one power bond"),
])
def test_bad_run_arguments_are_named(fmu_dir, kwargs, message):
    bonds = kwargs.pop("bonds", None)
    with pytest.raises(SystemError_) as info:
        simulate(system(fmu_dir, bonds=bonds), **kwargs)
    assert message in str(info.value)


def _isolated(code: str) -> str:
    """Run code in a fresh interpreter: an exception inside a pythonfmu FMU corrupts reference counts of the
    process (pythonfmu 0.7 handle_py_exception), so FMU failures are provoked away from the test process."""
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_a_non_physical_parameter_stops_the_run_with_the_fmu_message(fmu_dir):
    out = _isolated(f"""
import warnings
from harness import simulate
from harness.model import Instance, System, bond
s = System("t", [Instance("a", r"{fmu_dir / 'Inertia.fmu'}", {{"w0": 1.0}}),
                 Instance("b", r"{fmu_dir / 'SpringInertia.fmu'}")], bonds=[bond("a.flange", "b.drive")])
with warnings.catch_warnings(record=True) as w:
    warnings.simplefilter("always")
    df = simulate(s, 0.01, 1e-3, parameters={{"a.J": -1.0}})
print(df.attrs["complete"], len(df), any("run stopped early" in str(x.message) for x in w))
print(df.attrs["error"])
""")
    first, err = out.splitlines()[:2]
    assert first == "False 0 True"
    assert err.startswith("system t: a (Inertia): parameter J = -1.0 kg.m2 is not admissible") and "fmi2" not in err


def test_fmu_wrapper_checks_status_and_names_instance_call_and_time(fmu_dir):
    # (a failing fmi2DoStep of a pythonfmu FMU is not exercised here: pythonfmu 0.7 corrupts reference
    # counts when a Python exception escapes do_step, which crashes a later garbage collection)
    f = FMU(fmu_dir / "Gain.fmu", "gx")
    try:
        f.setup(0.0)
        f.enter_initialization()
        f.exit_initialization()
        u, y = f.reals(["u"]), f.reals(["y", "integral"])
        f.set(u, [2.0])
        f.do_step(0.0, 0.5)
        np.testing.assert_allclose(f.get(y), [0.5 * 2.0, 1.0])
        state = f.get_state()
        f.do_step(0.5, 0.25)
        after = f.get(y).copy()
        f.set_state(state)
        f.do_step(0.5, 0.25)
        np.testing.assert_array_equal(f.get(y), after)
        with pytest.raises(FMUError, match="has no variable 'nope'"):
            f.reals(["nope"])
    finally:
        f.free()
    text = _isolated(f"""
from harness.fmi.fmu import FMU
g = FMU(r"{fmu_dir / 'Gain.fmu'}", "gbad")
g.setup(0.25)
g.set_value("limit", -2.0)
try:
    g.enter_initialization()
except Exception as e:
    print(e)
""").strip()
    assert text.startswith("instance gbad: fmi2EnterInitializationMode failed at t = 0.25 s with status fatal")
    assert "parameter limit = -2.0" in text and len(text.splitlines()) == 1


def test_result_frame_and_csv(fmu_dir, tmp_path):
    df = simulate(system(fmu_dir, [Connection("b.drive.tau", "g.u", unit_conversion=True)]),
                  outputs=["a.flange.w", "b.w", "g.u"])
    assert df.index.name == "time" and list(df.columns) == ["a.flange.w", "b.w", "g.u"]
    np.testing.assert_array_equal(df.index.values, np.arange(11) / 1000)  # from an integer ns clock
    assert df.attrs["complete"] is True and df.attrs["master"] == "jacobi"
    out = to_csv(df, tmp_path / "r.csv")
    assert out.read_text().splitlines()[0] == "time,a.flange.w,b.w,g.u"
    back = read_csv(out)
    np.testing.assert_allclose(back.values, df.values, rtol=1e-15)
    full = simulate(system(fmu_dir, [Connection("b.drive.tau", "g.u", unit_conversion=True)]))
    assert set(full.columns) == {"a.flange.phi", "a.flange.w", "b.drive.tau", "g.y", "g.integral"}


def test_load_module_and_errors():
    s = load("two_inertia")
    assert s.name == "two_inertia" and load(s) is s
    with pytest.raises(SystemError_, match="unknown system 'no_such_system'"):
        load("no_such_system")


def _cli(args, fmu_dir):
    env = dict(os.environ, PRESSDRIVE_FMU_DIR=str(fmu_dir), PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "harness", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=120)


def test_cli_run_writes_csv(fmu_dir, tmp_path):
    out = tmp_path / "ti.csv"
    r = _cli(["run", "two_inertia", "--stop-time", "0.05", "--step", "1e-3", "--master", "gauss-seidel",
              "--extrapolation", "1", "--set", "a.w0=2.0", "--out", str(out)], fmu_dir)
    assert r.returncode == 0, r.stderr
    df = pd.read_csv(out)
    assert df.columns[0] == "time" and len(df) == 51 and df["a.flange.w"].iloc[0] == 2.0


def test_cli_failure_is_one_line_without_traceback(fmu_dir, tmp_path):
    r = _cli(["run", "two_inertia", "--stop-time", "0.01", "--set", "a.J=-1"], fmu_dir)
    assert r.returncode != 0
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and "Warning" not in ln and "warn" not in ln]
    assert "Traceback" not in r.stderr and any("parameter J = -1" in ln for ln in lines)
    r = _cli(["run", "two_inertia", "--master", "bogus"], fmu_dir)
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith("error: master = 'bogus'")


@pytest.mark.parametrize("part", ["slave_core.py", "slave.py", "units.py", "physics/contact.py", "build.py"])
def test_an_fmu_is_stale_when_any_part_it_packs_changed(tmp_path, part):
    """A change to the shared slave core (split out for FMI 3.0) left build/fmus stale and old code ran
    silently: every part of fmus.build.RUNTIME counts, as the declaration does."""
    import os

    from harness.model import ROOT, _sources_newer_than

    fmu = tmp_path / "X.fmu"
    fmu.write_bytes(b"")
    script = ROOT / "fmus" / "components" / "pd_inertia.py"
    newest = max(p.stat().st_mtime for p in (ROOT / "fmus").rglob("*") if p.suffix in (".py", ".c"))
    os.utime(fmu, (newest + 10, newest + 10))
    assert not _sources_newer_than(fmu, script)
    src = ROOT / "fmus" / part
    old = src.stat().st_mtime
    try:
        os.utime(src, (newest + 20, newest + 20))
        assert _sources_newer_than(fmu, script)
    finally:
        os.utime(src, (old, old))
