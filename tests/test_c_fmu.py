"""The master runs ANY FMI 2.0 co-simulation FMU, not only the toolkit's pythonfmu FMUs.

tests/c_fmu/oscillator.c is a hand-written C FMU (damped mass-spring oscillator, m x'' = F - k x - d x',
input F [N], outputs x [m], v [m/s]); the session fixtures compile it with gcc against the FMI 2.0 headers
that fmpy ships and zip it with tests/c_fmu/modelDescription.xml into an .fmu (skipped if gcc is missing or
the compilation fails), twice: ``c_fmu`` (oscillator.fmu, F held over a step) and ``c_fmu_interp``
(oscillator_interp.fmu, built with -DINTERPOLATE_INPUTS: canInterpolateInputs, F follows the polynomial that
fmi2SetRealInputDerivatives describes).  Checked here:

* fmpy's validation of both FMUs reports no problems;
* a single instance through harness.simulate agrees with fmpy.simulate_fmu to 1e-12 on the same grid, and
  both agree with the closed-form solution (independent reference);
* two instances coupled in a ring (x of one -> F of the other, factor -k_c) run with jacobi, gauss-seidel and
  iterative; every result is compared with the exact solution of the coupled linear system (matrix
  exponential) and the iterative result with a jacobi run at a 10x smaller step;
* the iterative master rolls the C FMU back with fmi2GetFMUstate/fmi2SetFMUstate, bit-exactly;
* input derivatives (the master's path for FMUs with canInterpolateInputs): the FMU follows F + dF tau +
  ddF tau^2 / 2 for one step (exact solution) and rolls the derivatives back; jacobi sends the derivatives of its
  extrapolation polynomial (checked against the FMU's log); the ring converges with the orders that theory gives
  (also against the FMU that holds its input), and the iterative master sends no derivatives.
"""
from __future__ import annotations

import functools
import math
import os
import re
import subprocess
import warnings
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent / "c_fmu"
GUID = "{6f1c3a52-9d0e-4b7a-8c21-0b5e3f7d9a41}"
GUID_INTERP = "{b2d7e9c4-58a1-4f63-9e0d-7c3a1f5b8e26}"  # MODEL_GUID of oscillator.c with -DINTERPOLATE_INPUTS
DEFAULTS = dict(m=1.0, k=100.0, d=0.5, x0=0.1, v0=0.0, F=1.0)  # start values in modelDescription.xml


