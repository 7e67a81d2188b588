"""The master runs ANY FMI 2.0 co-simulation FMU, not only the toolkit's pythonfmu FMUs.

tests/c_fmu/oscillator.c is a hand-written C FMU (damped mass-spring oscillator, m x'' = F - k x - d x',
input F [N], outputs x [m], v [m/s]); the session fixture compiles it with gcc against the FMI 2.0 headers
that fmpy ships and zips it with tests/c_fmu/modelDescription.xml into an .fmu (skipped if gcc is missing or
the compilation fails).  Checked here:

* fmpy's validation of the FMU reports no problems;
* a single instance through harness.simulate agrees with fmpy.simulate_fmu to 1e-12 on the same grid, and
  both agree with the closed-form solution (independent reference);
* two instances coupled in a ring (x of one -> F of the other, factor -k_c) run with jacobi, gauss-seidel and
  iterative; every result is compared with the exact solution of the coupled linear system (matrix
  exponential) and the iterative result with a jacobi run at a 10x smaller step;
* the iterative master rolls the C FMU back with fmi2GetFMUstate/fmi2SetFMUstate, bit-exactly.
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent / "c_fmu"
GUID = "{6f1c3a52-9d0e-4b7a-8c21-0b5e3f7d9a41}"
DEFAULTS = dict(m=1.0, k=100.0, d=0.5, x0=0.1, v0=0.0, F=1.0)  # start values in modelDescription.xml


@pytest.fixture(scope="session")
def c_fmu(tmp_path_factory) -> Path:
    """tests/c_fmu compiled and packed as oscillator.fmu in a temporary folder."""
    import fmpy

    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("gcc not found: cannot compile the C test FMU")
    headers = Path(os.path.dirname(fmpy.__file__)) / "c-code"
    if not (headers / "fmi2Functions.h").is_file():
        pytest.skip(f"fmpy ships no FMI 2.0 headers at {headers}")
    out = tmp_path_factory.mktemp("c_fmu")
    binary = out / "binaries" / "linux64" / "oscillator.so"
    binary.parent.mkdir(parents=True)
    cmd = [gcc, "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", f"-I{headers}", str(HERE / "oscillator.c"),
           "-o", str(binary), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"compiling oscillator.c failed: {proc.stderr.strip().splitlines()[:1]}")
    (out / "compiler_warnings.txt").write_text(proc.stderr)
    fmu = out / "oscillator.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(HERE / "modelDescription.xml", "modelDescription.xml")
        z.write(binary, "binaries/linux64/oscillator.so")
        z.write(HERE / "oscillator.c", "sources/oscillator.c")
    return fmu


def _system(instances, connections=(), name="c_fmu_test"):
    from harness.model import System

    return System(name, list(instances), list(connections))


def _simulate(system, **kw):
    from harness import simulate
    from harness.model import SystemWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SystemWarning)
        return simulate(system, on_error="raise", **kw)


def closed_form(t, m, k, d, x0, v0, F):
    """x(t), v(t) of m x'' + d x' + k x = F (underdamped), written out independently of the FMU."""
    xe = F / k
    a = d / (2.0 * m)
    wd = math.sqrt(k / m - a * a)
    c1 = x0 - xe
    c2 = (v0 + a * c1) / wd
    e = np.exp(-a * t)
    x = xe + e * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t))
    v = e * (-a * (c1 * np.cos(wd * t) + c2 * np.sin(wd * t)) + (-c1 * wd * np.sin(wd * t) + c2 * wd * np.cos(wd * t)))
    return x, v


# -- the FMU itself --------------------------------------------------------------------------------------------
def test_compiles_without_warnings(c_fmu):
    text = (c_fmu.parent / "compiler_warnings.txt").read_text()
    assert text.strip() == "", text


def test_fmpy_validate_reports_no_problems(c_fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(c_fmu)) == []
    md = read_model_description(str(c_fmu))
    assert md.guid == GUID
    assert md.coSimulation.canGetAndSetFMUstate
    assert {u.variable.name: u.dependencies for u in md.outputs} == {"x": [], "v": []}


def test_bad_parameter_is_a_clear_harness_error(c_fmu):
    from harness.errors import SimulationError
    from harness.model import Instance

    system = _system([Instance("osc", fmu=str(c_fmu))])
    with pytest.raises(SimulationError) as e:
        _simulate(system, stop_time=0.01, step=1e-3, parameters={"osc.m": -2.0})
    msg = str(e.value)
    assert "osc" in msg and "parameter m = -2 is not admissible: must be > 0" in msg, msg


# -- single FMU: harness vs fmpy.simulate_fmu vs closed form -----------------------------------------------------
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel", "iterative"])
def test_single_fmu_matches_fmpy_simulate_fmu(c_fmu, master):
    from fmpy import simulate_fmu
    from harness.model import Experiment, Instance, System, SystemWarning

    stop, step = 1.0, 1e-3
    system = System("single", [Instance("osc", fmu=str(c_fmu))], experiment=Experiment(stop, step, master=master))
    from harness import simulate

    with pytest.warns(SystemWarning, match=r"input osc\.F is not connected: it keeps its start value 1\.0"):
        df = simulate(system, on_error="raise")
    assert df.attrs["complete"] and len(df) == round(stop / step) + 1
    ref = simulate_fmu(str(c_fmu), stop_time=stop, output_interval=step, fmi_type="CoSimulation")
    assert len(ref) == len(df)
    np.testing.assert_allclose(df.index.to_numpy(), ref["time"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["osc.x"].to_numpy(), ref["x"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["osc.v"].to_numpy(), ref["v"], rtol=0, atol=1e-12)
    # and both are the solution of the ODE (RK4 with h_max = 1e-4: error ~ 1e-11 here)
    x, v = closed_form(ref["time"], **DEFAULTS)
    np.testing.assert_allclose(ref["x"], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ref["v"], v, rtol=0, atol=1e-8)


def test_single_fmu_parameters_reach_the_c_fmu(c_fmu):
    from fmpy import simulate_fmu
    from harness.model import Instance

    p = dict(m=2.0, k=50.0, d=1.0, x0=-0.05, v0=0.3)
    system = _system([Instance("osc", fmu=str(c_fmu), parameters={"m": p["m"], "k": p["k"]})])
    df = _simulate(system, stop_time=0.5, step=2e-3, parameters={"osc.d": p["d"], "osc.x0": p["x0"],
                                                                 "osc.v0": p["v0"]})
    ref = simulate_fmu(str(c_fmu), stop_time=0.5, output_interval=2e-3, fmi_type="CoSimulation", start_values=p)
    np.testing.assert_allclose(df["osc.x"].to_numpy(), ref["x"], rtol=0, atol=1e-12)
    x, _v = closed_form(df.index.to_numpy(), F=DEFAULTS["F"], **p)
    np.testing.assert_allclose(df["osc.x"].to_numpy(), x, rtol=0, atol=1e-9)
    assert abs(df["osc.x"].iloc[0] - p["x0"]) == 0.0


# -- two instances in a ring -----------------------------------------------------------------------------------
KC = 30.0          # coupling gain [N/m]: F_a = -KC * x_b, F_b = -KC * x_a
RING_B = dict(x0=0.0, v0=0.5)


def ring_system(c_fmu, unit_conversion=True):
    from harness.model import Connection, Instance

    return _system([Instance("a", fmu=str(c_fmu)), Instance("b", fmu=str(c_fmu), parameters=dict(RING_B))],
                   [Connection("a.x", "b.F", factor=-KC, unit_conversion=unit_conversion),
                    Connection("b.x", "a.F", factor=-KC, unit_conversion=unit_conversion)], name="ring")


def ring_exact(t):
    """Exact solution of the monolithic coupled system z' = A z, z = (x_a, v_a, x_b, v_b)."""
    from scipy.linalg import expm

    m, k, d = DEFAULTS["m"], DEFAULTS["k"], DEFAULTS["d"]
    A = np.array([[0, 1, 0, 0], [-k / m, -d / m, -KC / m, 0], [0, 0, 0, 1], [-KC / m, 0, -k / m, -d / m]])
    z0 = np.array([DEFAULTS["x0"], DEFAULTS["v0"], RING_B["x0"], RING_B["v0"]])
    return np.array([expm(A * ti) @ z0 for ti in t])


def _ring_error(df):
    z = ring_exact(df.index.to_numpy())
    cols = ["a.x", "a.v", "b.x", "b.v"]
    return float(np.max(np.abs(df[cols].to_numpy() - z)))


def test_ring_needs_declared_unit_conversion(c_fmu):
    from harness.errors import SystemError_

    with pytest.raises(SystemError_, match=r"unit mismatch: a\.x is in m but b\.F is in N"):
        _simulate(ring_system(c_fmu, unit_conversion=False), stop_time=0.1, step=1e-3)


def test_ring_all_masters_complete_and_converge(c_fmu):
    stop, h = 1.0, 2e-3
    errors = {}
    for master in ("jacobi", "gauss-seidel", "iterative"):
        coarse = _simulate(ring_system(c_fmu), stop_time=stop, step=h, master=master)
        fine = _simulate(ring_system(c_fmu), stop_time=stop, step=h / 2, master=master)
        assert coarse.attrs["complete"] and fine.attrs["complete"], master
        assert len(coarse) == round(stop / h) + 1
        errors[master] = (_ring_error(coarse), _ring_error(fine))
    for master, (e1, e2) in errors.items():
        # zero-order hold coupling is first order in h (iterative with order 0 = implicit coupling, also
        # first order): halving h roughly halves the error (measured: 1.1e-2 at h = 2e-3, speeds dominate)
        assert e1 < 2e-2, (master, e1)
        assert 1.6 < e1 / e2 < 2.4, (master, e1, e2)


def test_ring_iterative_matches_fine_jacobi(c_fmu):
    """Iterative (implicit coupling, extrapolation 1 => trapezoidal, second order) at h vs jacobi at h/20:
    both approximate the same coupled system; the positions may differ by 1e-4 m (amplitude 0.1 m; measured
    ~5e-5, dominated by the first-order error of jacobi at h/20)."""
    stop, h = 1.0, 2e-3
    it = _simulate(ring_system(c_fmu), stop_time=stop, step=h, master="iterative", extrapolation=1)
    jac = _simulate(ring_system(c_fmu), stop_time=stop, step=h / 20, master="jacobi")
    jac_on_grid = jac.loc[jac.index.to_numpy()[::20]]
    np.testing.assert_allclose(jac_on_grid.index.to_numpy(), it.index.to_numpy(), rtol=0, atol=1e-12)
    diff = np.max(np.abs(it[["a.x", "b.x"]].to_numpy() - jac_on_grid[["a.x", "b.x"]].to_numpy()))
    assert diff < 1e-4, diff
    # and the iterative (second order) result is much closer to the exact solution than jacobi at the same h
    assert _ring_error(it) < 1e-4
    jac_h = _simulate(ring_system(c_fmu), stop_time=stop, step=h, master="jacobi")
    assert _ring_error(it) < 0.1 * _ring_error(jac_h)


# -- rollback ----------------------------------------------------------------------------------------------------
def test_iterative_master_rolls_back_the_c_fmu(c_fmu, monkeypatch):
    from harness import fmu as hfmu

    calls = {"get": 0, "set": 0}
    get_state, set_state = hfmu.FMU.get_state, hfmu.FMU.set_state

    def counting_get(self, state=None):
        calls["get"] += 1
        return get_state(self, state)

    def counting_set(self, state):
        calls["set"] += 1
        return set_state(self, state)

    monkeypatch.setattr(hfmu.FMU, "get_state", counting_get)
    monkeypatch.setattr(hfmu.FMU, "set_state", counting_set)
    df = _simulate(ring_system(c_fmu), stop_time=0.2, step=2e-3, master="iterative")
    steps, evaluations = df.attrs["steps"], df.attrs["iterations"]
    assert steps == 100 and evaluations > 2 * steps  # the coupled steps really iterate
    assert calls["get"] == 2 * steps                 # one snapshot of both instances per step
    assert calls["set"] == 2 * (evaluations - steps)  # every evaluation but the first restores both


def test_get_set_fmu_state_is_bit_exact(c_fmu):
    from harness.fmu import FMU

    f = FMU(c_fmu, "direct")
    try:
        f.setup(0.0, 1.0)
        f.enter_initialization()
        f.exit_initialization()
        out, inp = f.reals(["x", "v"]), f.reals(["F"])
        f.set(inp, [2.0])
        f.do_step(0.0, 0.01)
        s = f.get_state()
        f.do_step(0.01, 0.01)
        first = f.get(out).copy()
        f.set(inp, [-5.0])
        f.do_step(0.02, 0.03)
        moved = f.get(out).copy()
        f.set_state(s)            # back to t = 0.01 with F = 2
        f.do_step(0.01, 0.01)
        again = f.get(out).copy()
        assert np.array_equal(first, again) and not np.array_equal(first, moved)
        f.get_state(s)            # overwrite the saved state in place (t = 0.02)
        f.do_step(0.02, 0.01)
        f.set_state(s)
        f.do_step(0.02, 0.01)     # the FMU's time was restored too, else this step is refused
        f.free_state(s)
    finally:
        f.terminate()
        f.free()


def test_a_c_fmu_always_runs_through_fmi(c_fmu):
    """The in-process path is for pythonfmu FMUs only: asking for it everywhere still calls the C FMU's library."""
    from harness.fmu import FMU, open_instance

    for in_process in (None, True, False):
        fmu = open_instance(c_fmu, f"osc_{in_process}", in_process=in_process)
        assert isinstance(fmu, FMU) and fmu.path_kind == "fmi"
        fmu.free()