def interp_model_description(text: str) -> str:
    """The model description of the interpolating build: the default one with its own GUID and
    modelIdentifier, canInterpolateInputs="true" and F's description (each replaced exactly once)."""
    for old, new in ((GUID, GUID_INTERP),
                     ('modelIdentifier="oscillator"', 'modelIdentifier="oscillator_interp"'),
                     ('canInterpolateInputs="false"', 'canInterpolateInputs="true"'),
                     ("(held constant over a communication step)",
                      "(F + dF*tau + ddF*tau^2/2 over a step, derivatives from fmi2SetRealInputDerivatives)")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text


@pytest.fixture(scope="session")
def _c_build(tmp_path_factory) -> tuple[str, Path, Path]:
    """(C compiler, FMI 2.0 headers of fmpy, output folder); without them the tests fail (tests/build_cache.py)."""
    import fmpy

    from build_cache import compiler

    headers = Path(os.path.dirname(fmpy.__file__)) / "c-code"
    if not (headers / "fmi2Functions.h").is_file():
        pytest.fail(f"fmpy ships no FMI 2.0 headers at {headers}: cannot compile the C test FMU", pytrace=False)
    return compiler(), headers, tmp_path_factory.mktemp("c_fmu")


def _pack(build, identifier: str, model_description: str, defines=()) -> Path:
    """tests/c_fmu/oscillator.c compiled (with ``-D`` ``defines``) and packed as <identifier>.fmu; the
    compiler's messages go to <identifier>.warnings.txt next to it."""
    gcc, headers, out = build
    binary = out / identifier / f"{identifier}.so"
    binary.parent.mkdir(parents=True)
    cmd = [gcc, "-shared", "-fPIC", "-O2", "-Wall", "-Wextra", *(f"-D{d}" for d in defines), f"-I{headers}",
           str(HERE / "oscillator.c"), "-o", str(binary), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.fail(f"compiling oscillator.c failed: {proc.stderr.strip()[-600:]}", pytrace=False)
    fmu = out / f"{identifier}.fmu"
    fmu.with_suffix(".warnings.txt").write_text(proc.stderr)
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", model_description)
        z.write(binary, f"binaries/linux64/{identifier}.so")
        z.write(HERE / "oscillator.c", "sources/oscillator.c")
    return fmu


@pytest.fixture(scope="session")
def c_fmu(_c_build) -> Path:
    """tests/c_fmu compiled and packed as oscillator.fmu (inputs held over a step) in a temporary folder."""
    return _pack(_c_build, "oscillator", (HERE / "modelDescription.xml").read_text())


@pytest.fixture(scope="session")
def c_fmu_interp(_c_build) -> Path:
    """The same source built with -DINTERPOLATE_INPUTS as oscillator_interp.fmu (canInterpolateInputs)."""
    return _pack(_c_build, "oscillator_interp", interp_model_description((HERE / "modelDescription.xml").read_text()),
                 ["INTERPOLATE_INPUTS"])


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
BUILDS = pytest.mark.parametrize("build, guid, interpolates", [("c_fmu", GUID, False),
                                                               ("c_fmu_interp", GUID_INTERP, True)],
                                 ids=["default", "interp"])


@BUILDS
def test_compiles_without_warnings(request, build, guid, interpolates):
    text = request.getfixturevalue(build).with_suffix(".warnings.txt").read_text()
    assert text.strip() == "", text


@BUILDS
def test_fmpy_validate_reports_no_problems(request, build, guid, interpolates):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    fmu = request.getfixturevalue(build)
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.guid == guid
    assert md.coSimulation.canGetAndSetFMUstate
    assert md.coSimulation.canInterpolateInputs is interpolates
    assert md.coSimulation.maxOutputDerivativeOrder == 0
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
RING_B_REST = dict(x0=0.05, v0=0.0)  # b starts at rest too: both inputs start with dF/dt = -KC * v0 = 0


def ring_system(c_fmu, unit_conversion=True, b=RING_B):
    from harness.model import Connection, Instance

    return _system([Instance("a", fmu=str(c_fmu)), Instance("b", fmu=str(c_fmu), parameters=dict(b))],
                   [Connection("a.x", "b.F", factor=-KC, unit_conversion=unit_conversion),
                    Connection("b.x", "a.F", factor=-KC, unit_conversion=unit_conversion)], name="ring")


def ring_matrix() -> np.ndarray:
    """A of the monolithic coupled system z' = A z, z = (x_a, v_a, x_b, v_b)."""
    m, k, d = DEFAULTS["m"], DEFAULTS["k"], DEFAULTS["d"]
    return np.array([[0, 1, 0, 0], [-k / m, -d / m, -KC / m, 0], [0, 0, 0, 1], [-KC / m, 0, -k / m, -d / m]])


def ring_start(b=RING_B) -> np.ndarray:
    return np.array([DEFAULTS["x0"], DEFAULTS["v0"], b["x0"], b["v0"]])


def ring_exact(t, b=RING_B):
    """Exact solution of the monolithic coupled system z' = A z, z = (x_a, v_a, x_b, v_b)."""
    from scipy.linalg import expm

    A, z0 = ring_matrix(), ring_start(b)
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


# -- input derivatives: the interpolating build ------------------------------------------------------------------
@contextmanager
def _running(fmu_path, name="direct"):
    """An FMU instance of ``fmu_path`` in step mode at t = 0 (terminated and freed afterwards)."""
    from harness.fmi.fmu import FMU

    f = FMU(fmu_path, name)
    try:
        f.setup(0.0, 1.0)
        f.enter_initialization()
        f.exit_initialization()
        yield f
    finally:
        f.terminate()
        f.free()


def _set_derivatives(f, ders) -> None:
    """fmi2SetRealInputDerivatives of F: ders[0] of order 1, ders[1] of order 2, ..."""
    for order, d in enumerate(ders, start=1):
        f.set_input_derivatives(f.reals(["F"]), order, [d])


def _step(f, t, h, ders=()):
    """Set the derivatives ``ders`` of F (if any), take the step, return (x, v)."""
    _set_derivatives(f, ders)
    f.do_step(t, h)
    return f.get(f.reals(["x", "v"])).copy()


def test_input_derivatives_are_refused_where_not_supported(c_fmu, c_fmu_interp):
    from harness.errors import FMUError

    with _running(c_fmu) as f, pytest.raises(FMUError, match="canInterpolateInputs is false"):
        f.set_input_derivatives(f.reals(["F"]), 1, [1.0])
    for var, order, message in (("F", 3, "order 3 of F is not supported: must be 1 or 2"),
                                ("F", 0, "order 0 of F is not supported: must be 1 or 2"),
                                ("x", 1, r"x is not an input \(only F has derivatives\)"),
                                ("m", 2, "m is not an input")):
        with _running(c_fmu_interp) as f, pytest.raises(FMUError, match=message):
            f.set_input_derivatives(f.reals([var]), order, [1.0])


def test_interpolating_fmu_follows_the_input_polynomial_for_one_step(c_fmu_interp):
    """Over a step the force is F + dF tau + ddF tau^2 / 2: against the exact solution of the oscillator with that
    force (matrix exponential of the system augmented with F, dF, ddF).  The derivatives apply to that step only
    (the next step holds F unless they are set again) and a rollback restores them, bit for bit."""
    from scipy.linalg import expm

    m, k, d = DEFAULTS["m"], DEFAULTS["k"], DEFAULTS["d"]
    F, ders, h = 2.0, (40.0, -300.0), 0.01
    A = np.zeros((5, 5))
    A[0, 1], A[1, :3], A[2, 3], A[3, 4] = 1.0, (-k / m, -d / m, 1.0 / m), 1.0, 1.0   # z = (x, v, F, dF, ddF)
    exact = (expm(A * h) @ [DEFAULTS["x0"], DEFAULTS["v0"], F, *ders])[:2]
    with _running(c_fmu_interp) as f:
        f.set(f.reals(["F"]), [F])
        _set_derivatives(f, ders)
        s = f.get_state()                 # the derivatives belong to the state
        first = _step(f, 0.0, h)
        held = _step(f, h, h)             # no derivatives set: F is held
        f.set_state(s)
        assert np.array_equal(_step(f, 0.0, h), first)
        assert np.array_equal(_step(f, h, h, ders=(0.0, 0.0)), held)
        f.set_state(s)
        _step(f, 0.0, h)
        again = _step(f, h, h, ders=ders)
        f.free_state(s)
    np.testing.assert_allclose(first, exact, rtol=0, atol=1e-11)
    held_exact = (expm(A * h) @ [*exact, F, 0.0, 0.0])[:2]   # F kept its value, the derivatives are 0
    np.testing.assert_allclose(held, held_exact, rtol=0, atol=1e-11)
    assert np.max(np.abs(again - held)) > 1e-4   # the derivatives do matter


LOGGED = re.compile(r"fmi2SetRealInputDerivatives: t = (\S+), F order (\d) = (\S+)")


def _kept_logs(monkeypatch) -> dict[str, list[str]]:
    """Instance name -> the messages its FMU logged, kept when the run frees the instance."""
    from harness.fmi import fmu as hfmu

    logs: dict[str, list[str]] = {}
    free = hfmu.FMU.free

    def keeping_free(self):
        logs[self.name] = [text for _status, text in self.log]
        free(self)

    monkeypatch.setattr(hfmu.FMU, "free", keeping_free)
    return logs


@pytest.mark.parametrize("order", [0, 1, 2])
def test_jacobi_sets_the_derivatives_of_the_extrapolation_polynomial(c_fmu_interp, order, monkeypatch):
    """What the FMU received (its log) against derivatives of the source signal computed here: at each step start
    t_n the polynomial through the newest min(n, order) + 1 samples of F = -KC x_source (fewer at the start),
    differentiated at t_n.  Extrapolation 0 sends no derivatives."""
    import numpy.polynomial.polynomial as P

    logs = _kept_logs(monkeypatch)
    h, n = 1e-2, 6
    df = _simulate(ring_system(c_fmu_interp), stop_time=n * h, step=h, master="jacobi", extrapolation=order)
    t = df.index.to_numpy()
    for target, source in (("a", "b"), ("b", "a")):
        F = -KC * df[f"{source}.x"].to_numpy()
        want = []  # (t, order, value) in the order of the calls
        for i in range(n):
            first = max(0, i - order)
            c = P.polyfit(t[first:i + 1] - t[i], F[first:i + 1], i - first)
            want += [(t[i], k, P.polyval(0.0, P.polyder(c, k))) for k in range(1, order + 1)]
        got = np.array(LOGGED.findall("\n".join(logs[target])), dtype=float).reshape(-1, 3)
        want = np.array(want).reshape(-1, 3)
        assert got.shape == want.shape and np.array_equal(got[:, 1], want[:, 1]), (target, got)
        np.testing.assert_allclose(got[:, ::2], want[:, ::2], rtol=1e-9, atol=1e-9)  # times, values


# convergence of the ring: global error at the end, in the energy norm of the undamped ring (it does not vanish
# where the error passes from positions to speeds, as a single component does), for three steps halving
STOP, STEPS = 1.0, (5e-3, 2.5e-3, 1.25e-3)
STARTS = {"moving": RING_B, "rest": RING_B_REST}


def energy_norm(e) -> float:
    """sqrt(2 * energy) of a state error e = (x_a, v_a, x_b, v_b) of the ring without damping."""
    k, m = DEFAULTS["k"], DEFAULTS["m"]
    ex, ev = np.asarray(e)[[0, 2]], np.asarray(e)[[1, 3]]
    return float(np.sqrt(ex @ np.array([[k, KC], [KC, k]]) @ ex + m * ev @ ev))


@functools.cache
def _ring_run(fmu: Path, step: float, extrapolation: int, start: str):
    return _simulate(ring_system(fmu, b=STARTS[start]), stop_time=STOP, step=step, master="jacobi",
                     extrapolation=extrapolation)


def _end_errors(fmu: Path, extrapolation: int, start: str) -> np.ndarray:
    errors = []
    for h in STEPS:
        df = _ring_run(fmu, h, extrapolation, start)
        assert df.index[-1] == STOP
        errors.append(energy_norm(df[["a.x", "a.v", "b.x", "b.v"]].to_numpy()[-1]
                                  - ring_exact([STOP], STARTS[start])[0]))
    return np.array(errors)


def _order(errors) -> float:
    """Slope of log(error) over log(step) (least squares)."""
    return float(np.polyfit(np.log(STEPS), np.log(errors), 1)[0])


@pytest.mark.parametrize("extrapolation, start, with_derivatives, held", [
    (0, "rest", 1, 1),
    (1, "rest", 2, 2),
    (2, "rest", 3, 2),
    (2, "moving", 2, 2),
])
def test_ring_convergence_order_with_input_derivatives(c_fmu, c_fmu_interp, extrapolation, start,
                                                       with_derivatives, held):
    """Jacobi, global error at the end against the exact solution of the coupled system.

    Theory: over a step the polynomial of degree k through the newest k + 1 samples misses the source by
    O(h^(k+1)).  An FMU that follows it (input derivatives) then makes a local error O(h^(k+2)), globally
    O(h^(k+1)): orders 1, 2, 3 for k = 0, 1, 2.  An FMU that holds a constant (the polynomial at the step
    midpoint) misses the source's slope over the step: position error O(h^3) per step whatever k >= 1, so at most
    order 2.  Both are limited by the start: the first step has one sample (a hold of the start value) and misses
    F by tau * dF/dt(0), a velocity error h^2 dF/dt(0) / (2 m) carried to the end: order 2 unless
    dF/dt(0) = -KC v0(source) = 0.  So with b moving at the start the ring is of order 2 with extrapolation 2,
    starting at rest of order 3.  With extrapolation 0 the master sends no derivatives and the interpolating FMU
    gives the same result bit for bit."""
    interp, hold = _end_errors(c_fmu_interp, extrapolation, start), _end_errors(c_fmu, extrapolation, start)
    assert abs(_order(interp) - with_derivatives) < 0.3, interp
    assert abs(_order(hold) - held) < 0.3, hold
    if extrapolation == 0:
        for h in STEPS:
            assert _ring_run(c_fmu_interp, h, 0, start).equals(_ring_run(c_fmu, h, 0, start))
    if with_derivatives > held:
        assert np.all(interp < hold), (interp, hold)


def linear_extrapolation_error_constant(b, held: bool) -> float:
    """C of the global error C h^2 at STOP (energy norm) of jacobi with extrapolation 1, from a local error analysis
    (independent of the master; for a start with dF/dt(0) = 0, else the first step adds an O(h^2) error).

    On a step [t, t + h] the line through the samples at t - h and t misses the source F = -KC x_other by
    -(F''/2) (tau^2 + h tau).  An FMU that follows the line (input derivatives) makes the velocity error
    -(5/12) F'' h^3 / m and a position error O(h^4); an FMU that holds the line's midpoint value makes the same
    velocity error and, as it misses the slope, the position error F' h^3 / (12 m).  The propagated local errors
    add up to e(STOP) = h^2 E(STOP) with E' = A E + G z, E(0) = 0, z' = A z: one augmented linear system."""
    from scipy.linalg import expm

    A, m = ring_matrix(), DEFAULTS["m"]
    G = np.zeros((4, 4))
    for i, j in ((0, 2), (2, 0)):  # the instance with state (z[i], z[i+1]) is fed by F = -KC z[j]
        G[i + 1] = 5.0 / 12.0 * KC / m * A[j + 1]  # -(5/12) F'' / m with F'' = -KC (A z)[j + 1]
        if held:
            G[i, j + 1] = -KC / (12.0 * m)         # F' / (12 m) with F' = -KC z[j + 1]
    M = np.block([[A, G], [np.zeros((4, 4)), A]])
    return energy_norm((expm(M * STOP) @ np.r_[np.zeros(4), ring_start(b)])[:4])


def test_ring_linear_extrapolation_error_constants(c_fmu, c_fmu_interp):
    """Extrapolation 1: both FMUs are of order 2 and their error constants are the local error analysis' (2 %).
    Following the line is not more accurate than holding its midpoint value here: the held FMU's position error
    partly cancels the velocity error both make, so its constant is the smaller one."""
    for fmu, held in ((c_fmu_interp, False), (c_fmu, True)):
        errors = _end_errors(fmu, 1, "rest")
        np.testing.assert_allclose(errors / np.square(STEPS), linear_extrapolation_error_constant(RING_B_REST, held),
                                   rtol=0.02)


# -- rollback ----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("build", ["c_fmu", "c_fmu_interp"])
def test_iterative_master_rolls_back_the_c_fmu(request, build, monkeypatch):
    from harness.fmi import fmu as hfmu

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
    df = _simulate(ring_system(request.getfixturevalue(build)), stop_time=0.2, step=2e-3, master="iterative")
    steps, evaluations = df.attrs["steps"], df.attrs["iterations"]
    assert steps == 100 and evaluations > 2 * steps  # the coupled steps really iterate
    assert calls["get"] == 2 * steps                 # one snapshot of both instances per step
    assert calls["set"] == 2 * (evaluations - steps)  # every evaluation but the first restores both


def test_iterative_master_sends_no_input_derivatives(c_fmu, c_fmu_interp, monkeypatch):
    """The iterative master converges held (midpoint) values and sets no input derivatives (Iterative.__init__):
    the interpolating FMU then holds its input as the default build does, and the runs agree bit for bit."""
    logs = _kept_logs(monkeypatch)
    held, interp = (_simulate(ring_system(f), stop_time=0.2, step=2e-3, master="iterative", extrapolation=2)
                    for f in (c_fmu, c_fmu_interp))
    assert interp.attrs["complete"] and interp.attrs["iterations"] == held.attrs["iterations"]
    assert interp.equals(held)
    assert set(logs) == {"a", "b"} and not any(LOGGED.search(text) for texts in logs.values() for text in texts)


def test_get_set_fmu_state_is_bit_exact(c_fmu):
    with _running(c_fmu) as f:
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


def test_a_c_fmu_always_runs_through_fmi(c_fmu):
    """The in-process path is for pythonfmu FMUs only: asking for it everywhere still calls the C FMU's library."""
    from harness.fmi import FMU, open_instance

    for in_process in (None, True, False):
        fmu = open_instance(c_fmu, f"osc_{in_process}", in_process=in_process)
        assert isinstance(fmu, FMU) and fmu.path_kind == "fmi"
        fmu.free()


def test_ring_jacobian_master_reaches_the_trapezoidal_fixed_point(c_fmu):
    """A foreign C FMU under the interface-Jacobian master (Jacobians by rollback and perturbation): no power
    bonds, so the fixed point is the trapezoid, which the iterative master reaches by iterating to 1e-13;
    the single Newton correction of a linear pair lands on it, and stays second order."""
    from harness.master import IterationOptions
    from harness.run import RunOptions

    stop, h = 1.0, 2e-3
    it = _simulate(ring_system(c_fmu), stop_time=stop, step=h, master="iterative", extrapolation=1,
                   options=RunOptions(iteration=IterationOptions(method="newton", tolerance=1e-13)))
    ij = _simulate(ring_system(c_fmu), stop_time=stop, step=h, master="jacobian", extrapolation=1)
    assert ij.attrs["complete"], ij.attrs.get("error")
    cols = ["a.x", "a.v", "b.x", "b.v"]
    np.testing.assert_allclose(ij[cols].to_numpy(), it[cols].to_numpy(), rtol=0, atol=1e-9)
    assert _ring_error(ij) < 1e-4
